"""The current methods on the easy and on the hard simulator (issue 24, item 6).

    PYTHONPATH=. python benchmarks/sim_hard.py [--seconds 85] [--seed 100] [--scenarios ...]
    PYTHONPATH=. python benchmarks/sim_hard.py --ablate   # each effect alone, normal walking

"easy": the accuracy evaluation's simulator as it was (``gaitmon lab accuracy``: the realistic
sensors); "hard": the same scenarios at ``realism="real"`` (docs/simulator.md, "Realism
levels": gain and cross-axis errors, a gyro scale error, roll and 180-degree turns, the stance
foot's rocking, stride time and length variability). Prints, per scenario and level, the joint
RMSE hip / knee / ankle (deg) of the paper's filter, the live gait-aware Kalman and the offline
smoother (gaitmon.lab.accuracy's definitions: after the ramp-in, mean offset removed), and the
stride length |error| median (p95) in % live and offline with the strides that got a value.
"""

from __future__ import annotations

import argparse

import numpy as np

from gaitmon.lab import accuracy as lab

JOINT_SCENARIOS = ("normal", "slow (85 steps/min)", "stiff-knee", "long-stance")


def ablate(seconds: float, seed: int) -> None:
    """Each effect of the real level alone on the easy simulator (normal walking): joint RMSE
    live and offline, and the offline stride length (foot-gyro heel strikes, stride_measures)."""
    from dataclasses import replace

    from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX
    from gaitmon.dsp.gyro_events import gyro_gait_events
    from gaitmon.dsp.stride_length import stride_measures
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.config import REAL_GAIT, REAL_SENSORS
    from gaitmon.io.sim.sensors import realistic_sensors, simulate

    def pick(d: dict[str, object], *keys: str) -> dict[str, object]:
        return {k: d[k] for k in keys}

    turn_keys = ("turn_every_strides", "turn_strides", "turn_deg", "first_turn_strides",
                 "turn_in_swing")
    effects: dict[str, tuple[dict[str, object], dict[str, object]]] = {
        "none (easy)": ({}, {}),
        "acc gain + cross-axis": ({}, pick(REAL_SENSORS, "acc_gain_sd", "acc_cross_sd")),
        "gyro scale + cross-axis": ({}, pick(REAL_SENSORS, "gyro_scale_sd", "gyro_cross_sd")),
        "stride time + length CV": (pick(REAL_GAIT, "stride_cv", "stride_length_cv"), {}),
        "stance roll-over": (
            pick(REAL_GAIT, "stance_micro_rad", "stance_micro_spread", "stance_pivot_m"), {}
        ),
        "roll (slow + swing)": (pick(REAL_GAIT, "roll_sd_deg", "swing_roll_deg"), {}),
        "roll + swing yaw": (
            pick(REAL_GAIT, "roll_sd_deg", "swing_roll_deg", "swing_yaw_deg"), {}
        ),
        "turns (no roll)": (pick(REAL_GAIT, *turn_keys), {}),
        "all (hard)": (dict(REAL_GAIT), dict(REAL_SENSORS)),
    }
    n = int((seconds + 5.0) * lab.FS)
    print("| effect alone | live hip / knee / ankle | offline | stride length offline "
          "median (p95) %; values / matched of true |")  # fmt: skip
    print("|---|---|---|---|")
    for name, (g_opts, s_opts) in effects.items():
        gait = GaitModel(GaitConfig(seed=seed, **g_opts))  # type: ignore[arg-type]
        sb = simulate(n, gait, replace(realistic_sensors(seed), **s_opts))  # type: ignore[arg-type]
        cal = lab._calibrate(sb.counts)
        cells = []
        for m in ("live", "offline"):
            e = lab.joint_rmse_deg(lab.tilts(sb.counts, cal, m), sb.kinematics.joint_rad)
            cells.append(" / ".join(f"{v:.2f}" for v in e))
        ph = DEFAULT_TABLE.to_physical(sb.counts)
        gyro = cal.apply_gyro(ph[:, GYRO_IDX])[:, 3]
        hs, _ = gyro_gait_events(gyro, lab.FS)
        ms = stride_measures(ph[:, ACC_X_IDX[3]], ph[:, ACC_Z_IDX[3]], gyro, lab.FS, hs)
        truth = gait.strides(0, n)
        e, _ = lab.match_strides(ms.heel_strike_idx, ms.stride_length_m, ms.speed_m_s, truth)
        n_true = int(np.sum(truth.heel_strike_idx > lab.SKIP))
        cells.append(f"{lab._median_p95(e)}; {int(np.isfinite(e).sum())} / {len(e)} of {n_true}")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--seconds", type=float, default=85.0, help="walking after 5 s standing")
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--scenarios", nargs="*", default=list(JOINT_SCENARIOS))
    ap.add_argument("--ablate", action="store_true", help="each effect alone (normal walking)")
    args = ap.parse_args(argv)
    if args.ablate:
        ablate(args.seconds, args.seed)
        return 0
    n = int((args.seconds + 5.0) * lab.FS)
    methods = ("paper", "live", "offline")
    print("| scenario | level | " + " | ".join(lab.labels()[m] for m in methods) + " |")
    print("|---|---|" + "---|" * len(methods))
    means: dict[str, dict[str, list[np.ndarray]]] = {}
    for i, name in enumerate(args.scenarios):
        for level, realism in (("easy", "default"), ("hard", "real")):
            _, sb = lab._simulate(name, n, args.seed + i, realism)
            cal = lab._calibrate(sb.counts)
            cells = []
            for m in methods:
                e = lab.joint_rmse_deg(lab.tilts(sb.counts, cal, m), sb.kinematics.joint_rad)
                means.setdefault(level, {}).setdefault(m, []).append(e)
                cells.append(" / ".join(f"{v:.2f}" for v in e))
            print(f"| {name} | {level} | " + " | ".join(cells) + " |", flush=True)
    for level, per in means.items():
        cells = [" / ".join(f"{v:.2f}" for v in np.mean(per[m], axis=0)) for m in methods]
        print(f"| mean | {level} | " + " | ".join(cells) + " |")
    print("\nstride length |error|, % of the truth: median (p95); strides with a value / matched "
          "to a true one of the true strides after the ramp-in")  # fmt: skip
    print("\n| scenario | level | live | offline |\n|---|---|---|---|")
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.config import realism_gait

    for level, realism in (("easy", "default"), ("hard", "real")):
        acc = lab.Accuracy()
        lab._strides(n + 2000, args.seed, acc, realism)
        for i, (name, st) in enumerate(acc.stride_err_pct.items()):
            opts = lab.STRIDE_SCENARIOS[name]
            gait = GaitModel(realism_gait(GaitConfig(seed=args.seed + i, **opts), realism))
            n_true = int(np.sum(gait.strides(0, n + 2000).heel_strike_idx > lab.SKIP))
            cells = []
            for mode in ("live", "offline"):
                e = st["length"][mode]
                cells.append(f"{lab._median_p95(e)}; {int(np.isfinite(e).sum())}/{len(e)} of "
                             f"{n_true}")  # fmt: skip
            print(f"| {name} | {level} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
