"""``/strides``: each stride's length and foot clearance from the foot IMU, stored at close.

The foot IMU's strapdown with zero-velocity updates (:mod:`gaitmon.dsp.stride_length`) costs
~0.35 CPU s per recorded hour plus reading every raw count (~0.07 s per hour): most of
``gaitmon info`` and the report of a long session, and it was paid on every analysis. Its
result depends only on the raw counts of the foot board, the channel table, the foot gyro bias
in force at each row, the sample rate and the heel strikes, none of which a user's exclusions
touch, so it is computed once, where ``/smoothed`` and ``/overview`` are (close, recovery,
``gaitmon process``), and stored:

    /strides/heel_strike_idx   (J,) int64     the heel strikes the strides run between
    /strides/stride_length_m   (J - 1,) float64
    /strides/foot_clearance_m  (J - 1,) float64
    /strides/foot_flat_idx     (J - 1, 2) int64
    /strides/flag              (J - 1,) int64  StrideMeasures.flag (FLAG_* bits; a store without
                                               it is computed again)
    /strides.attrs["computed_from"]   JSON: method and its constants, sample rate, rows, the
                                       foot channels' conversion, the foot gyro bias at each row

:func:`stride_measures_of` (through ``Session.foot_stride_measures``) is the one way every
reader gets them: from ``/strides`` when it was computed from exactly these inputs (the same
``computed_from`` and the same heel strikes), else computed on the fly by the same function that
stored them (:func:`compute`). So a file written before ``/strides`` existed, a store made with
other heel strikes (``gaitmon process`` with other settings, review's in-memory reprocessing),
another rate or another method version all give the numbers of the computation itself.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import h5py
import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, GYRO_IDX, SEGMENTS, ChannelTable
from gaitmon.dsp.lost_frames import Losses, bridged_rows
from gaitmon.dsp.stride_flags import StrideMeasures
from gaitmon.dsp.stride_method import METHOD
from gaitmon.io.session.codec import COMPRESSION
from gaitmon.io.session.layout import stored_datasets
from gaitmon.io.session.series import attr_text

log = logging.getLogger("gaitmon.session")

GROUP = "strides"
_FOOT = SEGMENTS.index("foot")
_FOOT_COLS = (int(ACC_X_IDX[_FOOT]), int(ACC_Z_IDX[_FOOT]), int(GYRO_IDX[_FOOT]))

_STAMP_BLOCK_ROWS = 1 << 20  # rows of the filled-in frames hashed at a time

ReadCounts = Callable[[int, int], np.ndarray]  # rows [a, b) of /raw/adc


@dataclass(frozen=True)
class StrideInputs:
    """What the measures of a record depend on besides its raw counts' values and the heel
    strikes: ``Session.foot_stride_measures`` fills it from the reader, the close path from
    what it wrote."""

    n_rows: int
    fs_hz: float
    table: ChannelTable
    calibration: Calibration
    calibration_changes: Sequence[tuple[int, Calibration]]
    # (n_rows,) frames lost just before each row (the gap table's, lost_before_from_gaps), or
    # only the rows with losses (Losses: the close's, no per-row array): the losses the
    # pipeline bridges are filled in (gaitmon.dsp.stride_length); None: none
    lost_before: np.ndarray | Losses | None = None

    def _losses(self) -> Losses:
        lost = self.lost_before
        if lost is None:
            return Losses(np.empty(0, np.int64), np.empty(0, np.int64))
        if isinstance(lost, Losses):
            keep = lost.rows < self.n_rows
            return Losses(lost.rows[keep], lost.n_lost[keep])
        return Losses.of(np.asarray(lost)[: self.n_rows])

    def filled(self) -> np.ndarray:
        """(n_rows,) the frames filled in before each row (gaitmon.dsp.lost_frames.bridged_fill)."""
        fill = np.zeros(self.n_rows, dtype=np.int64)
        rows, k = bridged_rows(self._losses(), self.fs_hz)
        fill[rows] = k
        return fill

    def positions(self, rows: np.ndarray) -> np.ndarray:
        """The position on the true timeline of each of ``rows`` (rows of the record): the row
        plus the frames filled in before it and every earlier row, ``(arange(n) +
        cumsum(filled()))[rows]`` from the filled rows alone (four per-row int64 arrays were
        ~90 MB for 8 hours, in every ``info`` and report)."""
        rows = np.asarray(rows, dtype=np.int64)
        at, k = bridged_rows(self._losses(), self.fs_hz)
        if not len(at):
            return rows.copy()
        before = np.concatenate(([0], np.cumsum(np.asarray(k, dtype=np.int64))))
        return rows + before[np.searchsorted(np.asarray(at, dtype=np.int64), rows, side="right")]

    def _filled_stamp(self) -> dict[str, object]:
        """The lost frames filled in (how many, and the SHA-1 of :meth:`filled` as little-endian
        int64), hashed a block of rows at a time; {} when none are."""
        rows, k = bridged_rows(self._losses(), self.fs_hz)
        if not len(rows):
            return {}
        import hashlib  # a record with lost frames filled in (~3 ms for the others)

        sha = hashlib.sha1()
        for a in range(0, self.n_rows, _STAMP_BLOCK_ROWS):
            b = min(self.n_rows, a + _STAMP_BLOCK_ROWS)
            block = np.zeros(b - a, dtype="<i8")
            lo, hi = np.searchsorted(rows, [a, b])
            block[rows[lo:hi] - a] = k[lo:hi]
            sha.update(block.tobytes())
        return {"filled_frames": int(k.sum()), "filled_sha1": sha.hexdigest()}

    def stamp(self) -> str:
        """The ``computed_from`` a stored ``/strides`` must carry to be used (JSON)."""
        changes = sorted(self.calibration_changes, key=lambda x: x[0])  # as they are applied
        # the lost frames filled in (where, how many): a record without any keeps the stamp
        # it had before they were
        lost = self._filled_stamp()
        return json.dumps({
            **lost,
            "method": METHOD,
            "sample_rate_hz": float(self.fs_hz),
            "n_rows": int(self.n_rows),
            "zero_counts": [float(self.table.zero_counts[c]) for c in _FOOT_COLS],
            "units_per_count": [float(self.table.units_per_count[c]) for c in _FOOT_COLS],
            "gyro_bias_rad_s": [[0, float(self.calibration.gyro_bias_rad_s[_FOOT])],
                                *[[int(r), float(c.gyro_bias_rad_s[_FOOT])] for r, c in changes]],
        }, sort_keys=True)  # fmt: skip


def heel_strikes_used(heel_strike_idx: np.ndarray, n_rows: int) -> np.ndarray:
    """The heel strikes the measures run between: distinct, sorted, inside the record."""
    # np.unique's values, by a sort: np.unique imports numpy.ma (~20 ms of gaitmon info)
    hs = np.sort(np.asarray(heel_strike_idx, dtype=np.int64).ravel())
    hs = hs[np.concatenate(([True], hs[1:] != hs[:-1]))] if len(hs) else hs
    return hs[hs < n_rows]


def compute(read_counts: ReadCounts, inputs: StrideInputs, hs: np.ndarray) -> StrideMeasures:
    """The measures of the strides between heel strikes ``hs`` (:func:`heel_strikes_used`),
    computed from the raw counts a block of strides at a time: the one computation behind
    both the stored and the computed-when-read measures."""
    # the computation, where measures are computed (a reader of stored ones needs only METHOD)
    from gaitmon.dsp.stride_length import foot_imu_from_counts, record_stride_measures

    def read_foot(a: int, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return foot_imu_from_counts(read_counts(a, b), a, inputs.table, inputs.calibration,
                                    inputs.calibration_changes)  # fmt: skip

    lost = None if inputs.lost_before is None else inputs._losses()
    return record_stride_measures(read_foot, inputs.n_rows, inputs.fs_hz, hs, lost_before=lost)


def read_stored(f: h5py.File, inputs: StrideInputs, hs: np.ndarray) -> StrideMeasures | None:
    """The stored measures if ``/strides`` was computed from these inputs and heel strikes,
    else None (none stored, stale or damaged)."""
    g = f.get(GROUP)
    if not isinstance(g, h5py.Group):
        return None
    try:
        stamp = g.attrs.get("computed_from", "")
        if attr_text(stamp) != inputs.stamp():
            return None
        stored_hs = np.asarray(g["heel_strike_idx"][()], dtype=np.int64)
        if not np.array_equal(stored_hs, hs):
            return None
        length = np.asarray(g["stride_length_m"][()], dtype=np.float64)
        clearance = np.asarray(g["foot_clearance_m"][()], dtype=np.float64)
        flats = np.asarray(g["foot_flat_idx"][()], dtype=np.int64)
        flag = np.asarray(g["flag"][()], dtype=np.int64)
    except (OSError, RuntimeError, ValueError, KeyError, TypeError):
        return None  # a damaged store: computed instead
    k = max(len(hs) - 1, 0)
    if (length.shape != (k,) or clearance.shape != (k,) or flats.shape != (k, 2)
            or flag.shape != (k,)):  # fmt: skip
        return None
    # the stride times on the true timeline: the lost frames filled in count
    hs_t = inputs.positions(hs)  # (heel_strikes_used: rows of the record)
    return StrideMeasures(
        heel_strike_idx=hs[:k],
        stride_length_m=length,
        foot_clearance_m=clearance,
        stride_time_s=np.diff(hs_t).astype(np.float64) / inputs.fs_hz,
        foot_flat_idx=flats,
        flag=flag,
    )


def stride_measures_of(
    f: h5py.File, read_counts: ReadCounts, inputs: StrideInputs, heel_strike_idx: np.ndarray
) -> StrideMeasures:
    """Stride length and foot clearance of the strides between ``heel_strike_idx`` (repeats
    and rows past the record dropped): stored, or computed (module doc)."""
    hs = heel_strikes_used(heel_strike_idx, inputs.n_rows)
    got = read_stored(f, inputs, hs)
    return got if got is not None else compute(read_counts, inputs, hs)


def write_strides(f: h5py.File, inputs: StrideInputs, hs: np.ndarray, m: StrideMeasures) -> None:
    """Store (or replace) ``/strides`` in ``f`` (open for writing)."""
    from gaitmon.io.session.attributes import describe  # a writer's (readers: ~1 ms saved)

    if GROUP in f:
        del f[GROUP]
    g = f.create_group(GROUP)
    opts = COMPRESSION if int(f.attrs.get("format_version", 1)) >= 2 else {}
    for name, data in (("heel_strike_idx", hs), ("stride_length_m", m.stride_length_m),
                       ("foot_clearance_m", m.foot_clearance_m),
                       ("foot_flat_idx", m.foot_flat_idx), ("flag", m.flags)):  # fmt: skip
        g.create_dataset(name, data=data, **(opts if len(data) else {}))
    g.attrs["computed_from"] = inputs.stamp()
    describe(f)




def store_strides(
    f: h5py.File, table: ChannelTable, calibration: Calibration, fs_hz: float,
    *, keep_valid: bool = False,
) -> None:  # fmt: skip
    """Compute and store ``/strides`` of the raw-mode session open (writable) in ``f``, from
    what the file holds: called where a session is finished (close, recovery, ``gaitmon
    process``) once its raw counts, events and calibration changes are all written. Data the
    method rejects only leave the measures to be computed when read (logged); a write error
    raises as any write of the close does. ``keep_valid`` (``gaitmon process``, whose copy
    holds the recording's own): measures stored from the same inputs and heel strikes (their
    ``computed_from`` stamp, :func:`read_stored`) are kept, not computed again."""
    if attr_text(f.attrs.get("mode", "")) != "raw" or "raw/adc" not in f:
        return
    try:
        # the rows every per-sample dataset has: what the reader will call the record
        version = int(f.attrs.get("format_version", 1))
        n = min(f[p].shape[0] for p in stored_datasets("raw", version))
        changes = [(int(r["sample_idx"]), Calibration.from_dict(json.loads(attr_text(r["json"]))))
                   for r in f["calibration/changes"][()]]  # fmt: skip
        from gaitmon.io.session.rows import losses_from_gaps

        # sparse: the close holds no per-row array (issue 26)
        lost = losses_from_gaps(f["gaps"][()], n) if "gaps" in f else None
        inputs = StrideInputs(n, float(fs_hz), table, calibration, changes, lost)
        hs = heel_strikes_used(f["events/heel_strike"][()], n)
        if keep_valid and read_stored(f, inputs, hs) is not None:
            return  # (the same numbers: a function of the stamped inputs and the heel strikes)
        adc = f["raw/adc"]
        m = compute(lambda a, b: adc[a:b], inputs, hs)
    except (ValueError, FloatingPointError, KeyError, TypeError) as e:
        log.warning("stride measures not stored in %s: %s", f.filename, e)
        return
    write_strides(f, inputs, hs, m)

