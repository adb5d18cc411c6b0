"""Stride length on real feet: gdins footprints (16 walks, a measured footprint per stride) and
the x-io closed-loop walks, trial by trial, through the public entry points only
(``gyro_gait_events`` then ``stride_measures``).

    PYTHONPATH=. python benchmarks/stride_real.py [--data ../shared/data] [--strides]

gdins: each reference stride (footprint k to k + 1, zero-velocity end to zero-velocity end) is
matched by time to the computed stride whose opening heel strike lies in footprint k's stance
and closing one in footprint k + 1's (``match``; a first step from standing, computed with
``first_steps=True``, by its closing heel strike); coverage is the share of reference strides
whose match has a value. Errors are (computed - reference) / reference in %, over all strides
with a value, and over those not flagged (``StrideMeasures.trusted``, where it exists).
xio: the sum of the stride lengths against the source's approximate path (~25 / ~60 m) and
the 3-D ZUPT path of the data's own check (22.66 / 56.75 m): a weak reference (README), not a
per-stride one.
"""

from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

from gaitmon.dsp import gyro_gait_events, stride_measures
from gaitmon.dsp.stride_length import StrideMeasures

XIO_PATH_M = {"short_walk": (25.0, 22.66), "long_walk": (60.0, 56.75)}


def default_data() -> pathlib.Path:
    return pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "data"


Board = tuple[np.ndarray, np.ndarray, np.ndarray, float, dict[str, np.ndarray]]


def board(path: pathlib.Path) -> Board:
    """The foot in the unit's board frame (the datasets' load.py board_frame): acc x = the sole
    normal (up), acc z = forward, gyro y toe-up +."""
    z = np.load(path)
    return (z["foot_acc_z"].astype(float), z["foot_acc_x"].astype(float),
            z["foot_gyro_y"].astype(float), float(z["fs"]), dict(z))  # fmt: skip


def measure(ax: np.ndarray, az: np.ndarray, gy: np.ndarray, fs: float) -> StrideMeasures:
    hs, _ = gyro_gait_events(gy, fs)
    try:
        return stride_measures(ax, az, gy, fs, hs, first_steps=True)
    except TypeError:  # (before first steps existed)
        return stride_measures(ax, az, gy, fs, hs)


def flags_of(m: StrideMeasures) -> np.ndarray:
    f = getattr(m, "flag", None)
    if f is None:
        return np.zeros(len(m), dtype=bool)
    return ~np.asarray(m.trusted) & np.isfinite(m.stride_length_m)


def match(m: StrideMeasures, zv_end: np.ndarray, fs: float) -> np.ndarray:
    """(K_ref,) index of the computed stride matched to each reference stride (-1: none).

    A footprint's stance holds its heel strike and ends at its zero-velocity end, so the
    computed stride j (opening heel strike a_j, closing b_j) is reference stride k when a_j is
    in footprint k's stance (the first zero-velocity end at or after a_j is k's) and b_j in
    footprint k + 1's."""
    a = m.heel_strike_idx.astype(np.int64)
    b = a + np.round(m.stride_time_s * fs).astype(np.int64)
    ka = np.searchsorted(zv_end, a, side="left")
    kb = np.searchsorted(zv_end, b, side="left")
    first = (np.asarray(getattr(m, "flag", np.zeros(len(a), np.int64))) & 16) != 0
    ka[first] = kb[first] - 1  # a first step opens at a standing, not in a stance
    out = np.full(len(zv_end) - 1, -1, dtype=np.int64)
    for j in np.flatnonzero((kb == ka + 1) & (ka < len(zv_end) - 1)):
        out[ka[j]] = j
    return out


def pct(x: np.ndarray, q: float) -> float:
    return float(np.percentile(x, q)) if len(x) else float("nan")


