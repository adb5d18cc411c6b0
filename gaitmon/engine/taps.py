"""What the engine thread hands to its listeners after each block: a plain, read-only value.

A listener (``Engine.add_listener``) is any callable taking a :class:`BlockOut`. It is called on
the engine thread, after the block is shown and handed to the recorder, so it must be quick and
must not block (the Lab Streaming Layer outlets push and return). One ``BlockOut`` carries what
a consumer outside the engine needs to follow the stream without reaching into it: sample
indices, the unit's frame counter and sample clock, receive times, the live angles, the raw
counts in raw mode, the gait events confirmed in the block, the gaps before its samples, the
markers dropped since the last block, settings that took effect, and recording start / stop.
With no listener the engine builds none of this. No Qt, no network here: the engine does not
know who listens (``gaitmon.lsl.outlets`` is one).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.dsp.channel_table import N_JOINTS, N_SEGMENTS

if TYPE_CHECKING:
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.engine.recorder import Recorder
    from gaitmon.io.device import SampleBlock

_NO_INT = np.zeros(0, np.int64)


def _empty(*shape: int) -> np.ndarray:
    return np.zeros((0, *shape))


@dataclass(frozen=True, eq=False)
class BlockOut:
    """One processed block, or (``last``) the engine's end, for a listener.

    Per sample (N rows):
      ``idx``          engine sample index (the pipeline's and the display's numbering)
      ``seq``          the unit's frame counter, unwrapped (a recording's ``timeline/seq``)
      ``k``            the unit's sample clock: sample periods since the first sample, lost
                       frames included (``t_s * fs``; a recording's ``timeline/t_s * fs``)
      ``host_time_s``  ``time.monotonic()`` when the bytes were read
      ``lost_before``  frames lost just before the sample (a gap, whose first lost frame is
                       at ``k - lost_before``)
      ``joint_deg``    (N, 3) hip, knee, ankle: the live filter's (the unit's own in
                       tilt / joint mode); NaN where the mode has none
      ``tilt_deg``     (N, 4) body, thigh, shank, foot tilts; NaN where the mode has none
      ``adc``          (N, 14) raw counts in raw mode, else None
    Events: ``heel_strike_k`` / ``toe_off_k``: the sample clock of the gait events confirmed in
    this block (they may lie on earlier blocks' samples: the detector decides a little later).
    At the first sample: ``markers`` dropped since the last block, ``gap_reason`` of the gap
    before it ("" = frames lost), ``config`` / ``calibration`` that took effect there (None:
    unchanged), ``recording_started`` (the file whose row 0 it is, or ""),
    ``recording_stopped`` (a recording ended just before it). ``last``: the engine stopped;
    no sample follows (a recording stopped then is said here).
    """

    mode: str
    fs_hz: float
    idx: np.ndarray = field(default_factory=lambda: _NO_INT)
    seq: np.ndarray = field(default_factory=lambda: _NO_INT)
    k: np.ndarray = field(default_factory=lambda: _NO_INT)
    host_time_s: np.ndarray = field(default_factory=lambda: _empty())
    lost_before: np.ndarray = field(default_factory=lambda: _NO_INT)
    joint_deg: np.ndarray = field(default_factory=lambda: _empty(3))
    tilt_deg: np.ndarray = field(default_factory=lambda: _empty(4))
    adc: np.ndarray | None = None
    heel_strike_k: np.ndarray = field(default_factory=lambda: _NO_INT)
    toe_off_k: np.ndarray = field(default_factory=lambda: _NO_INT)
    markers: tuple[str, ...] = ()
    gap_reason: str = ""
    config: PipelineConfig | None = None
    calibration: Calibration | None = None
    recording_started: str = ""
    recording_stopped: bool = False
    last: bool = False

    def __len__(self) -> int:
        return int(self.idx.shape[0])


BlockListener = Callable[[BlockOut], None]


class Taps:
    """The engine's listeners and what it keeps for them: markers dropped since the last
    block, and the recording they last saw (to say when it stopped). The listener tuple is
    replaced, never changed in place, so the engine thread reads it without a lock; the
    markers are guarded by the taps' own lock; the rest is the engine thread's."""

    def __init__(self, mode: str, fs_hz: float, on_error: Callable[[str], None]) -> None:
        self.mode, self.fs_hz, self._on_error = mode, fs_hz, on_error
        self.listeners: tuple[BlockListener, ...] = ()
        self._markers: list[str] = []
        self._lock = threading.Lock()
        self._recording: Recorder | None = None  # the engine's recorder last seen

    def __bool__(self) -> bool:
        return bool(self.listeners)

    def add(self, listener: BlockListener) -> None:
        with self._lock:
            self.listeners = (*self.listeners, listener)

    def remove(self, listener: BlockListener) -> None:
        with self._lock:
            self.listeners = tuple(x for x in self.listeners if x is not listener)
            if not self.listeners:
                self._markers.clear()

    def marker(self, label: str) -> None:
        """A marker dropped now: it goes out at the first sample of the next block."""
        if self.listeners:
            with self._lock:
                self._markers.append(label)

    def _saw_recording(self, rec: Recorder | None) -> bool:
        """Note the recording of this block; True if the one seen before has stopped."""
        stopped = self._recording is not None and rec is not self._recording
        self._recording = rec
        return stopped

    def block(
        self, block: SampleBlock, start_idx: int, t_s: np.ndarray, lost: np.ndarray,
        cols: dict[str, np.ndarray], events: tuple[np.ndarray, np.ndarray],
        times_of: Callable[[np.ndarray], np.ndarray], gap_reason: str,
        changes: tuple[PipelineConfig | None, Calibration | None],
        recording: tuple[Recorder | None, str],
    ) -> None:  # fmt: skip
        """Tell the listeners about a processed block (the engine thread, after the block is
        shown and handed to the recorder). ``events``: heel-strike and toe-off engine indices
        confirmed in it; ``changes``: the settings and calibration that took effect at its
        first sample; ``recording``: the recorder in force and, if this block is its row 0,
        the file's path."""
        with self._lock:
            markers, self._markers = tuple(self._markers), []
        k = np.rint(t_s * self.fs_hz).astype(np.int64)
        joint, tilt = columns(cols, len(block))
        hs_k, to_k = (event_k(i, start_idx, k, times_of, self.fs_hz) for i in events)
        rec, started = recording
        self._tell(BlockOut(
            self.mode, self.fs_hz, np.arange(start_idx, start_idx + len(block)), block.seq,
            k, block.host_time_s, lost, joint, tilt, block.adc, hs_k, to_k, markers,
            gap_reason, changes[0], changes[1], started, self._saw_recording(rec),
        ))  # fmt: skip

    def engine_stopped(self) -> None:
        """The engine thread is gone: the end, and a recording that stopped with it."""
        stopped = self._saw_recording(None)
        self._tell(BlockOut(self.mode, self.fs_hz, recording_stopped=stopped, last=True))

    def _tell(self, out: BlockOut) -> None:
        for listener in self.listeners:
            try:
                listener(out)
            except Exception as exc:  # a listener must never stop acquisition
                self._on_error(f"listener error: {type(exc).__name__}: {exc}")


def columns(cols: dict[str, np.ndarray], n: int) -> tuple[np.ndarray, np.ndarray]:
    """The live joint angles and tilts of a block's display columns (NaN where absent)."""
    joint = cols.get("joint_kalman_deg")
    tilt = cols.get("tilt_kalman_deg")
    return (
        np.full((n, N_JOINTS), np.nan) if joint is None else joint,
        np.full((n, N_SEGMENTS), np.nan) if tilt is None else tilt,
    )


def event_k(
    idx: np.ndarray, start_idx: int, k: np.ndarray, times_of: Callable[[np.ndarray], np.ndarray],
    fs_hz: float,
) -> np.ndarray:  # fmt: skip
    """The sample clock of events at engine indices ``idx``: from this block's ``k``, or, for
    an event on an earlier block's sample, from the display ring's true time (``times_of``);
    an event whose sample the ring no longer holds is left out."""
    idx = np.asarray(idx, np.int64)
    if not len(idx):
        return _NO_INT
    out = np.full(len(idx), -1, np.int64)
    here = (idx >= start_idx) & (idx < start_idx + len(k))
    out[here] = k[idx[here] - start_idx]
    if (~here).any():
        t = times_of(idx[~here])
        got = np.isfinite(t)
        earlier = np.flatnonzero(~here)
        out[earlier[got]] = np.rint(t[got] * fs_hz).astype(np.int64)
    return out[out >= 0]
