"""Readers of the real recordings in ../shared/data (its README.md and each folder's README).

Library code cannot import the folders' own ``load.py``; these are the same few lines, numpy
and h5py only. Every IMU trial comes as an :class:`ImuTrial` in the unit's board frame (x up
along the segment when standing, z forward, y to the subject's right; tilt =
atan2(acc_z, acc_x), toe-up positive; gyro_y toe-up positive), 100 Hz:

* ``broad``: BROAD (Laidig et al. 2021, CC BY 4.0), 4 trials, resampled 2000/7 Hz -> 100 Hz
  (``resample_poly(x, 7, 20)``); the board frame is the sensor's own axes; ``ref_tilt_rad`` is
  the optical reference's planar tilt atan2(u_z, u_x) of the earth-up vector u in sensor axes,
  ``ref_valid`` where it is meaningful (tracking kept, |u_y| < 0.5, after the first 2 s).
* ``gdins_footprints``: 16 foot-IMU walks with a measured footprint per stride (MIT). The
  dataset's foot frame is x forward, y left, z up: board acc_x = foot acc z, board acc_z = foot
  acc x, board gyro_y = foot gyro_y; ``acc_xyz``/``gyr_xyz`` are the 3-D foot-frame arrays.
  ``extra``: ``ref_stride_length``, ``zv_end_idx``, ``footprint_xy``, ``stride_time``.
* ``xio_closed_loop_walks``: two closed-loop walks (MIT), the same layout; ``extra``:
  ``stance_intervals`` (IMU-detected, not a reference), ``approx_path_length_m`` (the source
  README's ~25 and ~60 m) and ``ref_3d_path_m`` (the data README's 3-D ZUPT path, 22.7 / 56.8 m).

``gaitpdb`` (PhysioNet, ODC-By) has no IMU: :class:`ForceTrial`, 19 whitespace-separated
columns (time, L1..L8, R1..R8, total L, total R), heel = sensor 1, toe = sensor 8.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

FS = 100.0
BROAD_TRIALS = (
    "02_undisturbed_slow_rotation_B",
    "07_undisturbed_fast_rotation_B",
    "16_undisturbed_fast_translation_B",
    "24_disturbed_tapping_A",
)
XIO_REFERENCE = {  # the data README: source README's approximate length; 3-D ZUPT path
    "short_walk": (25.0, 22.7),
    "long_walk": (60.0, 56.8),
}
DATASETS = ("broad", "gdins_footprints", "xio_closed_loop_walks", "gaitpdb")


@dataclass(frozen=True)
class ImuTrial:
    """One real IMU recording in the unit's board frame (module doc)."""

    dataset: str
    name: str
    fs_hz: float
    acc_x: np.ndarray  # (N,) m/s^2, board x (up along the segment)
    acc_z: np.ndarray  # (N,) m/s^2, board z (forward)
    gyro_y: np.ndarray  # (N,) rad/s, toe-up positive, raw (no bias removed)
    acc_xyz: np.ndarray | None = None  # (N, 3) foot frame x fwd, y left, z up (gdins, xio)
    gyr_xyz: np.ndarray | None = None
    ref_tilt_rad: np.ndarray | None = None  # optical reference (BROAD)
    ref_valid: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.acc_x)

    @property
    def duration_s(self) -> float:
        return len(self) / self.fs_hz


@dataclass(frozen=True)
class ForceTrial:
    """gaitpdb: insole forces (N) of both feet at 100 Hz."""

    name: str
    fs_hz: float
    time_s: np.ndarray
    heel: dict[str, np.ndarray]  # "left" | "right" -> sensor 1's force
    toe: dict[str, np.ndarray]  # sensor 8's
    total: dict[str, np.ndarray]  # the foot's total force

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0]) + 1.0 / self.fs_hz


