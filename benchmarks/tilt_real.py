"""Foot tilt on every real recording in ../shared/data: the paper's filter, the gait-aware live
filter and the offline smoother, trial by trial.

    python benchmarks/tilt_real.py [--data DIR] [--loto]

``--loto``: the foot parameters fitted on the walks (``r_static``, ``r_live_gravity``, with
``live_gravity_hz`` and ``q_angle``), judged leave-one-walk-out: for each walk, the configuration
of a small grid best on the other walks (mean RMS; only configurations within the paper's + 1
deg on every BROAD trial), scored on the walk left out.

* BROAD (4 trials, optical reference; not walking): planar tilt RMS error where the planar model
  holds (|u_y| < 0.5), the convention of tests/test_broad.py and ``gaitmon lab accuracy``.
* gdins_footprints (16 walks) and xio_closed_loop_walks (2 walks): no orientation reference, so
  the reference is a 3-D 6-axis estimate from the same IMU (``reference_foot_tilt`` below): the
  full gyro and accelerometer, strapdown between still phases (zero-velocity stance), corrected
  to the accelerometer in every still phase, run forward and backward in time and blended by the
  time since / until the nearest still phase; turned into the board frame's planar tilt
  atan2(u_fwd, u_up) (u = earth-up in foot coordinates). The planar filters see only the 2-D
  channels (acc_x, acc_z, gyro_y of ``d["board"]``). RMS error after removing the constant
  offset (the held-out measure's convention), first 2 s left out.

The gyro bias is the mean of gyro_y over samples 20-100 (BROAD, as the lab) or the first second
(walks), as a standing calibration would give.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
from pathlib import Path

import numpy as np

from gaitmon.dsp.angles import wrap_angle
from gaitmon.dsp.estimate import estimate_tilt
from gaitmon.lab.accuracy import default_data_dir

FS = 100.0
G = 9.81
BROAD_TRIALS = (
    "02_undisturbed_slow_rotation_B",
    "07_undisturbed_fast_rotation_B",
    "16_undisturbed_fast_translation_B",
    "24_disturbed_tapping_A",
)
SKIP = 200  # filter start (and BROAD's resampling edge)


def load_broad(root: Path, trial: str) -> dict[str, np.ndarray] | None:
    """100 Hz board channels, the optical planar tilt and where it is valid."""
    import h5py
    from scipy import signal

    path = root / "broad" / f"{trial}.hdf5"
    if not path.is_file():
        return None
    with h5py.File(path, "r") as f:
        a, g, q = f["imu_acc"][:], f["imu_gyr"][:], f["opt_quat"][:]
    w, x, y, z = q.T
    up = np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1)
    lost = np.isnan(up).any(axis=1)

    def to_100hz(v: np.ndarray) -> np.ndarray:
        return np.asarray(signal.resample_poly(np.nan_to_num(v), 7, 20, axis=0))

    lost100 = to_100hz(lost.astype(float)) > 0.01
    up100, a100, g100 = to_100hz(up), to_100hz(a), to_100hz(g)
    valid = ~lost100 & (np.abs(up100[:, 1]) < 0.5)
    valid[:SKIP] = False
    return {
        "ax": a100[:, 0], "az": a100[:, 2], "gy": g100[:, 1] - g100[20:100, 1].mean(),
        "ref": np.arctan2(up100[:, 2], up100[:, 0]), "valid": valid,
    }  # fmt: skip


def _loader(folder: Path):  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location(f"load_{folder.name}", folder / "load.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _still(acc: np.ndarray, gyr: np.ndarray, half: int = 2) -> np.ndarray:
    """Zero-velocity samples: | |a| - g | < 0.6 m/s^2 (g: the median |a| where |omega| < 0.3)
    and |omega| < 0.6 rad/s over +-half samples; where no such sample lies within 1 s (fast
    walking), 1.5 m/s^2 and 1.5 rad/s."""
    from scipy.ndimage import maximum_filter1d

    norm = np.linalg.norm(acc, axis=1)
    rate = np.linalg.norm(gyr, axis=1)
    dev = np.abs(norm - np.median(norm[rate < 0.3]))  # the local g
    n = 2 * half + 1
    md, mr = maximum_filter1d(dev, n), maximum_filter1d(rate, n)
    strict = (md < 0.6) & (mr < 0.6)
    near = maximum_filter1d(strict.astype(np.uint8), 201) > 0
    return np.asarray(strict | (~near & (md < 1.5) & (mr < 1.5)))


def _quat_mul(p: tuple[float, ...], q: tuple[float, ...]) -> tuple[float, float, float, float]:
    a1, b1, c1, d1 = p
    a2, b2, c2, d2 = q
    return (
        a1 * a2 - b1 * b2 - c1 * c2 - d1 * d2,
        a1 * b2 + b1 * a2 + c1 * d2 - d1 * c2,
        a1 * c2 - b1 * d2 + c1 * a2 + d1 * b2,
        a1 * d2 + b1 * c2 - c1 * b2 + d1 * a2,
    )


def _mahony_up(acc: np.ndarray, gyr: np.ndarray, still: np.ndarray, dt: float) -> np.ndarray:
    """(N, 3) earth-up in sensor coordinates: 3-D strapdown, pulled to the accelerometer (gain
    5 /s) only in still samples. Started level with the first accelerometer reading."""
    n = len(acc)
    out = np.empty((n, 3))
    a0 = acc[0] / np.linalg.norm(acc[0])
    # a quaternion that turns a0 (sensor) onto earth-up
    axis = np.cross(a0, [0.0, 0.0, 1.0])
    s = np.linalg.norm(axis)
    ang = math.atan2(s, a0[2])
    axis = axis / s if s > 1e-12 else np.array([1.0, 0.0, 0.0])
    q = (math.cos(ang / 2), *(math.sin(ang / 2) * axis))
    kp = 5.0
    for k in range(n):
        w0, x0, y0, z0 = q
        # earth-up in sensor coordinates: third row of R(q)
        ux, uy, uz = 2 * (x0 * z0 - w0 * y0), 2 * (y0 * z0 + w0 * x0), 1 - 2 * (x0 * x0 + y0 * y0)
        gx, gy, gz = gyr[k]
        if still[k]:
            ax, ay, az = acc[k] / np.linalg.norm(acc[k])
            # error = a x u (rotate the estimate towards the measurement)
            gx += kp * (ay * uz - az * uy)
            gy += kp * (az * ux - ax * uz)
            gz += kp * (ax * uy - ay * ux)
        dq = _quat_mul(q, (0.0, 0.5 * gx * dt, 0.5 * gy * dt, 0.5 * gz * dt))
        q = tuple(q[i] + dq[i] for i in range(4))
        nq = math.sqrt(sum(c * c for c in q))
        q = tuple(c / nq for c in q)
        w0, x0, y0, z0 = q
        out[k] = (2 * (x0 * z0 - w0 * y0), 2 * (y0 * z0 + w0 * x0), 1 - 2 * (x0 * x0 + y0 * y0))
    return out


def reference_foot_tilt(acc_xyz: np.ndarray, gyr_xyz: np.ndarray, fs: float) -> np.ndarray:
    """The foot's planar tilt (rad) in the board frame's convention (module doc): forward and
    backward 3-D filters blended by the distance in time to the nearest still phase."""
    dt = 1.0 / fs
    gyr_xyz = gyr_xyz - gyr_xyz[:100].mean(axis=0)  # the bias, standing in the first second
    still = _still(acc_xyz, gyr_xyz)
    fwd = _mahony_up(acc_xyz, gyr_xyz, still, dt)
    bwd = _mahony_up(acc_xyz[::-1], -gyr_xyz[::-1], still[::-1], dt)[::-1]
    t_f = np.unwrap(np.arctan2(fwd[:, 0], fwd[:, 2]))
    t_b = t_f + wrap_angle(np.arctan2(bwd[:, 0], bwd[:, 2]) - t_f)
    n = len(still)
    idx = np.arange(n)
    last = np.maximum.accumulate(np.where(still, idx, -1))
    nxt = np.minimum.accumulate(np.where(still, idx, n)[::-1])[::-1]
    since = np.where(last >= 0, idx - last, 10 * n).astype(float)
    until = np.where(nxt < n, nxt - idx, 10 * n).astype(float)
    wb = np.full(n, 0.5)  # (still samples: both passes hold the accelerometer)
    np.divide(since, since + until, out=wb, where=~still)
    return np.asarray(t_f + wb * (t_b - t_f))


def load_walks(
    root: Path, cache: bool = True, only: str | None = None
) -> dict[str, dict[str, np.ndarray]]:
    """gdins and xio walks: board channels, the 6-axis reference (``cache``: kept in /tmp
    between runs), and ``ref_rate_corr``, the correlation of the reference's rate with gyro_y
    (a check of the reference: the planar gyro sees the planar tilt's rate only while the
    foot's y axis stays level). ``only``: that one trial ("gdins/exp31")."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for folder in ("gdins_footprints", "xio_closed_loop_walks"):
        if not (root / folder / "load.py").is_file():
            continue
        mod = _loader(root / folder)
        for path in sorted((root / folder / "trials").glob("*.npz")):
            key = f"{folder.split('_')[0]}/{path.stem}"
            if only is not None and key != only:
                continue
            d = mod.load_trial(path)
            stored = Path("/tmp") / f"gaitmon_tilt_ref_{folder}_{path.stem}.npy"
            acc, gyr = d["foot"]["acc_xyz"], d["foot"]["gyr_xyz"]
            if cache and stored.is_file():
                ref = np.load(stored)
            else:
                ref = reference_foot_tilt(acc, gyr, d["fs"])
                if cache:
                    np.save(stored, ref)
            b = d["board"]
            valid = np.ones(len(ref), bool)
            valid[:SKIP] = False
            gy = b["gyro_y"]
            rate = np.gradient(np.unwrap(ref)) * d["fs"]
            out[key] = {
                "ax": b["acc_x"], "az": b["acc_z"], "gy": gy - gy[:100].mean(), "ref": ref,
                "valid": valid,
                "ref_rate_corr": np.corrcoef(rate[SKIP:], gy[SKIP:])[0, 1],
            }  # fmt: skip
    return out


def rms_deg(est: np.ndarray, ref: np.ndarray, valid: np.ndarray, offset: bool) -> float:
    e = wrap_angle(est - ref)[valid]
    if offset:
        e = e - np.angle(np.mean(np.exp(1j * e)))
        e = wrap_angle(e)
    return float(np.degrees(np.sqrt(np.mean(e**2))))


def table(root: Path) -> list[tuple[str, float, float, float, float]]:
    """(trial, paper, live, offline, reference check) per trial; the check is 1 for BROAD's
    optical reference, else ``ref_rate_corr``."""
    rows = []
    for trial in BROAD_TRIALS:
        d = load_broad(root, trial)
        if d is None:
            continue
        rows.append((f"broad/{trial[:2]}", *_three(d, offset=False), 1.0))
    for name, d in load_walks(root).items():
        rows.append((name, *_three(d, offset=True), float(d["ref_rate_corr"])))
    return rows


def _three(d: dict[str, np.ndarray], offset: bool) -> tuple[float, float, float]:
    res = []
    for method, offline in (("paper", False), ("gait-aware", False), ("gait-aware", True)):
        est = estimate_tilt(d["ax"], d["az"], d["gy"], FS, segment="foot", method=method,
                            offline=offline)  # fmt: skip
        res.append(rms_deg(est, d["ref"], d["valid"], offset))
    return res[0], res[1], res[2]


LOTO_GRID = {
    "q_angle": (1e-7, 3e-7, 1e-6, 3e-6),
    "r_static": (1e-3, 1e-4),
    "live_gravity_hz": (0.25, 0.4),
    "r_live_gravity": (3e-3, 1e-3),
}


def loto(root: Path) -> None:
    """Leave-one-walk-out over LOTO_GRID (module doc)."""
    import dataclasses
    import itertools

    from gaitmon.dsp.motion_kalman import GaitAwareKalman, tuning_for

    broad = {t: d for t in BROAD_TRIALS if (d := load_broad(root, t)) is not None}
    walks = load_walks(root)
    base = tuning_for("foot")

    def live(d: dict[str, np.ndarray], tun: object) -> np.ndarray:
        kf = GaitAwareKalman(FS, segments=("foot",), tuning={"foot": tun})  # type: ignore[dict-item]
        return np.asarray(kf.process(d["ax"], d["az"], d["gy"]))

    paper = {t: rms_deg(estimate_tilt(d["ax"], d["az"], d["gy"], FS, method="paper"), d["ref"],
                        d["valid"], False) for t, d in broad.items()}  # fmt: skip
    scores: dict[tuple[float, ...], dict[str, float]] = {}
    for values in itertools.product(*LOTO_GRID.values()):
        tun = dataclasses.replace(base, **dict(zip(LOTO_GRID, values, strict=True)))
        if any(rms_deg(live(d, tun), d["ref"], d["valid"], False) > paper[t] + 1.0
               for t, d in broad.items()):  # fmt: skip
            continue
        scores[values] = {k: rms_deg(live(d, tun), d["ref"], d["valid"], True)
                          for k, d in walks.items()}  # fmt: skip
    chosen = tuple(getattr(base, k) for k in LOTO_GRID)
    held = []
    print(f"leave-one-walk-out over {len(scores)} configurations ({', '.join(LOTO_GRID)}):")
    for k in walks:
        best = min(scores, key=lambda c: np.mean([v for j, v in scores[c].items() if j != k]))
        held.append(scores[best][k])
        print(f"  {k:<20} picks {best}: {scores[best][k]:5.2f} (chosen {scores[chosen][k]:5.2f})")
    inside = list(scores[chosen].values())
    print(f"median held out {np.median(held):.2f}, in-sample with the chosen {chosen}: "
          f"{np.median(inside):.2f}")  # fmt: skip


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=default_data_dir())
    p.add_argument("--loto", action="store_true", help="leave-one-walk-out of the foot's fit")
    args = p.parse_args()
    if args.data is None:
        raise SystemExit("no ../shared/data; give --data DIR")
    if args.loto:
        loto(args.data)
        return
    rows = table(args.data)
    print("foot tilt RMS error, deg (walks: against the 6-axis reference, offset removed; "
          "ref check: corr(reference rate, gyro_y))")  # fmt: skip
    print(f"{'trial':<22} {'paper':>6} {'live':>6} {'offline':>7}  live-paper  ref check")
    for name, pa, li, of, corr in rows:
        flag = "  WORSE" if li > pa + 1.0 else "       "
        print(f"{name:<22} {pa:6.1f} {li:6.1f} {of:7.1f}  {li - pa:+6.1f}{flag} {corr:6.3f}")
    walks = [r for r in rows if not r[0].startswith("broad")]
    if walks:
        arr = np.array([r[1:4] for r in walks])
        print(f"{'walks median':<22} " + " ".join(f"{v:6.1f}" for v in np.median(arr, 0)))
        print(f"{'walks worst':<22} " + " ".join(f"{v:6.1f}" for v in arr.max(0)))
    print(f"live worse than paper + 1 deg: {sum(r[2] > r[1] + 1.0 for r in rows)} of {len(rows)}")


if __name__ == "__main__":
    main()
