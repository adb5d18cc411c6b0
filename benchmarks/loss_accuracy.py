"""Lost frames against the live joint angles: how much worse the pipeline reads when frames go
missing on the link, against the same recording with nothing lost (issue 24, "lost frames are
time").

A simulated walk (seeded, ground truth known) is zeroed on its standing start and run through
the live :class:`~gaitmon.dsp.pipeline.Pipeline` with and without seeded frame loss; the rows that
arrive are given with ``lost_before`` as the recorder gives them. Printed per loss scenario: the
live (causal) and the offline (smoothed, as a file's ``/smoothed``) hip / knee / ankle RMSE
(deg) against the simulator's truth over the walking rows that arrived, and the worst joint's
ratio to the loss-free run; plus the stride count and the
mean |error| of the stride times against the true time between their heel-strike rows.

    python benchmarks/loss_accuracy.py [--seeds 3] [--seconds 120] [--method gait-aware]
"""

from __future__ import annotations

import argparse

import numpy as np

from gaitmon.dsp import pipeline
from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.channels import DEFAULT_TABLE
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.finish.smoothed import smoothed_angles
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

FS = 100.0
WALK_FROM = 1000  # rows: the 5 s standing start and the first strides are left out of the RMSE
# (name, fraction of frames lost, shortest and longest burst in frames)
SCENARIOS = (
    ("no loss", 0.0, 1, 1),
    ("1 % single", 0.01, 1, 1),
    ("2 % single", 0.02, 1, 1),
    ("5 % single", 0.05, 1, 1),
    ("2 % bursts 2-5", 0.02, 2, 5),
    ("5 % bursts 2-5", 0.05, 2, 5),
    ("1 % bursts 6-10", 0.01, 6, 10),
    ("1 % bursts 11-20", 0.01, 11, 20),
)


def lost_frames(n: int, frac: float, lo: int, hi: int, rng: np.random.Generator) -> np.ndarray:
    """Which of n frames are lost: bursts of lo..hi frames (separated by at least one frame that
    arrives), started at random until about ``frac`` of the frames are lost."""
    lost = np.zeros(n, dtype=bool)
    target = round(frac * n)
    while lost.sum() < target:
        k = int(rng.integers(lo, hi + 1))
        a = int(rng.integers(WALK_FROM // 2, n - k - 1))
        if not lost[max(a - 1, 0) : a + k + 1].any():
            lost[a : a + k] = True
    return lost


def run(
    counts: np.ndarray, lost: np.ndarray, config: PipelineConfig, cal_rows: slice
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]:
    """Rows kept, their live and their offline (smoothed, ``gaitmon.finish.smoothed``) joint
    angles (rad), and each stride's time error (s) against the true time between its
    heel-strike rows."""
    first = Pipeline(config).process(counts[cal_rows])
    cal = standing_calibration(first.acc_ms2, first.gyro_rad_s)
    keep = np.flatnonzero(~lost)
    steps = np.diff(np.r_[-1, keep])
    lost_before = steps - 1
    p = Pipeline(config, calibration=cal)
    # live-sized blocks (10 rows), as the engine feeds it
    joints, errs = [], []
    for a in range(0, len(keep), 10):
        b = p.process(counts[keep[a : a + 10]], lost_before[a : a + 10])
        joints.append(b.joint_kalman_rad)
        # the stride time against the true time between the rows its heel strikes are on
        errs.extend(s.stride_time_s - (keep[s.end_idx] - keep[s.start_idx]) / FS
                    for s in b.strides)  # fmt: skip
    smoothed = smoothed_angles(counts[keep], DEFAULT_TABLE, cal, [], lost_before, FS)
    offline = np.radians(smoothed["smoothed/joint_deg"].astype(np.float64))
    return keep, np.concatenate(joints), offline, errs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=120.0)
    ap.add_argument("--method", default="gait-aware", help="tilt method (gait-aware | paper)")
    ap.add_argument("--bridge-s", type=float, default=None,
                    help="measure with another BRIDGE_MAX_S (s) than the pipeline's")
    args = ap.parse_args()
    if args.bridge_s is not None:
        pipeline.BRIDGE_MAX_S = args.bridge_s
    config = PipelineConfig(tilt_method=args.method)
    n = round(args.seconds * FS)
    print(f"live joint RMSE (deg) vs simulator truth, {args.method}, {args.seeds} seeds x "
          f"{args.seconds:g} s, rows from {WALK_FROM / FS:g} s on, bridged losses up to "
          f"{pipeline.BRIDGE_MAX_S:g} s")  # fmt: skip
    print(f"{'':<16} {'live':^34} {'offline (smoothed)':^34}")
    print(f"{'loss':<16} " + f"{'hip':>6} {'knee':>6} {'ankle':>6} {'worst/no loss':>14} " * 2
          + f"{'strides':>8} {'stride time |err| ms':>21}")  # fmt: skip
    sims = []
    for seed in range(args.seeds):
        gait = GaitModel(GaitConfig(seed=100 + seed, cadence_steps_min=110.0))
        sims.append(simulate(n, gait, SensorConfig(seed=100 + seed)))
    base: list[np.ndarray] = []
    for name, frac, lo, hi in SCENARIOS:
        rmse: tuple[list[np.ndarray], list[np.ndarray]] = ([], [])
        n_str, t_err = 0, []
        for seed, sb in enumerate(sims):
            rng = np.random.default_rng(1000 + seed)
            lost = lost_frames(n, frac, lo, hi, rng) if frac else np.zeros(n, dtype=bool)
            keep, live, offline, errs = run(sb.counts, lost, config, slice(100, 450))
            truth = sb.kinematics.joint_rad[keep]
            w = keep >= WALK_FROM
            for out, joint in zip(rmse, (live, offline), strict=True):
                e = np.degrees(wrap_angle(joint[w] - truth[w]))
                out.append(np.sqrt(np.mean(e**2, axis=0)))
            n_str += len(errs)
            t_err.extend(1000.0 * np.asarray(errs))
        cells = []
        for k, per_seed in enumerate(rmse):
            r = np.mean(per_seed, axis=0)
            if len(base) <= k:
                base.append(r)
            ratio = float(np.max(r / base[k]))
            cells.append(f"{r[0]:6.2f} {r[1]:6.2f} {r[2]:6.2f} {ratio:13.2f}x ")
        med = float(np.mean(np.abs(t_err))) if t_err else float("nan")
        print(f"{name:<16} {''.join(cells)}{n_str:8d} {med:21.1f}")

if __name__ == "__main__":
    main()
