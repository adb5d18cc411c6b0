"""The engine thread's place in the stream: its sample count and the unit's true sample clock.

The engine numbers every sample it processes (the "engine index", ``samples``) and times each
on the unit's own clock: sample periods since the first sample, lost frames included, as a
recording's timeline counts them (``true_times``). Frames of a block that is not processed
(another mode's frames) are carried as lost before the next one that is (``not_processed``).
Only the engine thread writes a ``StreamPosition``; other threads read ``samples`` and
``last_data_s``, each a single value, without a lock. ``StreamHealth`` is what the engine
thread counts for a viewer: errors and the frame rate. A stream has *stalled* when no frame has
arrived for ``STALL_AFTER_S`` of wall time while the unit streams (``stalled_s``): a link
cut, or a unit that holds its frames and sends them late. Which of the two it was only the
sequence numbers tell, once frames arrive again: a late backlog fills the stall in (no gap),
lost frames become a gap. ``UnitClockMark`` is a moment of the
unit's clock that a caller keeps (``Engine.clock_mark``, ``Engine.seconds_since``).
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from gaitmon.io.device import SampleBlock

# no frame for this long (wall time) while the unit streams: a viewer says "no data for N s"
# (a unit sends 100 frames a second: a second without one is no jitter)
STALL_AFTER_S = 1.0


def stalled_s(last_data_age_s: float, streaming: bool) -> float:
    """Seconds without a frame once that reaches :data:`STALL_AFTER_S` while the unit streams
    (``Snapshot.stalled_s``); 0.0 while frames arrive or the unit is not asked to stream."""
    return last_data_age_s if streaming and last_data_age_s >= STALL_AFTER_S else 0.0


def lost_in(block: SampleBlock) -> int:
    """Frames lost before the samples of ``block``, all told."""
    return 0 if block.lost_before is None else int(block.lost_before.sum())


@dataclass(frozen=True)
class UnitClockMark:
    """A moment of a unit's clock: samples processed and frames its link lost until then."""

    samples: int = 0
    frames_lost: int = 0


@dataclass
class StreamPosition:
    """The engine thread's place in the stream (module doc). ``start`` sets ``last_data_s``
    before the engine thread runs."""

    samples: int = 0  # samples processed since start (the pipeline's index)
    last_data_s: float = field(default_factory=time.monotonic)
    pipeline_offset: int = 0  # engine sample index of the current pipeline's sample 0
    block_start: int = 0  # BlockHandler.handle: engine index of the current block's first sample
    handed_over: bool = False  # BlockHandler.handle: the current block is with the recorder
    k_last: int | None = None  # unit sample periods from the first sample to the last (t_s * fs)
    pending_lost: int = 0  # frames of blocks not processed, lost before the next one processed
    reconnects_seen: int = 0

    def not_processed(self, block: SampleBlock) -> None:
        """``block`` gets no engine indices: its frames are lost before the next one's."""
        self.pending_lost += len(block) + lost_in(block)

    def lost(self, block: SampleBlock) -> np.ndarray:
        """Frames lost before each sample of ``block``, with those of blocks not processed."""
        lost = (
            np.zeros(len(block), np.int64)
            if block.lost_before is None
            else np.asarray(block.lost_before, np.int64).copy()
        )
        if self.k_last is None:
            lost[0] = 0  # what came before the first sample is no gap
        lost[0] += self.pending_lost
        self.pending_lost = 0
        return lost

    def true_times(self, lost: np.ndarray, fs_hz: float) -> np.ndarray:
        """t_s: the unit's sample periods since the first sample, counting lost frames (as the
        recording's timeline does; sequence numbers alone would count control frames too)."""
        k = np.cumsum(lost + 1)
        k += -k[0] if self.k_last is None else self.k_last
        self.k_last = int(k[-1])
        return k / fs_hz


@dataclass
class StreamHealth:
    """What the engine thread counts for a viewer (under the engine's lock)."""

    error: str = ""  # the last device or processing error (Snapshot.engine_error)
    errors: int = 0  # blocks that could not be read or processed (Snapshot.engine_errors)
    # (host time of a block's last sample, samples so far) of recent blocks: the frame rate
    rate_times: deque[tuple[float, int]] = field(default_factory=lambda: deque(maxlen=64))

    def note_error(self, text: str) -> None:
        self.errors += 1
        self.error = " ".join(text.split())[:300]

    def block_done(self, host_time_s: float, samples: int) -> None:
        self.rate_times.append((host_time_s, samples))

    def frame_rate_hz(self) -> float:
        """Samples per second of host time over the recent blocks (0 until two)."""
        r = self.rate_times
        if len(r) >= 2 and r[-1][0] > r[0][0]:
            return (r[-1][1] - r[0][1]) / (r[-1][0] - r[0][0])
        return 0.0