def available(root: Path | None) -> dict[str, bool]:
    """Which of :data:`DATASETS` are in ``root``."""
    return {
        name: root is not None and (root / name).is_dir() and any((root / name).iterdir())
        for name in DATASETS
    }


def read_broad(root: Path) -> list[ImuTrial]:
    import h5py
    from scipy import signal

    out = []
    for trial in BROAD_TRIALS:
        path = root / "broad" / f"{trial}.hdf5"
        if not path.is_file():
            continue
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
        valid[:200] = False
        out.append(ImuTrial(
            "broad", trial, FS, a100[:, 0], a100[:, 2], g100[:, 1],
            ref_tilt_rad=np.arctan2(up100[:, 2], up100[:, 0]), ref_valid=valid,
        ))  # fmt: skip
    return out


def _npz_trial(dataset: str, path: Path, keys: tuple[str, ...]) -> ImuTrial:
    z = np.load(path)
    extra = {k: np.asarray(z[k]) for k in keys if k in z}
    return ImuTrial(
        dataset, path.stem, float(z["fs"]),
        acc_x=z["foot_acc_z"].astype(np.float64),  # board x = the sole normal (up)
        acc_z=z["foot_acc_x"].astype(np.float64),  # board z = forward
        gyro_y=z["foot_gyro_y"].astype(np.float64),
        acc_xyz=z["foot_acc_xyz"].astype(np.float64),
        gyr_xyz=z["foot_gyr_xyz"].astype(np.float64),
        extra=extra,
    )  # fmt: skip


def read_gdins(root: Path) -> list[ImuTrial]:
    keys = ("ref_stride_length", "zv_end_idx", "footprint_xy", "stride_time")
    return [_npz_trial("gdins_footprints", p, keys)
            for p in sorted((root / "gdins_footprints" / "trials").glob("exp*.npz"))]  # fmt: skip


def read_xio(root: Path) -> list[ImuTrial]:
    out = []
    for p in sorted((root / "xio_closed_loop_walks" / "trials").glob("*.npz")):
        t = _npz_trial("xio_closed_loop_walks", p, ("stance_intervals",))
        approx, path3d = XIO_REFERENCE.get(p.stem, (np.nan, np.nan))
        t.extra["approx_path_length_m"] = np.asarray(approx)
        t.extra["ref_3d_path_m"] = np.asarray(path3d)
        out.append(t)
    return out


def read_gaitpdb(root: Path) -> list[ForceTrial]:
    out = []
    for p in sorted((root / "gaitpdb").glob("*.txt")):
        d = np.loadtxt(p)
        if d.ndim != 2 or d.shape[1] != 19:
            raise ValueError(f"{p}: expected 19 columns, got {d.shape}")
        fs = round((d.shape[0] - 1) / (d[-1, 0] - d[0, 0]), 3)
        out.append(ForceTrial(
            p.stem, fs, d[:, 0],
            heel={"left": d[:, 1], "right": d[:, 9]},
            toe={"left": d[:, 8], "right": d[:, 16]},
            total={"left": d[:, 17], "right": d[:, 18]},
        ))  # fmt: skip
    return out


def gyro_bias_at_start(trial: ImuTrial, max_s: float = 1.0) -> float:
    """The board gyro's bias as the app's standing calibration would take it: the mean over the
    still samples the recording starts with (up to ``max_s``; 0 when it does not start still).
    BROAD: the mean over samples 20-100 (its first second at rest, as tests/test_broad.py)."""
    if trial.dataset == "broad":
        return float(np.mean(trial.gyro_y[20:100]))
    n = int(max_s * trial.fs_hz)
    g = trial.gyro_y[:n]
    acc = np.hypot(trial.acc_x[:n], trial.acc_z[:n])
    moving = (np.abs(g) > 0.3) | (np.abs(acc - np.median(acc)) > 0.8)
    end = int(np.argmax(moving)) if moving.any() else len(g)
    return float(np.mean(g[:end])) if end >= 10 else 0.0
