"""How long the joint angles take to settle after a link outage: the measurement behind
``gaitmon.dsp.pipeline.SETTLE_S``.

A simulated walk (ground truth known, zeroed on its standing start) loses ``--gap-s`` of frames
(default 3 s; issue 24 asks about 5 s) at 44 places; each time the pipeline either carries on
across the gap (``lost_before`` not given) or restarts after it (the default). Printed: the
mean over the outages of the largest hip/knee/ankle error (deg) in windows after the gap,
beside the same figure 10-15 s later (the walking level); then per joint the mean |error| 3 s
after data resumes (rows 275-325 after the gap) beside the walking level (rows 1000-1500).

    python benchmarks/gap_settling.py [--gap-s 5]
"""

from __future__ import annotations

import argparse

import numpy as np

from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.pipeline import SETTLE_S, Pipeline
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

N = 12_000
WINDOWS = ((0, 50), (50, 100), (100, 200), (200, 300), (300, 500), (1000, 1500))
AT_3S = (275, 325)
LEVEL = (1000, 1500)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--gap-s", type=float, default=3.0, help="outage length (default 3 s)")
    gap = round(ap.parse_args().gap_s * 100)
    gait = GaitModel(GaitConfig(seed=11, cadence_steps_min=110.0))
    sb = simulate(N, gait, SensorConfig(seed=11))
    first = Pipeline().process(sb.counts[:450])
    cal = standing_calibration(first.acc_ms2[100:450], first.gyro_rad_s[100:450])
    print(f"max joint error (deg) after a {gap / 100:g} s outage, mean over outages")
    print("rows after gap   " + "  ".join(f"{a:>4}-{b:<4}" for a, b in WINDOWS))
    per_joint = {}
    for how in ("carry on", "restart"):
        errs, at3, level = [], [], []
        for gs in range(3000, 9000, 137):
            keep = np.r_[0:gs, gs + gap : N]
            lost = np.zeros(len(keep), np.int64)
            lost[gs] = gap
            b = Pipeline(calibration=cal).process(
                sb.counts[keep], lost_before=lost if how == "restart" else None
            )
            truth = sb.kinematics.joint_rad[keep]
            ej = np.degrees(np.abs(wrap_angle(b.joint_kalman_rad - truth)))
            e = ej.max(axis=1)
            errs.append([e[gs + a : gs + z].mean() for a, z in WINDOWS])
            at3.append(ej[gs + AT_3S[0] : gs + AT_3S[1]].mean(axis=0))
            level.append(ej[gs + LEVEL[0] : gs + LEVEL[1]].mean(axis=0))
        per_joint[how] = (np.mean(at3, axis=0), np.mean(level, axis=0))
        print(f"{how:<16} " + "  ".join(f"{v:9.1f}" for v in np.mean(errs, axis=0)))
    print(f"SETTLE_S = {SETTLE_S:g} s (rows 0-{round(SETTLE_S * 100)} are flagged settling)")
    print("\nmean |joint error| (deg) 3 s after data resumes (walking level 10-15 s later)")
    print("                  hip          knee         ankle")
    for how, (at3_j, level_j) in per_joint.items():
        cells = (f"{a:4.1f} ({v:3.1f})" for a, v in zip(at3_j, level_j, strict=True))
        print(f"{how:<16} " + "  ".join(cells))


if __name__ == "__main__":
    main()
