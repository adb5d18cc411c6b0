"""Lost frames against the live joint angles: how much worse the pipeline reads when frames go
missing on the link, against the same recording with nothing lost (issue 24, "lost frames are
time").

A simulated walk (seeded, ground truth known) is zeroed on its standing start and run through
the live :class:`~gaitmon.dsp.pipeline.Pipeline` with and without seeded frame loss; the rows that
arrive are given with ``lost_before`` as the recorder gives them. Printed per loss scenario: the
live (causal) and the offline (smoothed, as a file's ``/smoothed``) hip / knee / ankle RMSE
(deg) against the simulator's truth over the walking rows that arrived, and the worst joint's
ratio to the loss-free run; plus the stride count and the mean |error| of the stride times
(the engine's strides of the events, ``GaitEvents``, timed on the rows' true times as live and
in a file) against the simulator's true stride times.

    python benchmarks/loss_accuracy.py [--seeds 3] [--seconds 120] [--method gait-aware]
        [--data DIR]

With ``--data DIR`` (default: ../shared/data when it is there) it also runs the real foot-IMU
walks of DIR/gdins_footprints (their foot board in every segment's channels) with and without
a seeded 2 % single-frame loss, and prints per trial how far the live foot tilt with loss is
from the loss-free run (RMS, deg), filling the lost frames in (now) and taking each row as
the next frame (before): there is no reference angle, so this measures what the loss alone
does on real signals.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from gaitmon.dsp import lost_frames as bridging
from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.channels import DEFAULT_TABLE
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.engine.live_gait import GaitEvents
from gaitmon.finish.smoothed import smoothed_angles
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate
from gaitmon.lab.accuracy import default_data_dir

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
    counts: np.ndarray, lost: np.ndarray, config: PipelineConfig, cal_rows: slice,
    true_hs: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]:  # fmt: skip
    """Rows kept, their live and their offline (smoothed, ``gaitmon.finish.smoothed``) joint
    angles (rad), and each stride's time error (s) against the true stride (``true_hs``: the
    simulator's heel strikes, frames) nearest its heel strikes."""
    first = Pipeline(config).process(counts[cal_rows])
    cal = standing_calibration(first.acc_ms2, first.gyro_rad_s)
    keep = np.flatnonzero(~lost)
    steps = np.diff(np.r_[-1, keep])
    lost_before = steps - 1
    p = Pipeline(config, calibration=cal)
    events = GaitEvents(FS)
    # live-sized blocks (10 rows), as the engine feeds it
    joints, errs = [], []
    for a in range(0, len(keep), 10):
        b = p.process(counts[keep[a : a + 10]], lost_before[a : a + 10])
        joints.append(b.joint_kalman_rad)
        for s in events.strides(b.heel_strike_idx, b.toe_off_idx):
            # timed on the rows' true times (frames), against the true stride nearest it
            t0, t1 = keep[s.start_idx], keep[s.end_idx]
            k = int(np.argmin(np.abs(true_hs - t0)))
            if k + 1 < len(true_hs):
                errs.append((t1 - t0 - (true_hs[k + 1] - true_hs[k])) / FS)
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
    ap.add_argument("--data", type=Path, default=None, help="real data folder (../shared/data)")
    args = ap.parse_args()
    if args.bridge_s is not None:
        bridging.BRIDGE_MAX_S = args.bridge_s
    config = PipelineConfig(tilt_method=args.method)
    n = round(args.seconds * FS)
    print(f"live joint RMSE (deg) vs simulator truth, {args.method}, {args.seeds} seeds x "
          f"{args.seconds:g} s, rows from {WALK_FROM / FS:g} s on, bridged losses up to "
          f"{bridging.BRIDGE_MAX_S:g} s")  # fmt: skip
    print(f"{'':<16} {'live':^34} {'offline (smoothed)':^34}")
    print(f"{'loss':<16} " + f"{'hip':>6} {'knee':>6} {'ankle':>6} {'worst/no loss':>14} " * 2
          + f"{'strides':>8} {'stride time |err| ms':>21}")  # fmt: skip
    sims = []
    for seed in range(args.seeds):
        gait = GaitModel(GaitConfig(seed=100 + seed, cadence_steps_min=110.0))
        sims.append((simulate(n, gait, SensorConfig(seed=100 + seed)), gait.events(0, n)[0]))
    base: list[np.ndarray] = []
    for name, frac, lo, hi in SCENARIOS:
        rmse: tuple[list[np.ndarray], list[np.ndarray]] = ([], [])
        n_str, t_err = 0, []
        for seed, (sb, true_hs) in enumerate(sims):
            rng = np.random.default_rng(1000 + seed)
            lost = lost_frames(n, frac, lo, hi, rng) if frac else np.zeros(n, dtype=bool)
            keep, live, offline, errs = run(sb.counts, lost, config, slice(100, 450), true_hs)
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
    data = args.data or default_data_dir()
    if data is not None and (data / "gdins_footprints" / "trials").is_dir():
        real_walks(data / "gdins_footprints" / "trials", config)


def real_walks(folder: Path, config: PipelineConfig) -> None:
    """Per real walk: the live foot tilt with 2 % loss against the loss-free run (module doc)."""
    from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, GYRO_IDX, N_CHANNELS

    print(f"\nreal walks ({folder}): RMS difference (deg) of the live foot tilt with 2 % "
          "single-frame loss from the loss-free run")  # fmt: skip
    print(f"{'trial':<8} {'samples':>8} {'rows as frames':>15} {'filled in':>10}")
    worst = [0.0, 0.0]
    for path in sorted(folder.glob("exp*.npz")):
        z = np.load(path)
        if abs(float(z["fs"]) - FS) > 1e-6:
            continue
        n = len(z["foot_gyro_y"])
        phys = np.zeros((n, N_CHANNELS))
        phys[:, ACC_X_IDX] = z["foot_acc_z"][:, None]  # the board frame: x up (sole normal)
        phys[:, ACC_Z_IDX] = z["foot_acc_x"][:, None]  # z forward
        phys[:, GYRO_IDX] = z["foot_gyro_y"][:, None]  # toe-up positive
        counts = DEFAULT_TABLE.to_counts(phys)
        rng = np.random.default_rng(7)
        lost = lost_frames(n, 0.02, 1, 1, rng)
        keep = np.flatnonzero(~lost)
        lost_before = np.diff(np.r_[-1, keep]) - 1
        whole = Pipeline(config).process(counts).tilt_kalman_rad[keep, 3]
        out = []
        for told in (None, lost_before):
            got = Pipeline(config).process(counts[keep], told).tilt_kalman_rad[:, 3]
            w = keep >= WALK_FROM
            out.append(float(np.sqrt(np.mean(np.degrees(wrap_angle(got[w] - whole[w])) ** 2))))
        worst = [max(a, b) for a, b in zip(worst, out, strict=True)]
        print(f"{path.stem:<8} {n:8d} {out[0]:15.2f} {out[1]:10.2f}")
    print(f"{'worst':<8} {'':>8} {worst[0]:15.2f} {worst[1]:10.2f}")


if __name__ == "__main__":
    main()
