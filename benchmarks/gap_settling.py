"""How long the joint angles take to settle after a link outage: the measurement behind
``gaitmon.dsp.pipeline.SETTLE_S``.

A simulated walk (ground truth known) loses 3 s of frames at 44 places; each time the pipeline
either carries on across the gap (``lost_before`` not given) or restarts after it (the
default). Printed: the mean over the outages of the largest hip/knee/ankle error (deg) in
windows after the gap, beside the same figure 10-15 s later (the walking level).

    python benchmarks/gap_settling.py
"""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.pipeline import SETTLE_S, Pipeline
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

N = 12_000
GAP = 300  # frames (3 s at 100 Hz)
WINDOWS = ((0, 50), (50, 100), (100, 200), (200, 300), (300, 500), (1000, 1500))


def main() -> None:
    gait = GaitModel(GaitConfig(seed=11, cadence_steps_min=110.0))
    sb = simulate(N, gait, SensorConfig(seed=11))
    first = Pipeline().process(sb.counts[:450])
    cal = standing_calibration(first.acc_ms2[100:450], first.gyro_rad_s[100:450])
    print(f"max joint error (deg) after a {GAP / 100:g} s outage, mean over outages")
    print("rows after gap   " + "  ".join(f"{a:>4}-{b:<4}" for a, b in WINDOWS))
    for how in ("carry on", "restart"):
        errs = []
        for gs in range(3000, 9000, 137):
            keep = np.r_[0:gs, gs + GAP : N]
            lost = np.zeros(len(keep), np.int64)
            lost[gs] = GAP
            b = Pipeline(calibration=cal).process(
                sb.counts[keep], lost_before=lost if how == "restart" else None
            )
            truth = sb.kinematics.joint_rad[keep]
            e = np.degrees(np.abs(wrap_angle(b.joint_kalman_rad - truth))).max(axis=1)
            errs.append([e[gs + a : gs + z].mean() for a, z in WINDOWS])
        print(f"{how:<16} " + "  ".join(f"{v:9.1f}" for v in np.mean(errs, axis=0)))
    print(f"SETTLE_S = {SETTLE_S:g} s (rows 0-{round(SETTLE_S * 100)} are flagged settling)")


if __name__ == "__main__":
    main()
