"""What the engine thread applies at a given sample, for ``Engine`` (``engine/core.py``).

Callers ask for changes (new settings, a calibration from the next block or from an engine
sample index) and the engine thread takes them at its next block, or cuts its blocks at the
scheduled sample so the change takes effect exactly there (the pipeline is chunk-invariant:
the cut changes no output). A zero found by the engine thread's search (``engine/zeroing.py``)
with ``hold`` keeps the parts processed from its sample on (:class:`HeldRows`), so a recording
asked to start there gets its rows however late the caller's thread gets to it. A change that
came after its sample (a machine far behind) takes effect from the next block and leaves one
line in ``Engine.timing_notes`` (:func:`timing_note`).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine.buffers import RingBuffer
from gaitmon.engine.rows import slice_samples
from gaitmon.engine.zeroing import HOLD_MAX_S, ZERO_MARGIN_S, HeldPart, ZeroSearch
from gaitmon.io.device import SampleBlock


@dataclass
class PendingChanges:
    """Changes a caller asked for; the engine thread takes them at its next block (under the
    engine's lock), so a recording started meanwhile gets them in its header."""

    config: PipelineConfig | None = None
    calibration: Calibration | None = None
    # the engine index from which ``calibration`` takes effect (None: the next block); the
    # engine thread cuts its blocks there, so it is applied exactly at that sample
    calibration_at: int | None = None

    def header_calibration(
        self, current: Calibration, from_idx: int | None, processed: int
    ) -> Calibration:
        """The calibration a file starting now (or at ``from_idx``) starts with: a zeroing
        still waiting for the next block is; one scheduled at a sample is, if the file starts
        at or after that sample (``processed``: the engine thread's sample count)."""
        at = self.calibration_at
        if self.calibration is not None and (
            at is None or (from_idx is not None and from_idx >= at) or at <= processed
        ):
            return self.calibration
        return current

    def take(
        self, processed: int
    ) -> tuple[PipelineConfig | None, Calibration | None, int | None]:
        """The engine thread, at a block starting at ``processed``: (the new settings or None,
        the calibration taking effect now or None, the sample it was scheduled at)."""
        cfg, self.config = self.config, None
        cal, cal_at = None, self.calibration_at
        if cal_at is None or cal_at <= processed:  # a scheduled one waits for its sample
            cal, self.calibration = self.calibration, None
            self.calibration_at = None
        return cfg, cal, cal_at

    def withdraw(
        self, found: Calibration, current: Calibration, before: Calibration | None
    ) -> None:
        """A zero withdrawn: ``found`` is not applied (or, already ``current``, ``before`` is
        again from the next block)."""
        if self.calibration is found:
            self.calibration = self.calibration_at = None
        elif current is found and before is not None:
            self.calibration = before
            self.calibration_at = None


class HeldRows:
    """The engine thread's parts processed from a found zero's sample on, for a recording to
    start there (``Engine.request_zero(hold=True)``); only the engine thread touches them."""

    def __init__(self, fs_hz: float) -> None:
        self.fs_hz = fs_hz
        self.parts: list[HeldPart] = []
        self.from_idx: int | None = None  # the sample they are held from (None: not holding)

    def begin(self, from_idx: int | None) -> None:
        self.parts, self.from_idx = [], from_idx

    def hold(self, part: HeldPart) -> None:
        """Keep a processed part from the sample a zero takes effect at, for a recording asked
        to start there once the caller gets to it (``start_recording`` with ``from_idx``); at
        most ``HOLD_MAX_S`` of them."""
        if self.from_idx is None or part.start < self.from_idx:
            return
        if self.parts and part.start != self.parts[-1].start + len(self.parts[-1].block):
            self.begin(None)  # not contiguous (a failed block)
            return
        if not self.parts and part.start != self.from_idx:
            self.from_idx = None  # the zero's sample was processed before it was found
            return
        if part.start - self.from_idx > HOLD_MAX_S * self.fs_hz:
            self.begin(None)  # nobody started a recording there
            return
        self.parts.append(part)

    def take(self, start_idx: int | None) -> list[HeldPart]:
        """The parts held from ``start_idx`` on, in order ([] if none), holding no more."""
        held = self.parts
        self.begin(None)
        if not held or held[0].start != start_idx:
            return []
        return held


class ZeroControl:
    """The engine thread's zero search (``Engine.request_zero``, ``engine/zeroing.py``): at
    most one open; what it finds goes to the pending changes (``apply``) and, with ``hold``,
    starts holding rows. ``lock``: the engine's, which guards ``pending`` and ``search``;
    ``calibration``: the engine's calibration in force (read under the lock)."""

    def __init__(
        self, lock: threading.Lock, pending: PendingChanges, held: HeldRows,
        calibration: Callable[[], Calibration], fs_hz: float,
    ) -> None:  # fmt: skip
        self._lock = lock
        self._pending = pending
        self._held = held
        self._calibration = calibration
        self.fs_hz = fs_hz
        self.search: ZeroSearch | None = None

    def request(self, window_s: float, since_idx: int, apply: bool, hold: bool) -> ZeroSearch:
        n = int(window_s * self.fs_hz)
        search = ZeroSearch(n=n, step=max(1, round(0.1 * self.fs_hz)), next_end=since_idx + n,
                            margin=round(ZERO_MARGIN_S * self.fs_hz), apply=apply,
                            hold=hold)  # fmt: skip
        with self._lock:
            if self.search is not None:
                self.search.done = True
            search.before = self._calibration()
            self.search = search
        return search

    def status(self, search: ZeroSearch) -> tuple[tuple[Calibration, int] | None, str, int]:
        with self._lock:
            refused = "" if search.refused is None else str(search.refused)
            return search.result, refused, search.next_end - search.step

    def cancel(self, search: ZeroSearch, withdraw: bool) -> tuple[Calibration, int] | None:
        with self._lock:
            search.done = True
            if self.search is search:
                self.search = None
            found = search.result
            if withdraw and found is not None and search.apply:
                search.result = None
                self._pending.withdraw(found[0], self._calibration(), search.before)
            return found

    def next_end(self) -> int | None:
        """The sample the engine thread cuts its blocks at (the caller holds the lock)."""
        if self.search is not None and not self.search.done:
            return self.search.next_end  # look at it as soon as it is here
        return None

    def look(self, ring: RingBuffer, processed: int) -> None:
        """The engine thread, after each part: the open search's windows now processed."""
        with self._lock:
            search = self.search
        if search is None or search.done or search.next_end > processed:
            return
        data = ring.latest(ring.capacity)
        with self._lock:
            if search.done:
                return
            if search.look(data, processed, self._calibration().gyro_bias_rad_s, self.fs_hz):
                self.search = None
                found = search.result
                if search.apply and found is not None:
                    self._pending.calibration, self._pending.calibration_at = found
                if search.hold and found is not None:  # a recording may start there: hold
                    self._held.begin(found[1])


def split_at(
    block: SampleBlock, start: int, marks: list[int | None]
) -> tuple[SampleBlock, SampleBlock | None]:
    """``block`` (its first engine index ``start``) up to the first of the scheduled samples
    ``marks`` inside it, and the rest (None: no such sample inside it)."""
    n = len(block)
    cuts = [m - start for m in marks if m is not None and 0 < m - start < n]
    if not cuts:
        return block, None
    cut = min(cuts)
    return slice_samples(block, 0, cut), slice_samples(block, cut, n)


def timing_note(what: str, late_samples: int, fs_hz: float) -> str:
    """A scheduled change took effect from a block after its sample (``ZERO_MARGIN_S``): the
    result depends on the machine's timing this once; say so."""
    return (
        f"{what} {late_samples / fs_hz:.2f} s of the unit's clock after its sample "
        "(the machine was behind): this time it depends on the machine's timing"
    )
