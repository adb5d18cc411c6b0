"""The display ring buffers: which series a viewer gets, and how engine blocks become them.

``SERIES`` is the one list of display columns. ``cols_from_pipeline`` (raw mode, everything
computed on the PC) and ``cols_from_device`` (the unit's own angles) turn a block into those
columns; a series a block does not carry is shown as NaN.

Lost frames are rows too: ``with_gap_rows`` puts one row per lost frame (at most a ring's
worth) before the row that followed them, at its true time, with every value NaN and
``lost`` = 1. So time stays true on screen, lines break across an outage instead of joining
its two ends, and no phase or event can be drawn there. ``idx`` is the engine's index of a
received sample (NaN on a lost row): events and strides, which carry engine indices, find their
rows and times through it (``RingBuffer.times_of``, ``RingBuffer.since_index``).
"""

from __future__ import annotations

import threading

import numpy as np

from gaitmon.dsp.angles import joint_angles
from gaitmon.dsp.channel_table import N_FSR, N_JOINTS, N_SEGMENTS
from gaitmon.dsp.gait import phase_from_contacts
from gaitmon.dsp.pipeline import PipelineBlock
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind

# name -> per-sample shape; every series is float64 (bools as 0/1) so a snapshot is uniform
SERIES: dict[str, tuple[int, ...]] = {
    "t_s": (),
    "host_time_s": (),
    "idx": (),  # engine sample index; NaN on a lost row
    "lost": (),  # 1 on a row standing for a lost frame
    "settling": (),  # 1 while the filters settle after a gap (raw mode)
    "tilt_acc_deg": (N_SEGMENTS,),
    "tilt_gyro_deg": (N_SEGMENTS,),
    "tilt_kalman_deg": (N_SEGMENTS,),
    "joint_acc_deg": (N_JOINTS,),
    "joint_gyro_deg": (N_JOINTS,),
    "joint_kalman_deg": (N_JOINTS,),
    "acc_ms2": (N_SEGMENTS, 2),
    "gyro_rad_s": (N_SEGMENTS,),
    "fsr_counts": (N_FSR,),
    "heel_loaded": (),
    "toe_loaded": (),
    "phase": (),
}


class RingBuffer:
    """Fixed-capacity, multi-series ring of the most recent samples (one writer, one reader)."""

    def __init__(self, capacity: int) -> None:
        self.capacity = int(capacity)
        self._data = {k: np.full((self.capacity, *s), np.nan) for k, s in SERIES.items()}
        self._write = 0  # total samples ever written
        self._lock = threading.Lock()

    def append(self, cols: dict[str, np.ndarray]) -> None:
        n = len(cols["t_s"])
        if n == 0:
            return
        if n > self.capacity:
            cols = {k: v[-self.capacity :] for k, v in cols.items()}
            skipped = n - self.capacity
            n = self.capacity
        else:
            skipped = 0
        with self._lock:
            start = (self._write + skipped) % self.capacity
            first = min(n, self.capacity - start)
            for k, arr in self._data.items():
                v = cols.get(k)
                if v is None:
                    arr[start : start + first] = np.nan
                    arr[: n - first] = np.nan
                    continue
                arr[start : start + first] = v[:first]
                arr[: n - first] = v[first:]
            self._write += n + skipped

    def _latest_cols(self, n: int, names: tuple[str, ...]) -> dict[str, np.ndarray]:
        with self._lock:
            n = int(min(n, self.capacity, self._write))
            end = self._write % self.capacity
            return {k: _last_rows(self._data[k], end, n) for k in names}

    def times_of(self, engine_idx: np.ndarray) -> np.ndarray:
        """True times (t_s) of the samples with these engine indices (NaN if no longer held)."""
        want = np.asarray(engine_idx, dtype=np.float64)
        got = self._latest_cols(self.capacity, ("idx", "t_s"))
        real = np.isfinite(got["idx"])
        idx, t = got["idx"][real], got["t_s"][real]
        out = np.full(want.shape, np.nan)
        if not len(idx):
            return out
        pos = np.clip(np.searchsorted(idx, want), 0, len(idx) - 1)
        hit = idx[pos] == want
        out[hit] = t[pos[hit]]
        return out

    def since_index(self, engine_idx: int) -> dict[str, np.ndarray]:
        """The rows from the sample with engine index ``engine_idx`` on (lost rows included);
        empty if that sample is no longer held."""
        got = self._latest_cols(self.capacity, ("idx",))["idx"]
        pos = np.flatnonzero(got == engine_idx)
        if not len(pos):
            return {k: np.empty((0, *s)) for k, s in SERIES.items()}
        return self.latest(len(got) - int(pos[0]))

    def latest(self, n: int) -> dict[str, np.ndarray]:
        """Copies of the last ``n`` samples (fewer if fewer were written), oldest first."""
        with self._lock:
            n = int(min(n, self.capacity, self._write))
            end = self._write % self.capacity
            return {k: _last_rows(arr, end, n) for k, arr in self._data.items()}


