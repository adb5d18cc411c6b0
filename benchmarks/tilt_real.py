"""The foot's live-filter parameters fitted on the real walks, judged leave-one-walk-out.

    python benchmarks/tilt_real.py [--data DIR]

The per-trial table (paper, live, offline, every real recording) is ``gaitmon lab accuracy
--data DIR``; this script checks the fit behind it. The foot parameters fitted on the walks
(``r_static``, ``r_live_gravity``, with ``live_gravity_hz`` and ``q_angle``): for each walk of
gdins_footprints and xio_closed_loop_walks, the configuration of a small grid best on the other
walks (mean RMS error against the lab's 3-D 6-axis reference, offset removed; only
configurations within the paper's + 1 deg on every BROAD trial), scored on the walk left out
(``gaitmon.lab.loto``), beside the chosen configuration's in-sample figure.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.estimate import estimate_tilt
from gaitmon.dsp.motion_kalman import GaitAwareKalman, SegmentTuning, tuning_for
from gaitmon.lab import datasets
from gaitmon.lab.accuracy import default_data_dir
from gaitmon.lab.loto import loto
from gaitmon.lab.real_tilt import walking_span
from gaitmon.lab.reference import reference_foot_tilt

GRID = {
    "q_angle": (1e-7, 3e-7, 1e-6, 3e-6),
    "r_static": (1e-3, 1e-4),
    "live_gravity_hz": (0.25, 0.4),
    "r_live_gravity": (3e-3, 1e-3),
}
Config = tuple[float, ...]


def _rms(est: np.ndarray, ref: np.ndarray, valid: np.ndarray, offset: bool) -> float:
    e = np.degrees(wrap_angle(est - ref)[valid])
    return float(np.sqrt(np.mean((e - e.mean() if offset else e) ** 2)))


def _live(t: datasets.ImuTrial, tuning: SegmentTuning) -> np.ndarray:
    kf = GaitAwareKalman(t.fs_hz, segments=("foot",), tuning={"foot": tuning})
    gy = t.gyro_y - datasets.gyro_bias_at_start(t)
    return np.asarray(kf.process(t.acc_x, t.acc_z, gy)).ravel()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=default_data_dir())
    args = p.parse_args()
    if args.data is None:
        raise SystemExit("no ../shared/data; give --data DIR")
    base = tuning_for("foot")
    configs = {v: dataclasses.replace(base, **dict(zip(GRID, v, strict=True)))
               for v in itertools.product(*GRID.values())}  # fmt: skip
    broad = datasets.read_broad(args.data)
    paper = {}
    for t in broad:
        gy = t.gyro_y - datasets.gyro_bias_at_start(t)
        assert t.ref_tilt_rad is not None and t.ref_valid is not None
        est = estimate_tilt(t.acc_x, t.acc_z, gy, t.fs_hz, method="paper")
        paper[t.name] = _rms(est, t.ref_tilt_rad, t.ref_valid, False)
    allowed = [c for c, tun in configs.items() if all(
        _rms(_live(t, tun), t.ref_tilt_rad, t.ref_valid, False) <= paper[t.name] + 1.0  # type: ignore[arg-type]
        for t in broad)]  # fmt: skip
    walks = datasets.read_gdins(args.data) + datasets.read_xio(args.data)
    scores: dict[str, dict[Config, float]] = {}
    for t in walks:
        ref = reference_foot_tilt(t)
        a, b = walking_span(t)
        valid = np.isfinite(ref)
        valid[:a] = valid[b:] = False
        scores[t.name] = {c: _rms(_live(t, configs[c]), ref, valid, True) for c in allowed}

    def fit(trials: Sequence[str]) -> Config:
        return min(allowed, key=lambda c: float(np.mean([scores[k][c] for k in trials])))

    names = list(scores)
    held = loto(names, fit, lambda k, c: scores[k][c])
    chosen = tuple(getattr(base, k) for k in GRID)
    print(f"leave-one-walk-out over {len(allowed)} of {len(configs)} configurations "
          f"({', '.join(GRID)}; the rest: worse than the paper's on a BROAD trial):")  # fmt: skip
    for k, h in zip(names, held, strict=True):
        own = scores[k].get(chosen, np.nan)
        print(f"  {k:<12} held out {h:5.2f} deg   (chosen {chosen}: {own:5.2f})")
    inside = [scores[k].get(chosen, np.nan) for k in names]
    print(f"median held out {np.median(held):.2f} deg; in-sample with the chosen: "
          f"{np.median(inside):.2f} deg")  # fmt: skip


if __name__ == "__main__":
    main()
