"""Throughput of the gait-event detector and stride tracker on an 8-hour synthetic record.

Prints samples/s for one whole-record call and for streaming in 10-sample (100 ms) blocks.
Run: python benchmarks/bench_gait.py
"""

from __future__ import annotations

import time

import numpy as np

from gaitmon.dsp.gait import GaitEventDetector, StrideTracker, strides_from_events

FS_HZ = 100.0
N_SAMPLES = int(8 * 3600 * FS_HZ)  # 8 hours


def synthetic_fsr(n: int, seed: int = 0) -> np.ndarray:
    """Heel and toe loaded for 60 % of a 1.1 s stride, toe lagging the heel, plus noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS_HZ
    ph = (t / 1.1) % 1.0
    heel = np.where(ph < 0.45, 2500.0, 100.0)
    toe = np.where((ph > 0.1) & (ph < 0.6), 2200.0, 100.0)
    return np.column_stack([heel, toe]) + rng.normal(0.0, 30.0, (n, 2))


def best_of(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    fsr = synthetic_fsr(N_SAMPLES)
    det = GaitEventDetector()

    def detect() -> None:
        det.reset()
        det.process(fsr)

    t_det = best_of(detect)
    det.reset()
    blk = det.process(fsr)
    t_strides = best_of(lambda: strides_from_events(blk.heel_strike_idx, blk.toe_off_idx, FS_HZ))
    n_strides = len(strides_from_events(blk.heel_strike_idx, blk.toe_off_idx, FS_HZ))
    print(f"8 h record, {N_SAMPLES:,} samples, {n_strides:,} strides")
    print(
        f"GaitEventDetector, one call:       {t_det * 1e3:8.1f} ms  "
        f"{N_SAMPLES / t_det / 1e6:6.1f} M samples/s"
    )
    print(f"strides_from_events, one call:     {t_strides * 1e3:8.1f} ms")

    block = 10
    n_stream = 360_000  # one hour in 10-sample blocks keeps the benchmark short
    tracker = StrideTracker(FS_HZ)

    def streamed() -> None:
        det.reset()
        tracker.reset()
        for i in range(0, n_stream, block):
            b = det.process(fsr[i : i + block])
            tracker.process(b.heel_strike_idx, b.toe_off_idx)

    t_stream = best_of(streamed, repeat=1)
    us_per_block = t_stream / (n_stream / block) * 1e6
    print(
        f"streaming {block}-sample blocks:        {us_per_block:8.1f} us/block "
        f"{n_stream / t_stream / 1e6:6.2f} M samples/s (detector + StrideTracker)"
    )


if __name__ == "__main__":
    main()
