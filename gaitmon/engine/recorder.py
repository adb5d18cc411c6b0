"""The single recorder thread: the only code that touches a recording's session file.

The engine thread hands it items through a queue and never waits for it: sample blocks are
bounded (a stalled disk drops blocks, counted), control items (settings, calibration, marker,
link statistics, stop) never are.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import queue
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineBlock, PipelineConfig
from gaitmon.engine.rows import RowMap, slice_pipeline, slice_samples
from gaitmon.io.device import SampleBlock


@dataclass(frozen=True)
class RecorderProgress:
    """What the recorder thread reports: one consistent copy, replaced after every item."""

    rows: int = 0
    file_bytes: int = 0
    error: str = ""  # why the recording stopped on its own ("" if it did not)
    finished: bool = False  # the thread ended on the stop item (not by a BaseException)


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
        writer: Any,
        queue_max: int,
        header_config: PipelineConfig | None = None,
        header_calibration: Calibration | None = None,
    ) -> None:
        self.writer = writer
        self.queue: queue.Queue[tuple[str, Any]] = queue.Queue()
        self.queue_max = queue_max
        self.header_config = header_config
        self.header_calibration = header_calibration
        self.row_map = RowMap()
        self._lock = threading.Lock()
        self._blocks_waiting = 0
        self._dropped_blocks = 0
        self._progress = RecorderProgress()
        self.thread = threading.Thread(target=self._run, name="gaitmon-recorder", daemon=True)
        self.started_monotonic_s = time.monotonic()
        self.thread.start()

    # -- any thread -----------------------------------------------------------------------

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

    # -- the engine thread (and the caller's, for control items) -------------------------

    def put(self, item: tuple[str, Any]) -> None:
        """Queue a control item (never refused: they are few and small)."""
        self.queue.put_nowait(item)

    def put_block(self, item: tuple[str, Any]) -> bool:
        """Queue a block; False (and counted) if ``queue_max`` blocks are already waiting."""
        with self._lock:
            if self._blocks_waiting >= self.queue_max:
                self._dropped_blocks += 1
                return False
            self._blocks_waiting += 1
        self.queue.put_nowait(item)
        return True

    # -- the recorder thread --------------------------------------------------------------

    def _publish(self, **changes: Any) -> None:
        with self._lock:
            self._progress = dataclasses.replace(self._progress, **changes)

    def _append(
        self,
        w: Any,
        samples: SampleBlock,
        processed: PipelineBlock | None,
        offset: int,
        gap_reason: str,
        first_gap_reason: str = "",
    ) -> None:
        """Write a block, logging a gap at each row where frames were lost before it
        (``first_gap_reason``, if given, is the reason of a gap before the block's first row)."""
        lost = samples.lost_before
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
            if lost[a]:
                why = (first_gap_reason if a == 0 else "") or gap_reason or "frames lost"
                w.add_gap(int(lost[a]), float(lost[a]) / fs, why)
            part_p = None if processed is None else slice_pipeline(processed, a, b, k == 0)
            w.append(slice_samples(samples, a, b), part_p, event_offset=offset)

    def _run(self) -> None:
        from gaitmon.finish.closing import close_recording
        from gaitmon.io.session import SessionError

        w = self.writer
        failed = False
        while True:
            try:
                kind, payload = self.queue.get(timeout=0.05)
            except queue.Empty:
                kind, payload = "tick", None
            if kind == "append":
                with self._lock:
                    self._blocks_waiting -= 1
            if failed:
                if kind == "stop":
                    self._publish(finished=True)
                    return
                continue
            try:
                if kind == "append":
                    self._append(w, *payload)
                elif kind == "marker":  # a label (the next row), or (label, row)
                    if isinstance(payload, tuple):
                        w.add_marker(payload[0], payload[1])
                    else:
                        w.add_marker(payload)
                elif kind == "config":
                    w.log_config(payload)
                elif kind == "calibration":
                    w.log_calibration(payload)
                elif kind == "link":
                    w.update_link(payload)
                elif kind == "stop":
                    close_recording(w, stop_reason=payload)
                    self._publish(rows=w.rows, file_bytes=w.bytes_written, finished=True)
                    return
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
                if kind == "stop":  # the stop itself failed: it is over all the same
                    self._publish(rows=w.rows, finished=True)
                    return
                self._publish(rows=w.rows)
