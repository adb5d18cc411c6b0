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

_jit = njit(cache=True, nogil=True)
gait_aware_update = _jit(loops.gait_aware_update)
constant_map_solve = _jit(loops.constant_map_solve)
band_cholesky = _jit(loops.band_cholesky)
band_solve = _jit(loops.band_solve)
running_mean = _jit(loops.running_mean)
lfilter = _jit(loops.lfilter)
