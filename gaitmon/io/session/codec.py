"""How a format-2 session stores its per-sample series: quantised, derived, or as they are.

Format 1 stores every per-sample series as its readers get it (float32, uncompressed). Format 2
(``docs/file-format.md``, "Storage") stores the same series in under a quarter of the space:

* **exact**: the raw counts, the timeline and the contact states as they are, shuffle + gzip;
* **quantised**: the processed float series as integers at a fixed resolution
  (:data:`RESOLUTION`: tilts at 0.01 deg as the unit's own protocol does, accelerations at
  0.005 m/s^2, low-passed force counts at 0.25 count), shuffle + gzip; ``stored = round(x /
  resolution)``, NaN stored as the dtype's minimum;
* **derived** on read, never stored (:data:`DERIVED`): the joint angles are pure functions of
  the tilts (computed in integer centidegrees, so exactly the difference of the stored tilts),
  and the bias-corrected gyro rate is the raw gyro count converted with the channel table,
  minus the calibration's gyro bias in force at that row.

The reader decodes whatever the file stores (:func:`decode`), so every caller gets the same
float32 arrays from format 1 and format 2 files. Nothing here needs a filter plugin: shuffle
and gzip ship with every HDF5 build.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from gaitmon.dsp.angles import JOINT_PAIRS

# filters of every format-2 per-sample dataset (HDF5 built-ins: any HDF5 tool reads them)
COMPRESSION = {"shuffle": True, "compression": "gzip", "compression_opts": 6}

CENTIDEG = 0.01
# path -> (stored dtype, resolution in the series' unit); quantised series of format 2
RESOLUTION: dict[str, tuple[np.dtype, float]] = {
    "processed/tilt_deg": (np.dtype("<i2"), CENTIDEG),
    "processed/tilt_acc_deg": (np.dtype("<i2"), CENTIDEG),
    "processed/tilt_gyro_deg": (np.dtype("<i2"), CENTIDEG),
    "processed/joint_deg": (np.dtype("<i2"), CENTIDEG),  # joint mode only (else derived)
    "processed/joint_acc_deg": (np.dtype("<i2"), CENTIDEG),  # joint mode only
    "processed/acc_ms2": (np.dtype("<i2"), 0.005),  # +-163 m/s2 (16.7 g)
    "processed/fsr_counts": (np.dtype("<i4"), 0.25),
    "smoothed/tilt_deg": (np.dtype("<i2"), CENTIDEG),
}

# derived series -> what they are computed from (format 2; joint mode stores its joints)
JOINT_OF: dict[str, str] = {
    "processed/joint_deg": "processed/tilt_deg",
    "processed/joint_acc_deg": "processed/tilt_acc_deg",
    "processed/joint_gyro_deg": "processed/tilt_gyro_deg",
    "smoothed/joint_deg": "smoothed/tilt_deg",
}
GYRO = "processed/gyro_rad_s"
DERIVED_RAW = (*JOINT_OF, GYRO)  # mode raw
DERIVED_TILT = ("processed/joint_deg", "processed/joint_acc_deg")  # mode tilt


def derived(mode: str, version: int) -> frozenset[str]:
    """The per-sample series a file of this mode and format version computes on read."""
    if version < 2:
        return frozenset()
    if mode == "raw":
        return frozenset(DERIVED_RAW)
    if mode == "tilt":
        return frozenset(DERIVED_TILT)
    return frozenset()


def tolerance(path: str, version: int = 2) -> float:
    """The largest difference format ``version`` promises between a series as read and the
    pipeline's float64 value, beyond float32 rounding: half the resolution of a quantised
    series, one resolution for a joint angle derived from two quantised tilts, else 0."""
    if version < 2:
        return 0.0
    if path in JOINT_OF:
        return RESOLUTION[JOINT_OF[path]][1]
    if path in RESOLUTION:
        return RESOLUTION[path][1] / 2
    return 0.0


def _nan_code(dtype: np.dtype) -> int:
    return int(np.iinfo(dtype).min)


def encode(path: str, data: np.ndarray) -> np.ndarray:
    """A series as format 2 stores it (quantised if it has a resolution, else unchanged)."""
    spec = RESOLUTION.get(path)
    if spec is None:
        return data
    return quantise(data, *spec)


def decode(path: str, stored: np.ndarray) -> np.ndarray:
    """Stored rows -> the float32 series readers get (monotonic: min/max commute with it)."""
    spec = RESOLUTION.get(path)
    if spec is None or stored.dtype.kind == "f":
        return stored
    return dequantise(stored, spec[1])


def quantise(data: np.ndarray, dtype: np.dtype, res: float) -> np.ndarray:
    """``round(x / res)`` as ``dtype`` (saturated), NaN as the dtype's minimum."""
    x = np.array(data, dtype=np.float64)  # a copy, worked on in place (fewer temporaries)
    np.divide(x, res, out=x)
    info = np.iinfo(dtype)
    bad = ~np.isfinite(x)
    any_bad = bool(bad.any())
    if any_bad:
        x[bad] = 0.0
    np.clip(x, info.min + 1, info.max, out=x)
    q = np.rint(x, out=x).astype(dtype)
    if any_bad:
        q[bad] = info.min
    return q


