"""The inner loops of :mod:`gaitmon.dsp.loops` compiled by numba: ``njit`` applied to those very
functions (one source), cached on disk in the user's cache folder
(:func:`gaitmon.dsp.kernel_cache.numba_cache_dir`).

Importing this module imports numba (~0.4 s of CPU and ~55 MB) and compiles nothing yet: a
kernel is compiled, or loaded from numba's cache, on its first call. Only
:mod:`gaitmon.dsp.kernels` imports it, when a job is large enough to pay for that (its module
doc). Never cached beside the package: files pip does not know of, left in an installed
package's ``__pycache__``, outlive its uninstall and hide a later editable install of gaitmon
(``cannot import name '__version__'``).
"""

from __future__ import annotations

import os

from gaitmon.dsp import loops
from gaitmon.dsp.kernel_cache import numba_cache_dir

# numba picks a function's cache folder when it is decorated, from its settings, which it reads
# at import: the environment variable is numba's own setting (child processes inherit it)
os.environ["NUMBA_CACHE_DIR"] = numba_cache_dir()

from numba import njit  # (after the cache folder is set)
from numba.core.config import reload_config

reload_config()  # type: ignore[no-untyped-call]  # (numba may have been imported before)


def _registry_without_blas() -> None:
    """Load numba's numpy registry without scipy.linalg. When its first kernel is loaded,
    numba imports ``numba.np.arraymath``, which imports scipy.linalg (~24 MB of resident
    memory, a fifth of numba's own) only to learn whether ``np.convolve`` and
    ``np.correlate`` may call BLAS; gaitmon's loops call neither, nor anything of BLAS. So
    that check is told "no BLAS" while the module loads, and numba's linear algebra is left as
    it was (it imports scipy.linalg itself if ever compiled). Where scipy.linalg is loaded
    already, or numba's modules are laid out otherwise, nothing changes."""
    import sys

    if "scipy.linalg" in sys.modules or "numba.np.arraymath" in sys.modules:
        return
    try:
        from numba.np import linalg
    except ImportError:
        return
    ensure_blas = getattr(linalg, "ensure_blas", None)
    if ensure_blas is None:
        return

    def no_blas() -> None:
        raise ImportError("gaitmon's compiled loops use no BLAS")

    linalg.ensure_blas = no_blas
    try:
        import numba.np.arraymath  # noqa: F401
    finally:
        linalg.ensure_blas = ensure_blas


_registry_without_blas()

_jit = njit(cache=True, nogil=True)
gait_aware_update = _jit(loops.gait_aware_update)
constant_map_solve = _jit(loops.constant_map_solve)
band_cholesky = _jit(loops.band_cholesky)
band_solve = _jit(loops.band_solve)
running_mean = _jit(loops.running_mean)
lfilter = _jit(loops.lfilter)
physical = _jit(loops.physical)
constant_rhs = _jit(loops.constant_rhs)
zeroed_tilts = _jit(loops.zeroed_tilts)
gravity_average = _jit(loops.gravity_average)
gait_aware_inputs = _jit(loops.gait_aware_inputs)
turned = _jit(loops.turned)
gyro_angle = _jit(loops.gyro_angle)
reduced = _jit(loops.reduced)
stride_pass = _jit(loops.stride_pass)
