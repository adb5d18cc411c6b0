"""Lost frames against the stride lengths and gait speeds (issue 24, "lost frames are time").

A seeded simulated walk is zeroed on its standing start and run through the live
:class:`~gaitmon.dsp.pipeline.Pipeline` with and without seeded random single-frame loss; the
rows that arrive are given with ``lost_before`` as the recorder gives them. The pipeline's heel
strikes (rows) open the strides; their length comes from the foot IMU as a file's
``/strides`` (:func:`gaitmon.dsp.stride_length.record_stride_measures`) and as the live panel
(:class:`~gaitmon.dsp.stride_length.StrideLengthTracker`, blocks of 10 rows) compute them:

- ``rows as frames`` (before): the rows integrated as if they were consecutive frames;
- ``lost filled in`` (now): the bridged losses filled in as the pipeline fills them.

Printed per loss: the median and p95 |error| (% of the simulator's truth) of stride length
and gait speed (length over the stride's true time), the signed median length error, and the
strides matched to a true one.

    python benchmarks/loss_strides.py [--seeds 3] [--seconds 120] [--loss-pct 2] [--data DIR]

With ``--data DIR`` (default: ../shared/data when it is there) it also runs the 16 real
foot-IMU walks of DIR/gdins_footprints with a seeded random single-frame loss: the loss-free
heel strikes (foot gyro, as ``gaitmon lab accuracy``) on the row that arrived at or after
them, and per trial the stride lengths with the rows taken as frames (before) and with the lost
frames filled in (now): the median |change| against the loss-free run (%), and the median
|error| against the measured footprints of the strides the loss-free run matched to one.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, SEGMENTS
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.dsp.stride_length import StrideLengthTracker, StrideMeasures, record_stride_measures
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.kinematics import StrideTruth
from gaitmon.io.sim.sensors import simulate
from gaitmon.lab.accuracy import default_data_dir, match_strides

FS = 100.0
SKIP = 1000  # frames: the standing start and the first strides are left out
FOOT = SEGMENTS.index("foot")


def lost_singles(n: int, frac: float, rng: np.random.Generator) -> np.ndarray:
    """Which of n frames are lost: single frames at random (never two in a row), ~``frac``."""
    lost = np.zeros(n, dtype=bool)
    target = round(frac * n)
    while lost.sum() < target:
        a = int(rng.integers(SKIP // 2, n - 2))
        if not lost[a - 1 : a + 2].any():
            lost[a] = True
    return lost


def measure(
    counts: np.ndarray, lost: np.ndarray, config: PipelineConfig, fill: bool
) -> tuple[np.ndarray, StrideMeasures, StrideMeasures]:
    """Rows kept, and the stride measures of the file and of the live tracker (indices: rows)."""
    first = Pipeline(config).process(counts[100:450])
    cal = standing_calibration(first.acc_ms2, first.gyro_rad_s)
    keep = np.flatnonzero(~lost)
    lost_before = np.diff(np.r_[-1, keep]) - 1
    p = Pipeline(config, calibration=cal)
    tracker = StrideLengthTracker(FS)
    hs: list[np.ndarray] = []
    gyro: list[np.ndarray] = []
    live: list[StrideMeasures] = []
    phys = DEFAULT_TABLE.to_physical(counts[keep])
    ax, az = phys[:, ACC_X_IDX[FOOT]], phys[:, ACC_Z_IDX[FOOT]]
    for a in range(0, len(keep), 10):
        b = p.process(counts[keep[a : a + 10]], lost_before[a : a + 10])
        hs.append(b.heel_strike_idx)
        gyro.append(b.gyro_rad_s[:, FOOT])
        sl = slice(a, a + 10)
        live.append(tracker.push(ax[sl], az[sl], b.gyro_rad_s[:, FOOT], b.heel_strike_idx,
                                 lost_before[sl] if fill else None))  # fmt: skip
    live.append(tracker.finish())
    g = np.concatenate(gyro)
    h = np.concatenate(hs)
    offline = record_stride_measures(lambda a, b: (ax[a:b], az[a:b], g[a:b]), len(keep), FS, h,
                                     lost_before=lost_before if fill else None)  # fmt: skip
    cat = StrideMeasures(*(np.concatenate([getattr(m, f) for m in live]) for f in (
        "heel_strike_idx", "stride_length_m", "foot_clearance_m", "stride_time_s",
        "foot_flat_idx")))  # fmt: skip
    return keep, offline, cat


def errors(
    keep: np.ndarray, m: StrideMeasures, truth: StrideTruth
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """|error| % of length and speed of the strides matched to a true one, and the signed
    length error %. A stride's speed is its length over the true time between its heel-strike
    rows (as the app's strides are timed); the last stride (closing heel strike not known
    here) is left out."""
    frames = keep[m.heel_strike_idx]
    hs, length = frames[:-1], m.stride_length_m[:-1]
    speed = length / (np.diff(frames) / FS)
    e_len, e_speed = match_strides(hs, length, speed, truth, after=SKIP)
    t_hs = truth.heel_strike_idx
    j = np.clip(np.searchsorted(t_hs, hs - 5), 0, len(t_hs) - 1)
    near = (np.abs(t_hs[j] - hs) <= 5) & (hs > SKIP) & np.isfinite(length)
    t = truth.stride_length_m[j[near]]
    return e_len, e_speed, (length[near] - t) / t * 100.0


def real_walks(root: Path, frac: float) -> None:
    """The gdins walks with seeded single-frame loss (module doc)."""
    from gaitmon.dsp import gyro_gait_events, stride_measures
    from gaitmon.lab.datasets import gyro_bias_at_start, read_gdins
    from gaitmon.lab.real_gait import match_footprints

    print(f"\ngdins real walks, {100 * frac:g} % single-frame loss: stride length median "
          "|change| vs the loss-free run (%), median |error| vs the footprints (%)")  # fmt: skip
    print(f"{'trial':<8} {'strides':>7} {'change before':>14} {'change now':>11} "
          f"{'err loss-free':>14} {'err before':>11} {'err now':>8}")  # fmt: skip
    all_b, all_a = [], []
    for i, trial in enumerate(read_gdins(root)):
        fs = trial.fs_hz
        gy = trial.gyro_y - gyro_bias_at_start(trial)
        hs, _ = gyro_gait_events(gy, fs)
        clean = stride_measures(trial.acc_x, trial.acc_z, gy, fs, hs)
        n = len(gy)
        rng = np.random.default_rng(2000 + i)
        lost = np.zeros(n, dtype=bool)
        while lost.sum() < round(frac * n):
            a = int(rng.integers(1, n - 2))
            if not lost[a - 1 : a + 2].any():
                lost[a] = True
        keep = np.flatnonzero(~lost)
        lost_before = np.diff(np.r_[-1, keep]) - 1
        rows = np.unique(np.searchsorted(keep, hs, side="left"))
        rows = rows[rows < len(keep)]
        if len(rows) != len(hs):
            continue
        x, z, g = trial.acc_x[keep], trial.acc_z[keep], gy[keep]
        before = stride_measures(x, z, g, fs, rows).stride_length_m
        now = stride_measures(x, z, g, fs, rows, lost_before=lost_before).stride_length_m
        ref = trial.extra["ref_stride_length"].astype(np.float64)
        j = match_footprints(clean, trial.extra["zv_end_idx"].astype(np.int64), fs)
        hit = j >= 0
        k = j[hit]
        c = clean.stride_length_m

        def med(v: np.ndarray) -> float:
            v = v[np.isfinite(v)]
            return float(np.median(v)) if len(v) else float("nan")

        ch_b = np.abs(before / c - 1) * 100
        ch_a = np.abs(now / c - 1) * 100
        all_b.append(ch_b)
        all_a.append(ch_a)
        errs = [med(np.abs(v[k] / ref[hit] - 1) * 100) for v in (c, before, now)]
        print(f"{trial.name:<8} {int(np.isfinite(c).sum()):>7} {med(ch_b):>14.2f} "
              f"{med(ch_a):>11.2f} {errs[0]:>14.2f} {errs[1]:>11.2f} {errs[2]:>8.2f}")  # fmt: skip
    b, a = np.concatenate(all_b), np.concatenate(all_a)
    print(f"{'all':<8} {int(np.isfinite(b).sum()):>7} {np.nanmedian(b):>14.2f} "
          f"{np.nanmedian(a):>11.2f}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=120.0)
    ap.add_argument("--loss-pct", type=float, default=2.0)
    ap.add_argument("--data", type=Path, default=None, help="real data folder (../shared/data)")
    ap.add_argument("--real-only", action="store_true", help="only the real walks (--data)")
    args = ap.parse_args()
    root = args.data or default_data_dir()
    if args.real_only:
        if root is not None:
            real_walks(root, args.loss_pct / 100.0)
        return
    n = round(args.seconds * FS)
    config = PipelineConfig()
    print(f"stride length / speed |error| (% of the simulator's truth), {args.seeds} seeds x "
          f"{args.seconds:g} s, frames from {SKIP / FS:g} s on; median (p95); signed median "
          "length error; strides matched")  # fmt: skip
    print(f"{'loss':<10} {'strides':<16} {'where':<8} {'length':>14} {'speed':>14} "
          f"{'signed':>8} {'n':>5}")  # fmt: skip
    for frac in (0.0, args.loss_pct / 100.0):
        for fill in (False, True) if frac else (True,):
            res: dict[str, list[np.ndarray]] = {}
            for seed in range(args.seeds):
                gait = GaitModel(GaitConfig(seed=100 + seed, cadence_steps_min=110.0))
                sb = simulate(n, gait, SensorConfig(seed=100 + seed))
                rng = np.random.default_rng(1000 + seed)
                lost = lost_singles(n, frac, rng) if frac else np.zeros(n, dtype=bool)
                keep, offline, live = measure(sb.counts, lost, config, fill)
                truth = gait.strides(0, n)
                for where, m in (("file", offline), ("live", live)):
                    for k, e in enumerate(errors(keep, m, truth)):
                        res.setdefault(f"{where}{k}", []).append(e)
            how = "lost filled in" if fill else "rows as frames"
            for where in ("file", "live"):
                e_len, e_speed, signed = (np.concatenate(res[f"{where}{k}"]) for k in range(3))
                cells = [f"{np.median(e):5.2f} ({np.percentile(e, 95):5.2f})"
                         for e in (e_len, e_speed)]  # fmt: skip
                print(f"{100 * frac:>4.1f} %    {how:<16} {where:<8} {cells[0]:>14} "
                      f"{cells[1]:>14} {np.median(signed):>+8.2f} {len(e_len):>5d}")  # fmt: skip
    if root is not None:
        real_walks(root, args.loss_pct / 100.0)


if __name__ == "__main__":
    main()