def dequantise(stored: np.ndarray, res: float) -> np.ndarray:
    """Integers at resolution ``res`` -> float32 (NaN where the dtype's minimum is stored):
    ``stored / (1 / res)`` correctly rounded, so a value the unit sent at 0.01 deg (-135.35)
    reads back as the float32 it was (a product with float32(0.01) would not). Monotonic, so
    min and max commute with it. Computed :data:`DECODE_BLOCK_ROWS` rows at a time (the
    float64 quotient of a whole 8-hour series is 69-92 MB; the values are elementwise, so the
    same)."""
    stored = np.asarray(stored)
    if stored.ndim == 0 or len(stored) <= DECODE_BLOCK_ROWS:
        return _dequantise(stored, res)
    out = np.empty(stored.shape, dtype=np.float32)
    for a in range(0, len(stored), DECODE_BLOCK_ROWS):
        out[a : a + DECODE_BLOCK_ROWS] = _dequantise(stored[a : a + DECODE_BLOCK_ROWS], res)
    return out


# rows decoded at a time (see dequantise)
DECODE_BLOCK_ROWS = 1 << 16


def _dequantise(stored: np.ndarray, res: float) -> np.ndarray:
    out = (stored / float(round(1.0 / res))).astype(np.float32)
    nan = stored == _nan_code(stored.dtype)
    if nan.any():
        out[nan] = np.nan
    return out


def joint_centideg(tilt_centideg: np.ndarray) -> np.ndarray:
    """(N, 4) int16 tilts in centidegrees -> (N, 3) hip, knee, ankle in centidegrees (int32),
    wrapped to (-18000, 18000] as :func:`gaitmon.dsp.angles.joint_angles` wraps to (-pi, pi]."""
    t = np.asarray(tilt_centideg, dtype=np.int32)
    plus = [p for p, _ in JOINT_PAIRS]
    minus = [m for _, m in JOINT_PAIRS]
    d = t[:, plus] - t[:, minus]
    d = np.where(d > 18000, d - 36000, d)
    return np.where(d <= -18000, d + 36000, d)


def joints_from_stored_tilts(stored: np.ndarray, tilt_path: str) -> np.ndarray:
    """(N, 3) float32 joint angles from a stored (int16 centidegree) tilt series; NaN where
    either tilt is NaN. Computed :data:`DECODE_BLOCK_ROWS` rows at a time (whole, an 8-hour
    series' int32 and float64 temporaries peaked at ~250 MB; elementwise, so the same values)."""
    stored = np.asarray(stored)
    if stored.dtype.kind == "f":  # (not expected in format 2; kept total)
        from gaitmon.dsp.angles import joint_angles

        return np.degrees(joint_angles(np.radians(stored))).astype(np.float32)
    if len(stored) <= DECODE_BLOCK_ROWS:
        return _joints_of_block(stored, tilt_path)
    out = np.empty((len(stored), len(JOINT_PAIRS)), dtype=np.float32)
    for a in range(0, len(stored), DECODE_BLOCK_ROWS):
        out[a : a + DECODE_BLOCK_ROWS] = _joints_of_block(stored[a : a + DECODE_BLOCK_ROWS],
                                                          tilt_path)  # fmt: skip
    return out


def _joints_of_block(stored: np.ndarray, tilt_path: str) -> np.ndarray:
    j = _dequantise(joint_centideg(stored), CENTIDEG)
    nan = stored == _nan_code(RESOLUTION[tilt_path][0])
    if nan.any():
        plus = np.array([p for p, _ in JOINT_PAIRS])
        minus = np.array([m for _, m in JOINT_PAIRS])
        j[nan[:, plus] | nan[:, minus]] = np.nan
    return j


def gyro_from_counts(
    adc: np.ndarray,
    start: int,
    to_physical: Callable[[np.ndarray], np.ndarray],
    gyro_idx: np.ndarray,
    bias_at: Sequence[tuple[int, np.ndarray]],
) -> np.ndarray:
    """(N, 4) float32 bias-corrected gyro rates of raw rows ``start:start + N``: the channel
    table's conversion minus the gyro bias in force at each row (``bias_at``: (first row,
    bias) in row order, the first at row 0), exactly as the pipeline computes them."""
    phys = to_physical(adc)[:, gyro_idx]
    n = len(phys)
    out = np.empty((n, len(gyro_idx)), np.float64)
    bounds = [(max(0, r - start), b) for r, b in bias_at]
    for k, (a, bias) in enumerate(bounds):
        b = bounds[k + 1][0] if k + 1 < len(bounds) else n
        a, b = min(a, n), min(b, n)
        if b > a:
            out[a:b] = phys[a:b] - bias
    return out.astype(np.float32)
