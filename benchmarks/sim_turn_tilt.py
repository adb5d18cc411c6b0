"""Is the hard simulator's foot as hard as real feet? The live and offline foot tilt error in
straight and turning strides, on gdins against its 3-D reference and on the simulator's
``realism="real"`` level against its truth (issue 24, item 6; docs/simulator.md).

    PYTHONPATH=. python benchmarks/sim_turn_tilt.py [--data ../shared/data] [--seeds 100 101 102]

Strides run from stance to stance (gdins: its ZV ends; the simulator: its heel strikes after
the ramp-in); "turn": the foot's heading changes by more than 45 deg over the stride (gdins: 3-D
strapdown, benchmarks/sim_realism_params.py; the simulator: its truth), "straight": less than
20 deg. RMS of the error (deg) over the samples of those strides, the trial's (record's) mean
error removed, as the lab's tables do. About 1 min on one core.
"""

from __future__ import annotations

import argparse
import sys
from itertools import pairwise
from pathlib import Path

import numpy as np

from gaitmon.dsp.angles import wrap_angle

sys.path.insert(0, str(Path(__file__).parent))
import sim_realism_params as params

KINDS = ("straight", "turn")


def _classify(err: np.ndarray, bounds: list[tuple[int, int]], turn: np.ndarray,
              out: dict[str, list[np.ndarray]]) -> None:  # fmt: skip
    for (a, b), t in zip(bounds, turn, strict=True):
        e = err[a:b]
        e = e[np.isfinite(e)]
        if abs(t) > np.radians(45.0):
            out["turn"].append(e)
        elif abs(t) < np.radians(20.0):
            out["straight"].append(e)


def real(data: Path) -> dict[str, dict[str, np.ndarray]]:
    from gaitmon.lab import datasets, real_tilt
    from gaitmon.lab.reference import reference_foot_tilt

    _, cg = params._import_dataset(data / "gdins_footprints")
    res: dict[str, dict[str, list[np.ndarray]]] = {m: {k: [] for k in KINDS}
                                                   for m in ("live", "offline")}  # fmt: skip
    for t in datasets.read_gdins(data):
        assert t.acc_xyz is not None and t.gyr_xyz is not None
        ref = reference_foot_tilt(t)
        est = real_tilt.method_tilts(t)
        zv = t.extra["zv_end_idx"]
        st = params._standing(t.acc_xyz, t.gyr_xyz, int(20 * t.fs_hz))
        bias = t.gyr_xyz[st].mean(0) if len(st) > 20 else np.zeros(3)
        turn = params._heading_per_stride(cg, t.acc_xyz, t.gyr_xyz, zv, t.fs_hz, bias)["turn"]
        a, b = real_tilt.walking_span(t)
        for m in res:
            e = np.degrees(wrap_angle(est[m] - ref))
            e = e - np.nanmean(e[a:b])
            _classify(e, list(pairwise(zv))[1:-1], turn[1:-1], res[m])
    return {m: {k: np.concatenate(v) for k, v in r.items()} for m, r in res.items()}


def simulated(seeds: list[int]) -> dict[str, dict[str, np.ndarray]]:
    from gaitmon.lab import accuracy as lab

    res: dict[str, dict[str, list[np.ndarray]]] = {m: {k: [] for k in KINDS}
                                                   for m in ("live", "offline")}  # fmt: skip
    for seed in seeds:
        gait, sb = lab._simulate("normal", 9000, seed=seed, realism="real")
        cal = lab._calibrate(sb.counts)
        kin = sb.kinematics
        hs, _ = gait.events(0, 9000)
        bounds = list(pairwise(hs[hs > lab.SKIP]))
        turn = np.array([kin.heading_rad[b] - kin.heading_rad[a] for a, b in bounds])
        for m in res:
            e = np.degrees(wrap_angle(lab.tilts(sb.counts, cal, m)[:, 3] - kin.tilt_rad[:, 3]))
            e[: lab.SKIP] = np.nan
            _classify(e - np.nanmean(e), bounds, turn, res[m])
    return {m: {k: np.concatenate(v) for k, v in r.items()} for m, r in res.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--seeds", type=int, nargs="*", default=[100, 101, 102])
    args = ap.parse_args(argv)
    data = args.data
    if data is None:
        from gaitmon.lab.accuracy import default_data_dir

        data = default_data_dir()
    rows = []
    if data is not None and (data / "gdins_footprints").is_dir():
        rows.append(("gdins (16 walks, 3-D reference)", real(data)))
    else:
        print("no gdins_footprints in the data folder (--data DIR): simulator only")
    rows.append((f"simulator real, normal, seeds {args.seeds}", simulated(args.seeds)))
    print("| foot tilt RMS error, deg | live straight | live turn | offline straight | "
          "offline turn |\n|---|---|---|---|---|")  # fmt: skip
    for name, r in rows:
        cells = [f"{np.sqrt(np.mean(r[m][k] ** 2)):.2f} ({len(r[m][k]) / 100:.0f} s)"
                 for m in ("live", "offline") for k in KINDS]  # fmt: skip
        print(f"| {name} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
