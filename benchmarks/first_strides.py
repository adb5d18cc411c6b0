"""How right the live joint angles are over the first 10 s of a recording (issue 24, item 3).

The simulated subject walks from the first sample (``record --simulate --standing-s 0``), or the
recording starts mid-walk (5.37 s into the walk), or it stands 4.5 s, is zeroed on its last
1.5 s and then walks (the ``--zero`` flow). The pipeline (live filter, ``Pipeline``) runs over
the samples and is scored against the simulator's truth, per pattern, over seeds 0-2:

* ``first 10 s``: joint RMSE over the first 10 s of walking after removing the steady offset
  (the mean error 15-30 s in: without a Zero the mounting offsets stay, whatever the filter
  does), i.e. how far the first strides are from what the same recording reads later;
* ``demeaned``: the same with the first 10 s' own mean removed (the shapes only);
* ``later``: RMSE 15-30 s in, its mean removed (the walking level).

Printed: the worst seed per pattern and joint (hip / knee / ankle, deg), beside today's
figures (``TODAY``: this script run on the commit before the start-up, 376dddf).

    python benchmarks/first_strides.py
    python benchmarks/first_strides.py --seeds 3,4,5   # held-out seeds (not tuned on)
"""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.calibration import standing_calibration
from gaitmon.dsp.pipeline import Pipeline
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

FS = 100
PATTERNS = ("normal", "stiff-knee", "long-stance")
SEEDS = (0, 1, 2)
SCENARIOS = ("from rest", "mid-walk", "zeroed")
# scenario -> pattern -> (first 10 s, demeaned, later) worst over seeds, hip/knee/ankle (deg),
# printed by this script on commit 376dddf (before the start-up)
TODAY: dict[str, dict[str, tuple[tuple[float, ...], ...]]] = {
    "from rest": {
        "normal": ((11.7, 13.5, 7.4), (4.2, 4.8, 3.2), (0.5, 0.9, 1.2)),
        "stiff-knee": ((11.7, 13.5, 8.6), (4.2, 4.8, 2.9), (0.5, 0.6, 1.1)),
        "long-stance": ((11.7, 13.2, 6.4), (4.2, 4.8, 3.3), (0.6, 1.0, 0.8)),
    },
    "mid-walk": {
        "normal": ((11.9, 15.3, 5.6), (4.6, 5.8, 3.2), (0.4, 0.9, 1.2)),
        "stiff-knee": ((11.9, 15.3, 7.3), (4.6, 5.7, 3.9), (0.4, 0.6, 1.2)),
        "long-stance": ((11.8, 13.9, 4.8), (4.1, 6.0, 2.9), (0.7, 1.0, 0.8)),
    },
    "zeroed": {
        "normal": ((3.8, 3.9, 2.9), (1.2, 1.4, 2.4), (0.4, 0.9, 0.9)),
        "stiff-knee": ((3.8, 3.9, 3.3), (1.2, 1.3, 1.8), (0.4, 0.6, 0.9)),
        "long-stance": ((4.4, 4.0, 4.1), (1.8, 1.5, 2.8), (0.6, 1.0, 0.8)),
    },
}


def score(pattern: str, seed: int, scenario: str) -> np.ndarray:
    """(3, 3): first 10 s, demeaned, later x hip, knee, ankle (deg)."""
    skip = {"from rest": 0, "mid-walk": 537, "zeroed": 0}[scenario]
    standing = 4.5 if scenario == "zeroed" else 0.0
    walk0 = round(standing * FS)
    n = skip + walk0 + 3000
    sb = simulate(n, GaitModel(GaitConfig(seed=seed, pattern=pattern, standing_s=standing)),
                  SensorConfig(seed=seed))  # fmt: skip
    pipe = Pipeline()
    if scenario == "zeroed":
        stand = pipe.process(sb.counts[:walk0])
        pipe.set_calibration(
            standing_calibration(stand.acc_ms2[walk0 - 150 :], stand.gyro_rad_s[walk0 - 150 :])
        )
    b = pipe.process(sb.counts[skip + walk0 :])
    e = np.degrees(wrap_angle(b.joint_kalman_rad - sb.kinematics.joint_rad[skip + walk0 :]))
    first, later = e[:1000], e[1500:]
    rms = lambda x: np.sqrt((x**2).mean(axis=0))  # noqa: E731
    return np.array([rms(first - later.mean(0)), rms(first - first.mean(0)),
                     rms(later - later.mean(0))])  # fmt: skip


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    seeds_default = ",".join(map(str, SEEDS))
    parser.add_argument("--seeds", default=seeds_default, help="comma-separated simulator seeds")
    seeds = tuple(int(x) for x in parser.parse_args().seeds.split(","))
    print(f"live joint RMSE (deg), hip / knee / ankle, worst of seeds {seeds}")
    print(f"{'scenario':<10} {'pattern':<12} {'first 10 s':>18} {'demeaned':>18} "
          f"{'later':>16}   376dddf, seeds 0-2: first 10 s / demeaned / later")  # fmt: skip
    worst = 0.0
    for scenario in SCENARIOS:
        for pattern in PATTERNS:
            s = np.max([score(pattern, seed, scenario) for seed in seeds], axis=0)
            worst = max(worst, float(s[0].max()))
            cells = ["/".join(f"{v:.1f}" for v in row) for row in s]
            today = TODAY.get(scenario, {}).get(pattern)
            then = " ; ".join("/".join(f"{v:.1f}" for v in row) for row in today) if today else "-"
            print(f"{scenario:<10} {pattern:<12} {cells[0]:>18} {cells[1]:>18} {cells[2]:>16}"
                  f"   {then}")  # fmt: skip
    print(f"worst joint over the first 10 s, every scenario and pattern: {worst:.1f} deg")


if __name__ == "__main__":
    main()