def gdins(folder: pathlib.Path, per_stride: bool) -> dict[str, np.ndarray]:
    print("gdins_footprints: per trial (errors in % of the footprint stride length)")
    head = f"{'med|e|':>7} {'p90|e|':>7} {'mean e':>7}"
    print(f"{'trial':7} {'ref':>4} {'cover%':>7} {'flag':>5} {head} | unflagged: {'n':>4} {head}")
    errs, unfl, covers = [], [], {}
    for p in sorted((folder / "trials").glob("exp*.npz")):
        ax, az, gy, fs, z = board(p)
        zv, ref = z["zv_end_idx"].astype(np.int64), z["ref_stride_length"].astype(float)
        m = measure(ax, az, gy, fs)
        j = match(m, zv, fs)
        val = np.where(j >= 0, m.stride_length_m[np.clip(j, 0, None)], np.nan)
        fl = np.where(j >= 0, flags_of(m)[np.clip(j, 0, None)], False)
        have = np.isfinite(val)
        e = 100 * (val[have] - ref[have]) / ref[have]
        eu = 100 * (val[have & ~fl] - ref[have & ~fl]) / ref[have & ~fl]
        errs.append(e)
        unfl.append(eu)
        covers[p.stem] = have.mean()
        print(f"{p.stem:7} {len(ref):4d} {100 * have.mean():7.1f} {int(fl.sum()):5d} "
              f"{pct(np.abs(e), 50):7.1f} {pct(np.abs(e), 90):7.1f} {np.mean(e):+7.1f} |"
              f"            {len(eu):4d} {pct(np.abs(eu), 50):7.1f} {pct(np.abs(eu), 90):7.1f} "
              f"{np.mean(eu) if len(eu) else np.nan:+7.1f}")  # fmt: skip
        if per_stride:
            for k in np.flatnonzero(~have | (np.abs(100 * (val - ref) / ref) > 10)):
                print(f"    stride {k:3d} ref {ref[k]:.2f} m  got {val[k]:.2f}  flag {fl[k]}")
    e, eu = np.concatenate(errs), np.concatenate(unfl)
    n_ref = sum(1 for _ in e)  # strides with a value
    print(f"{'all':7} {'':4} {'':7} {'':5} {pct(np.abs(e), 50):7.1f} {pct(np.abs(e), 90):7.1f} "
          f"{np.mean(e):+7.1f} |            {len(eu):4d} {pct(np.abs(eu), 50):7.1f} "
          f"{pct(np.abs(eu), 90):7.1f} {np.mean(eu):+7.1f}")  # fmt: skip
    print(f"strides with a value: {n_ref}; lowest trial coverage "
          f"{100 * min(covers.values()):.1f} % ({min(covers, key=covers.__getitem__)})")
    return {"err": e, "err_unflagged": eu}


def xio(folder: pathlib.Path) -> None:
    print("\nxio_closed_loop_walks: total distance (sum of stride lengths)")
    print(f"{'walk':11} {'strides':>7} {'valued':>6} {'flag':>5} {'sum m':>7} "
          f"{'~README':>8} {'3-D ZUPT':>8} {'vs 3-D %':>8}")  # fmt: skip
    for p in sorted((folder / "trials").glob("*.npz")):
        ax, az, gy, fs, _ = board(p)
        m = measure(ax, az, gy, fs)
        have = np.isfinite(m.stride_length_m)
        total = float(np.nansum(m.stride_length_m))
        approx, zupt3 = XIO_PATH_M.get(p.stem, (np.nan, np.nan))
        print(f"{p.stem:11} {len(m):7d} {int(have.sum()):6d} {int(flags_of(m).sum()):5d} "
              f"{total:7.2f} {approx:8.1f} {zupt3:8.2f} {100 * (total - zupt3) / zupt3:+8.1f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=pathlib.Path, default=default_data())
    ap.add_argument("--strides", action="store_true", help="list missing and > 10 %% strides")
    args = ap.parse_args(argv)
    if not (args.data / "gdins_footprints").is_dir():
        print(f"no gdins_footprints in {args.data}", file=sys.stderr)
        return 2
    gdins(args.data / "gdins_footprints", args.strides)
    if (args.data / "xio_closed_loop_walks").is_dir():
        xio(args.data / "xio_closed_loop_walks")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
