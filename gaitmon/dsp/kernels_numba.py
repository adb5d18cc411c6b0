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
import sys

from gaitmon.dsp import loops
from gaitmon.dsp.kernel_cache import numba_cache_dir

# numba picks a function's cache folder when it is decorated, from its settings, which it reads
# at import: the environment variable is numba's own setting (child processes inherit it)
os.environ["NUMBA_CACHE_DIR"] = numba_cache_dir()

from numba import njit  # (after the cache folder is set)
from numba.core.config import reload_config

reload_config()  # type: ignore[no-untyped-call]  # (numba may have been imported before)


def _registries_without_scipy() -> None:
    """Load numba's registries of compiled functions now, with scipy out of reach.

    numba loads them at its first compiled call (cached or not), and checks there for a BLAS
    by importing scipy.linalg (numba.np.arraymath's ``_check_blas``), which imports scipy's
    array API layer and numpy.f2py: ~0.14 s of CPU and ~12 MB that gaitmon's loops never use
    (they call no BLAS; numba then only refuses np.dot and the like in compiled code, which
    none of them has). Where scipy is imported already, nothing is saved or changed.
    """
    from numba.core.registry import cpu_target

    blocked = next((m for m in ("scipy", "scipy.linalg") if m not in sys.modules), None)
    if blocked is not None:
        sys.modules[blocked] = None  # type: ignore[assignment]  # (import refused: ImportError)
    try:
        cpu_target.target_context.refresh()
    finally:
        if blocked is not None and sys.modules.get(blocked, False) is None:
            del sys.modules[blocked]


_registries_without_scipy()

_jit = njit(cache=True, nogil=True)
gait_aware_update = _jit(loops.gait_aware_update)
constant_map_solve = _jit(loops.constant_map_solve)
band_cholesky = _jit(loops.band_cholesky)
band_solve = _jit(loops.band_solve)
running_mean = _jit(loops.running_mean)
lfilter = _jit(loops.lfilter)
