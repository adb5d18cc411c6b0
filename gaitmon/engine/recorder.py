"""The single recorder thread: the only code that touches a recording's session file.

The engine thread hands it messages (``engine.messages``) through a queue and never waits for
it: sample blocks are bounded (a stalled disk drops blocks, counted), control messages
(settings, calibration, marker, link statistics, stop) never are.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, Unpack, assert_never

import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine.messages import (
    AddMarker,
    AppendBlock,
    LogCalibration,
    LogConfig,
    RecorderMessage,
    Stop,
    UpdateLink,
)
from gaitmon.engine.rows import RECEIVE_QUEUE_FULL, RowMap, slice_pipeline, slice_samples
from gaitmon.engine.snapshot import RecordingStatus
from gaitmon.io.device import LinkStats

if TYPE_CHECKING:
    from gaitmon.io.session.writer import SessionWriter


@dataclass(frozen=True)
class RecorderProgress:
    """What the recorder thread reports: one consistent copy, replaced after every item."""

    rows: int = 0
    file_bytes: int = 0
    error: str = ""  # why the recording stopped on its own ("" if it did not)
    finished: bool = False  # the thread ended on the stop item (not by a BaseException)


class _ProgressChange(TypedDict, total=False):
    """Fields of ``RecorderProgress`` that one publish replaces."""

    rows: int
    file_bytes: int
    error: str
    finished: bool


class Recorder:
    """The thread that owns the session writer, and what it shares with the engine thread.

    Who writes what:

    - Set here and never changed: ``writer``, ``queue``, ``queue_max``, ``thread``,
      ``started_monotonic_s`` and what the header already holds (``header_config``,
      ``header_calibration``: a change pending at the start is not logged again).
    - Engine thread only: ``row_map`` (which of its samples are rows; the recorder thread
      never reads it).
    - Under ``_lock``, and nothing else under it: ``_blocks_waiting`` (the engine thread adds
      a block, the recorder thread takes it), ``_dropped_blocks`` (engine thread, a full
      queue) and ``_progress`` (recorder thread). Others read them through ``progress`` and
      ``dropped_blocks``.
    """

    def __init__(
        self,
        writer: SessionWriter,
        queue_max: int,
        header_config: PipelineConfig | None = None,
        header_calibration: Calibration | None = None,
        limit_samples: int | None = None,
    ) -> None:
        self.writer = writer
        # engine thread only: the rows end limit_samples sample periods after row 0
        self.limit_samples = limit_samples
        # the link's reconnects before the recording began (set by the engine at its start):
        # the file counts the recording's own (issue 25: "2 reconnects" beside 0 outages)
        self.reconnects_base = 0
        self._k0: int | None = None  # the unit's sample period of row 0
        self.queue: queue.Queue[RecorderMessage] = queue.Queue()
        self.queue_max = queue_max
        self.header_config = header_config
        self.header_calibration = header_calibration
        # engine thread: the engine index of row 0 if the recording starts at a given sample
        # (``Engine.start_recording(from_idx=...)``; None: the next block)
        self.start_idx: int | None = None
        # engine thread: the unit's sample period of the last sample seen since row 0 (handed
        # over or past the limit); with ``_k0``, how much of the unit's clock is recorded
        self.k_seen: int | None = None
        self.row_map = RowMap()
        self._lock = threading.Lock()
        self._blocks_waiting = 0
        self._dropped_blocks = 0
        self._dropped_frames = 0
        self._progress = RecorderProgress()
        self.thread = threading.Thread(target=self._run, name="gaitmon-recorder", daemon=True)
        self.started_monotonic_s = time.monotonic()
        self.thread.start()

    def rows_within_limit(self, k: np.ndarray) -> int:
        """Engine thread: how many of a block's rows (the unit's sample periods ``k``, from
        ``StreamPosition.true_times``) lie before the limit, counted from the first row
        handed over."""
        if not len(k):
            return 0
        if self._k0 is None:
            self._k0 = int(k[0])
        if self.limit_samples is None:
            return len(k)
        return int(np.searchsorted(k - self._k0, self.limit_samples, side="left"))

    # -- any thread -----------------------------------------------------------------------

    def unit_samples(self) -> int:
        """Sample periods of the unit's clock from row 0 through the last sample handed over
        (or seen past the limit): lost frames count; 0 before row 0."""
        k0, k = self._k0, self.k_seen
        return 0 if k0 is None or k is None else k - k0 + 1


    @property
    def alive(self) -> bool:
        return self.thread.is_alive()

    @property
    def progress(self) -> RecorderProgress:
        with self._lock:
            return self._progress

    @property
    def dropped_blocks(self) -> int:
        """Blocks refused because ``queue_max`` were waiting (never expected; never silent)."""
        with self._lock:
            return self._dropped_blocks

    @property
    def dropped_frames(self) -> int:
        """The rows of the blocks ``dropped_blocks`` counts: frames received, shown and not
        saved (each a gap "frames lost: recorder queue full" in the file)."""
        with self._lock:
            return self._dropped_frames

    def status(self) -> RecordingStatus:
        """The recording as a viewer sees it (``Engine.recording``)."""
        # alive before progress: a thread that ended normally published finished=True first
        alive = self.alive
        progress = self.progress
        error = progress.error
        if not error and not alive and not progress.finished:
            error = "the recorder stopped unexpectedly"  # only a BaseException gets here
        return RecordingStatus(
            active=not error,
            path=str(self.writer.path),
            started_monotonic_s=self.started_monotonic_s,
            elapsed_s=time.monotonic() - self.started_monotonic_s,
            rows=progress.rows,
            file_bytes=progress.file_bytes,
            dropped_blocks=self.dropped_blocks,
            dropped_frames=self.dropped_frames,
            error=error,
        )

    def finish(
        self, reason: str, timeout_s: float, link_stats: Callable[[], LinkStats]
    ) -> RecordingStatus:
        """The caller's thread, once the engine thread hands over no more blocks: the link's
        last statistics and the stop go in, and the final status comes back after up to
        ``timeout_s``. A recorder not finished by then (a stalled disk) carries on in the
        background, and the status says so in ``error`` (if the process ends first, the
        journal keeps every row handed over; the next open recovers the file)."""
        with contextlib.suppress(Exception):  # a vanished device: the file keeps the last ones
            self.put(UpdateLink(link_stats()))
        self.put(Stop(reason))  # control messages are never refused, even by a full queue
        self.thread.join(timeout=max(0.0, timeout_s))
        status = self.status()
        if self.alive and not status.error:
            name = Path(status.path).name
            status = dataclasses.replace(
                status,
                error=(
                    f"the recording to {name} was not finished after {timeout_s:g} s (slow "
                    "disk?); it finishes in the background, and if gaitmon quits first the "
                    "file is recovered from its journal when next opened"
                ),
            )
        return dataclasses.replace(status, active=False)

    # -- the engine thread (and the caller's, for control messages) ----------------------

    def put(self, item: AddMarker | LogConfig | LogCalibration | UpdateLink | Stop) -> None:
        """Queue a control message (never refused: they are few and small)."""
        self.queue.put_nowait(item)

    def put_block(self, item: AppendBlock) -> bool:
        """Queue a block; False (and counted, blocks and rows) if ``queue_max`` blocks are
        already waiting."""
        with self._lock:
            if self._blocks_waiting >= self.queue_max:
                self._dropped_blocks += 1
                self._dropped_frames += len(item.samples)
                return False
            self._blocks_waiting += 1
        self.queue.put_nowait(item)
        return True

    # -- the recorder thread --------------------------------------------------------------

    def _publish(self, **changes: Unpack[_ProgressChange]) -> None:
        with self._lock:
            self._progress = dataclasses.replace(self._progress, **changes)

    @staticmethod
    def _append(w: SessionWriter, msg: AppendBlock) -> None:
        """Write a block, logging a gap at each row where frames were lost before it
        (``first_gap_reason``, if given, is the reason of a gap before the block's first row)."""
        samples, processed, offset = msg.samples, msg.processed, msg.event_offset
        gap_reason, first_gap_reason = msg.gap_reason, msg.first_gap_reason
        lost, over = samples.lost_before, samples.overflow_before
        if lost is not None and w.rows == 0 and lost[0]:
            lost = lost.copy()  # frames lost before the first recorded row are not in the session
            lost[0] = 0
        cuts = [] if lost is None else [int(i) for i in np.flatnonzero(lost)]
        if not cuts:
            w.append(samples, processed, event_offset=offset)
            return
        assert lost is not None
        fs = w.header.sample_rate_hz
        bounds = [0, *cuts, len(samples)] if cuts[0] != 0 else [*cuts, len(samples)]
        for k, (a, b) in enumerate(itertools.pairwise(bounds)):
            if a == b:
                continue
            n_lost = int(lost[a])
            # the frames this computer's receive queue dropped: a gap of their own cause
            n_over = 0 if over is None else min(int(over[a]), n_lost)
            if n_over:
                w.add_gap(n_over, n_over / fs, RECEIVE_QUEUE_FULL)
            if n_lost > n_over:
                why = (first_gap_reason if a == 0 else "") or gap_reason or "frames lost"
                w.add_gap(n_lost - n_over, (n_lost - n_over) / fs, why)
            part_p = None if processed is None else slice_pipeline(processed, a, b, k == 0)
            w.append(slice_samples(samples, a, b), part_p, event_offset=offset)

    def _run(self) -> None:
        from gaitmon.finish.closing import close_recording
        from gaitmon.io.session import SessionError

        w = self.writer
        failed = False
        while True:
            msg: RecorderMessage | None
            try:
                msg = self.queue.get(timeout=0.05)
            except queue.Empty:
                msg = None  # a tick: flush what is due
            if isinstance(msg, AppendBlock):
                with self._lock:
                    self._blocks_waiting -= 1
            if failed:
                if isinstance(msg, Stop):
                    self._publish(finished=True)
                    return
                continue
            try:
                if msg is None:
                    pass
                elif isinstance(msg, AppendBlock):
                    self._append(w, msg)
                elif isinstance(msg, AddMarker):
                    w.add_marker(msg.label, msg.row)
                elif isinstance(msg, LogConfig):
                    w.log_config(msg.config)
                elif isinstance(msg, LogCalibration):
                    w.log_calibration(msg.calibration)
                elif isinstance(msg, UpdateLink):
                    w.update_link(msg.stats, self.reconnects_base)
                elif isinstance(msg, Stop):
                    close_recording(w, stop_reason=msg.reason)
                    self._publish(rows=w.rows, file_bytes=w.bytes_written, finished=True)
                    return
                else:
                    assert_never(msg)
                w.maybe_flush()
                self._publish(rows=w.rows, file_bytes=w.bytes_written)
            except Exception as exc:  # any failure must stop the recording visibly
                failed = True
                if isinstance(exc, (SessionError, OSError)):
                    self._publish(error=str(exc))
                    with contextlib.suppress(Exception):
                        close_recording(w, stop_reason=f"error: {exc}")
                else:
                    # a bug, not the disk: the writer's state is unknown, so do not finish the
                    # file; the journal (the truth) stays and the next open recovers every row
                    self._publish(error=w.abort(exc))
                if isinstance(msg, Stop):  # the stop itself failed: it is over all the same
                    self._publish(rows=w.rows, finished=True)
                    return
                self._publish(rows=w.rows)