def _last_rows(arr: np.ndarray, end: int, n: int) -> np.ndarray:
    """A copy of the ``n`` rows of a ring ``arr`` before row ``end``, oldest first: one or two
    slices (a snapshot ~30 times a second; an index array of every row cost ~3x more)."""
    start = end - n
    if start >= 0:
        return arr[start:end].copy()
    return np.concatenate([arr[start:], arr[:end]])


CONTACT_SERIES = ("heel_loaded", "toe_loaded", "phase")


def on_event_time(series: dict[str, np.ndarray], lag: int) -> dict[str, np.ndarray]:
    """``series`` with the contacts and the phase moved ``lag`` rows earlier, onto the time base
    of the events (see ``PipelineConfig.phase_lag_samples``); the newest ``lag`` rows have no
    phase yet (NaN: nothing is drawn there until the detector has decided), and a lost row
    has none either."""
    if lag <= 0:
        return series
    out = dict(series)
    lost = series["lost"] > 0
    for k in CONTACT_SERIES:
        v = series[k]
        moved = np.full_like(v, np.nan)
        moved[: max(0, len(v) - lag)] = v[lag:]
        moved[lost] = np.nan
        out[k] = moved
    return out


def with_gap_rows(
    cols: dict[str, np.ndarray], lost_before: np.ndarray, fs_hz: float, max_rows: int
) -> dict[str, np.ndarray]:
    """``cols`` with a NaN row (``lost`` = 1, true ``t_s``) for every frame lost before each
    row, at most ``max_rows`` per gap (a ring holds no more)."""
    n = len(cols["t_s"])
    lost = np.minimum(np.asarray(lost_before, dtype=np.int64), max_rows)
    if n == 0 or not lost.any():
        return {**cols, "lost": np.zeros(n)}
    pos = np.arange(n) + np.cumsum(lost)  # where each received row goes
    total = n + int(lost.sum())
    out: dict[str, np.ndarray] = {}
    for k, v in cols.items():
        arr = np.full((total, *v.shape[1:]), np.nan)
        arr[pos] = v
        out[k] = arr
    gap = np.ones(total, dtype=bool)
    gap[pos] = False
    rows = np.flatnonzero(gap)
    owner = np.searchsorted(pos, rows)  # the received row after each lost one
    out["t_s"][rows] = cols["t_s"][owner] - (pos[owner] - rows) / fs_hz
    out["lost"] = gap.astype(np.float64)
    return out


def cols_from_pipeline(
    p: PipelineBlock, t_s: np.ndarray, host: np.ndarray
) -> dict[str, np.ndarray]:
    deg = np.degrees
    return {
        "t_s": t_s,
        "host_time_s": host,
        "settling": p.settling.astype(np.float64),
        "tilt_acc_deg": deg(p.tilt_acc_rad),
        "tilt_gyro_deg": deg(p.tilt_gyro_rad),
        "tilt_kalman_deg": deg(p.tilt_kalman_rad),
        "joint_acc_deg": deg(p.joint_acc_rad),
        "joint_gyro_deg": deg(p.joint_gyro_rad),
        "joint_kalman_deg": deg(p.joint_kalman_rad),
        "acc_ms2": p.acc_ms2,
        "gyro_rad_s": p.gyro_rad_s,
        "fsr_counts": p.fsr_counts,
        "heel_loaded": p.heel_loaded.astype(np.float64),
        "toe_loaded": p.toe_loaded.astype(np.float64),
        "phase": p.phase.astype(np.float64),
    }


def cols_from_device(b: SampleBlock, t_s: np.ndarray) -> dict[str, np.ndarray]:
    cols: dict[str, np.ndarray] = {"t_s": t_s, "host_time_s": b.host_time_s}
    if b.kind == FrameKind.TILT and b.acc_tilt_deg is not None and b.kalman_tilt_deg is not None:
        cols["tilt_acc_deg"] = b.acc_tilt_deg
        cols["tilt_kalman_deg"] = b.kalman_tilt_deg
        cols["joint_acc_deg"] = np.degrees(joint_angles(np.radians(b.acc_tilt_deg)))
        cols["joint_kalman_deg"] = np.degrees(joint_angles(np.radians(b.kalman_tilt_deg)))
    elif b.kind == FrameKind.JOINT and b.kalman_joint_deg is not None:
        # SampleBlock.from_frames sets all of a JOINT block's arrays together
        assert b.acc_joint_deg is not None
        assert b.heel_loaded is not None and b.toe_loaded is not None and b.phase is not None
        cols["joint_acc_deg"] = b.acc_joint_deg
        cols["joint_kalman_deg"] = b.kalman_joint_deg
        cols["heel_loaded"] = b.heel_loaded.astype(np.float64)
        cols["toe_loaded"] = b.toe_loaded.astype(np.float64)
        cols["phase"] = phase_from_contacts(b.heel_loaded, b.toe_loaded).astype(np.float64)
    return cols
