"""The current methods on the easy and on the hard simulator (issue 24, item 6).

    PYTHONPATH=. python benchmarks/sim_hard.py [--seconds 85] [--seed 100] [--scenarios ...]

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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=85.0, help="walking after 5 s standing")
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--scenarios", nargs="*", default=list(JOINT_SCENARIOS))
    args = ap.parse_args(argv)
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
    print("\nstride length |error|, % of the truth: median (p95); strides with a value / matched")
    print("\n| scenario | level | live | offline |\n|---|---|---|---|")
    for level, realism in (("easy", "default"), ("hard", "real")):
        acc = lab.Accuracy()
        lab._strides(n + 2000, args.seed, acc, realism)
        for name, st in acc.stride_err_pct.items():
            cells = []
            for mode in ("live", "offline"):
                e = st["length"][mode]
                cells.append(f"{lab._median_p95(e)}; {int(np.isfinite(e).sum())}/{len(e)}")
            print(f"| {name} | {level} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
