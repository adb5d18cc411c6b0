"""``python -m gaitmon.dsp.kernel_fill [LOCK]``: compile every kernel into numba's cache, build
them ahead of time into a module that loads without numba (:mod:`gaitmon.dsp.kernel_aot`), mark
the cache ready for this install (:mod:`gaitmon.dsp.kernel_cache`), then remove ``LOCK``.

Started in the background (:func:`gaitmon.dsp.kernel_cache.start_fill`) by the live window's
first connect and by batch work long enough to want the compiled loops, so that nobody waits
for numba's compile: the interpreted loops serve until the cache is ready.
"""

from __future__ import annotations

import contextlib
import os
import sys

import numpy as np


def compile_all() -> None:
    """Run each kernel once through its real call site, compiled: numba compiles it for the
    argument types gaitmon calls it with (or loads it from the cache)."""
    from gaitmon.dsp import kernels, smoother
    from gaitmon.dsp.channels import DEFAULT_TABLE, GYRO_IDX
    from gaitmon.dsp.iir import LinearFilter, butter_lowpass
    from gaitmon.dsp.motion_kalman import GaitAwareKalman
    from gaitmon.dsp.pipeline import Pipeline

    rng = np.random.default_rng(0)
    n = 64
    ax = 9.81 + 0.1 * rng.standard_normal((n, 4))
    az = 0.1 * rng.standard_normal((n, 4))
    w = 0.1 * rng.standard_normal((n, 4))
    with kernels.use("compiled"):
        first = GaitAwareKalman(100.0).process(ax, az, w)
        smoother.smooth_tilts(ax, az, w, 100.0, first_pass=first)  # the constant solve
        smoother.smooth_map(az[:, 0], w[:, 0], np.full(n, 1e-2), np.full(n, 1e-4), 1e-7, 0.01)
        kernels.running_mean(ax.T.copy(), 5)
        LinearFilter(*butter_lowpass(2, 4.0, 100.0), 4).process(ax)  # (also run by the above)
        # the pipeline's own passes (counts to physical units, the zeroed tilts and joints)
        counts = np.rint(np.tile(DEFAULT_TABLE.zero_counts, (n, 1))).astype(np.uint16)
        Pipeline().process(counts)
        kernels.to_physical(DEFAULT_TABLE, counts, GYRO_IDX)  # (the smoother's columns)
        # the stride measures' pass (a foot standing still between three heel strikes)
        from gaitmon.dsp.stride_length import stride_measures

        still = np.zeros(200)
        stride_measures(still + 9.81, still, still, 100.0, np.array([10, 80, 150]))
    smoother.release_factors()


def build_aot() -> bool:
    """The loops compiled ahead of time (:mod:`gaitmon.dsp.kernel_aot`), with the signatures
    :func:`compile_all` compiled them for; False where they cannot be."""
    from gaitmon.dsp import kernel_aot
    from gaitmon.dsp.kernel_cache import aot_file

    path = aot_file()
    return path is not None and kernel_aot.build(path)


def main(argv: list[str]) -> int:
    from gaitmon.dsp.kernel_cache import mark_ready

    if hasattr(os, "nice"):  # in the background: the live window and the user's work first
        with contextlib.suppress(OSError):
            os.nice(10)
    try:
        compile_all()
        build_aot()
        mark_ready()
    finally:
        if argv:
            with contextlib.suppress(OSError):
                os.remove(argv[0])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
