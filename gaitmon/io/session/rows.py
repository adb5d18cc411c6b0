"""Blocks to rows: the ``/processed`` rows of a pipeline or device block, and the timeline.

The live writer and the recovery both turn blocks into rows here, so they write identical files.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from typing import TYPE_CHECKING, Protocol

import h5py
import numpy as np

from gaitmon.dsp.angles import joint_angles, wrap_angle
from gaitmon.dsp.lost_frames import Losses
from gaitmon.io.session.layout import _F4

if TYPE_CHECKING:  # a reader (the gaps' lost frames) needs neither the pipeline nor the wire
    import numpy.typing as npt  # (nor numpy.typing, ~0.6 ms)

    from gaitmon.dsp.fsr_check import FsrFault
    from gaitmon.dsp.pipeline import PipelineBlock
    from gaitmon.io.protocol import FrameKind


def _deg32(x_rad: np.ndarray) -> np.ndarray:
    return np.degrees(x_rad).astype(_F4)


# the ``/processed`` rows of a raw-mode pipeline block: path -> its value from the block
_PIPELINE_ROWS: dict[str, Callable[[PipelineBlock], np.ndarray]] = {
    "processed/tilt_deg": lambda b: _deg32(b.tilt_kalman_rad),
    "processed/tilt_acc_deg": lambda b: _deg32(b.tilt_acc_rad),
    "processed/tilt_gyro_deg": lambda b: _deg32(b.tilt_gyro_rad),
    "processed/joint_deg": lambda b: _deg32(b.joint_kalman_rad),
    "processed/joint_acc_deg": lambda b: _deg32(b.joint_acc_rad),
    "processed/joint_gyro_deg": lambda b: _deg32(b.joint_gyro_rad),
    "processed/acc_ms2": lambda b: b.acc_ms2.astype(_F4),
    "processed/gyro_rad_s": lambda b: b.gyro_rad_s.astype(_F4),
    "processed/fsr_counts": lambda b: b.fsr_counts.astype(_F4),
    "processed/heel_loaded": lambda b: b.heel_loaded.astype(np.uint8),
    "processed/toe_loaded": lambda b: b.toe_loaded.astype(np.uint8),
    "processed/phase": lambda b: b.phase.astype(np.int8),
}
PIPELINE_ROWS = tuple(_PIPELINE_ROWS)
JOINT_ROWS = tuple(p for p in PIPELINE_ROWS if p.startswith("processed/joint_"))


def stored_pipeline_rows(group: h5py.Group) -> list[str]:
    """The ``/processed`` rows of :data:`PIPELINE_ROWS` that ``group`` (a session file, or a
    unit of one) stores: a format-2 file derives the joint angles and gyro rates on read, so
    a replay that writes it need not make them (``replay_pipeline(only=...)``)."""
    return [p for p in PIPELINE_ROWS if p in group]


def rows_from_pipeline(
    block: PipelineBlock, only: Collection[str] | None = None
) -> dict[str, np.ndarray]:
    """The ``/processed`` rows of a raw-mode block (angles in degrees, float32); ``only``
    those of these paths (a file that derives some on read stores the others)."""
    return {path: row(block) for path, row in _PIPELINE_ROWS.items()
            if only is None or path in only}  # fmt: skip


def fault_rows(
    faults: Sequence[FsrFault], block_start_idx: int, first_row: int
) -> list[tuple[int, int, str, str]]:
    """``/events/fsr_faults`` records of the faults a pipeline block flagged, whose sample
    ``block_start_idx`` is row ``first_row`` (a fault's decision row can lie a little past the
    block, see gaitmon.dsp.fsr_check; one known before the recording started is known from
    ``first_row``, and its failing strides start at row 0 at the earliest)."""
    out = []
    for f in faults:
        decided = max(first_row + int(f.decided_idx) - block_start_idx, first_row)
        start = min(max(first_row + int(f.stride_start_idx) - block_start_idx, 0), decided)
        out.append((decided, start, f.sensor, f.reason))
    return out


class LazyRows:
    """The first ``n`` rows of an array-like (an h5py dataset, a field of a structured array)
    read only when sliced, as C-contiguous copies: a whole recording's raw counts handed to
    :func:`gaitmon.finish.recovery.replay_pipeline` or the smoother without reading them
    all into memory at once."""

    def __init__(
        self, data: np.ndarray | h5py.Dataset, n: int | None = None,
        dtype: npt.DTypeLike | None = None,
    ) -> None:  # fmt: skip
        self._data = data
        self._n = len(data) if n is None else int(n)
        self._dtype = dtype  # None: as stored

    def __len__(self) -> int:
        return self._n

    def rows(self, a: int, b: int) -> np.ndarray:
        """Rows a:b (clipped to the first ``n``)."""
        return np.ascontiguousarray(self._data[max(0, a) : min(b, self._n)], dtype=self._dtype)

    def __getitem__(self, key: slice) -> np.ndarray:
        if not isinstance(key, slice) or key.step not in (None, 1):
            raise TypeError("LazyRows takes row slices a:b only")
        a, b, _ = key.indices(self._n)
        return self.rows(a, b)


class GapRow(Protocol):
    """A gap as a reader gives it (:class:`~gaitmon.io.session.series.Gap`)."""

    @property
    def sample_idx(self) -> int: ...

    @property
    def n_lost(self) -> int: ...


def losses_from_gaps(gaps: Sequence[GapRow] | np.ndarray, n_rows: int) -> Losses:
    """The rows of ``[0, n_rows)`` with frames lost just before them and how many (gaps at one
    row add up), from a session's gap table (a reader's gaps, or the file's ``/gaps`` table, a
    structured array): :func:`lost_before_from_gaps` without a value for every row (a per-row
    array grows with the record; the gaps do not)."""
    acc: dict[int, int] = {}
    for g in gaps:
        if isinstance(g, np.void):  # a row of the table
            idx, n_lost = int(g["sample_idx"]), int(g["n_lost"])
        else:
            idx, n_lost = int(g.sample_idx), int(g.n_lost)
        if 0 <= idx < n_rows:
            acc[idx] = acc.get(idx, 0) + n_lost
    rows = np.array(sorted(acc), dtype=np.int64)
    return Losses(rows, np.array([acc[int(r)] for r in rows], dtype=np.int64))


class LostRows:
    """The frames lost before each of ``n`` rows as a per-row array's slices, from the sparse
    :class:`~gaitmon.dsp.lost_frames.Losses`: ``lost[a:b]`` equals ``lost_before_from_gaps(
    ...)[a:b]`` without a value for every row of the record in memory (8 bytes a row: 23 MB
    for 8 hours), for :func:`gaitmon.finish.recovery.replay_pipeline`."""

    def __init__(self, losses: Losses, n: int) -> None:
        keep = (losses.rows >= 0) & (losses.rows < n)
        self.losses = Losses(np.asarray(losses.rows[keep], np.int64),
                             np.asarray(losses.n_lost[keep], np.int64))  # fmt: skip
        self._n = int(n)

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, key: slice) -> np.ndarray:
        if not isinstance(key, slice) or key.step not in (None, 1):
            raise TypeError("LostRows takes row slices a:b only")
        a, b, _ = key.indices(self._n)
        out = np.zeros(max(0, b - a), dtype=np.int64)
        lo, hi = np.searchsorted(self.losses.rows, [a, b])
        out[self.losses.rows[lo:hi] - a] = self.losses.n_lost[lo:hi]
        return out


def lost_before_from_gaps(gaps: Sequence[GapRow] | np.ndarray, n_rows: int) -> np.ndarray:
    """Frames lost just before each row, from a session's gap table (gaps at one row add up):
    a reader's gaps, or the file's ``/gaps`` table (a structured array)."""
    lost = np.zeros(n_rows, dtype=np.int64)
    rows, n_lost = losses_from_gaps(gaps, n_rows)
    lost[rows] = n_lost
    return lost


def _joints_deg_from_tilts_deg(tilt_deg: np.ndarray) -> np.ndarray:
    return _deg32(joint_angles(wrap_angle(np.radians(tilt_deg))))


def _device_rows(kind: FrameKind, cols: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    from gaitmon.io.protocol import FrameKind

    if kind == FrameKind.TILT:
        kal = np.asarray(cols["kalman_tilt_deg"], dtype=np.float64)
        acc = np.asarray(cols["acc_tilt_deg"], dtype=np.float64)
        return {
            "processed/tilt_deg": kal.astype(_F4),
            "processed/tilt_acc_deg": acc.astype(_F4),
            "processed/joint_deg": _joints_deg_from_tilts_deg(kal),
            "processed/joint_acc_deg": _joints_deg_from_tilts_deg(acc),
        }
    if kind == FrameKind.JOINT:
        return {
            "processed/joint_deg": np.asarray(cols["kalman_joint_deg"]).astype(_F4),
            "processed/joint_acc_deg": np.asarray(cols["acc_joint_deg"]).astype(_F4),
            "processed/heel_loaded": np.asarray(cols["heel_loaded"]).astype(np.uint8),
            "processed/toe_loaded": np.asarray(cols["toe_loaded"]).astype(np.uint8),
            "processed/phase": np.asarray(cols["phase"]).astype(np.int8),
        }
    raise ValueError(f"device rows need a TILT or JOINT block, got {kind!r}")


class _Timeline:
    """``/timeline/t_s`` = k / fs + extra. ``k`` counts the unit's samples from row 0: each row
    advances it by 1 + the frames lost just before it (sequence numbers cannot be used
    directly: the unit's control frames share the counter). ``extra`` grows only at a gap row
    whose recorded duration is longer than that step (the unit restarted or stopped counting
    during an outage). Integer ``k`` and one formula make the live writer and the recovery,
    which sees all rows at once, give bit-identical times, with no drift over hours."""

    def __init__(self, fs_hz: float) -> None:
        self.fs_hz = fs_hz
        self.k_last: int | None = None
        self.extra_s = 0.0

    def times(self, lost_before: np.ndarray, gap_duration_s: float | None) -> np.ndarray:
        steps = np.asarray(lost_before, dtype=np.int64) + 1
        k = np.cumsum(steps)
        if self.k_last is None:
            k -= k[0]  # row 0 is time 0, whatever was lost before the recording
        else:
            if gap_duration_s is not None:
                step_s = int(steps[0]) / self.fs_hz
                self.extra_s += max(0.0, gap_duration_s + 1.0 / self.fs_hz - step_s)
            k += self.k_last
        self.k_last = int(k[-1])
        return k / self.fs_hz + self.extra_s


def _extrapolated_t(t_last: float | None, idx: int, rows: int, fs: float) -> float:
    if t_last is None:
        return idx / fs
    return t_last + (idx - (rows - 1)) / fs
