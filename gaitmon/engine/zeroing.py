"""A standing zero searched by the engine thread, so where it takes effect depends on the data.

``Engine.request_zero`` hands the engine thread a :class:`ZeroSearch`: the standing windows of
``n`` samples whose last sample is ``since_idx + n - 1``, then every ``step`` samples after
(engine indices; ``n`` rows, which may span a few lost frames: up to 10 % more time). While
one is open the engine thread cuts its blocks at the next window's end and looks at that
window as soon as its last sample has been processed (the pipeline is chunk-invariant: the
cut changes no output). The first still window gives the calibration, which takes effect
``ZERO_MARGIN_S`` of the unit's samples after the window's end, a sample not yet processed
then; with ``hold`` the engine keeps the rows processed from there for a recording to start
at it. So which window is zeroed, the calibration's first sample and a ``gaitmon record
--zero`` file's first row depend on the unit's samples only, never on when a thread ran (a
loaded machine, a simulator faster than real time): issue 24, "load independence".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.calibration import Calibration, CalibrationError, standing_calibration
from gaitmon.dsp.pipeline import PipelineBlock
from gaitmon.engine.buffers import RingBuffer
from gaitmon.io.device import SampleBlock

# A standing calibration takes effect this long (of the unit's clock) after the end of its
# window. The engine thread's search finds the window when its last sample is processed, so it
# is always ahead; ``Engine.zero`` (the live window's Zero button, computed on the caller's
# thread) is normally ahead too, and if the engine thread is further ahead than this the change
# takes effect from its next block and ``Engine.timing_notes`` says so.
ZERO_MARGIN_S = 0.25
# `gaitmon record --zero` starts its file at the zero's sample: the engine thread keeps the
# rows it processed from there until the recording is started (the caller's thread may run
# late), at most this long of them
HOLD_MAX_S = 60.0


@dataclass(frozen=True, eq=False)
class HeldPart:
    """A part the engine thread processed and kept for a recording to start at ``start``:
    what it would have handed the recorder (``BlockHandler._hand_over``)."""

    start: int  # its first engine index
    offset: int  # its pipeline's first engine index
    block: SampleBlock
    p: PipelineBlock | None
    gap_reason: str
    t_s: np.ndarray
    calibration: Calibration  # the one it was processed with


@dataclass
class ZeroSearch:
    """One search (module doc). The engine thread writes ``next_end``, ``result`` and
    ``refused`` under the engine's lock; the caller reads them under it (``Engine.zero_search``)."""

    n: int  # samples in a window
    step: int  # samples between the ends of windows looked at
    next_end: int  # engine index just after the next window to look at
    margin: int  # samples from a window's end to where its calibration takes effect
    apply: bool = True  # the engine thread applies what it finds (at its sample)
    result: tuple[Calibration, int] | None = None  # the calibration and its first sample
    refused: CalibrationError | None = None  # the last window's refusal (its figures)
    done: bool = False  # found, or given up by the caller
    before: Calibration | None = None  # the calibration in force when it was asked for
    hold: bool = False  # keep the rows from the found sample on (``Engine.request_zero``)

    def look(self, data: dict[str, np.ndarray], processed: int, bias: np.ndarray,
             fs_hz: float) -> bool:  # fmt: skip
        """Look at every window whose last sample is among the ``processed`` samples (the
        ring's rows ``data``; ``bias``: the gyro bias in force, added back for the true rate).
        True once a window was still (``result`` set)."""
        idx = np.nan_to_num(data["idx"], nan=-1.0).astype(np.int64)
        k = np.rint(data["t_s"] * fs_hz).astype(np.int64)  # the unit's clock: gaps show
        while not self.done and self.next_end <= processed:
            end, self.next_end = self.next_end, self.next_end + self.step
            rows = np.flatnonzero((idx >= end - self.n) & (idx < end))
            if len(rows) != self.n or k[rows[-1]] - k[rows[0]] > self.n - 1 + self.n // 10:
                continue  # not held any more, or more than 10 % of its time lost
            acc = data["acc_ms2"][rows]
            if np.isnan(acc).any():
                continue
            gyro = data["gyro_rad_s"][rows] + bias
            try:
                cal = standing_calibration(acc, gyro, fs_hz=fs_hz)
            except CalibrationError as exc:
                self.refused = exc
                continue
            self.result = (cal, end + self.margin)
            self.done = True
        return self.result is not None


def still_window(
    ring: RingBuffer, n: int, since_idx: int | None, fs_hz: float, bias: np.ndarray
) -> tuple[tuple[Calibration, int] | None, CalibrationError | None]:
    """``Engine.zero_at``'s search, on the caller's thread: the last ``n`` rows of the display
    ring, or (``since_idx``) the earliest still window of ``n`` rows among those held from that
    engine index on (windows ending every 0.1 s). ((its calibration, the engine index after
    it), None), or (None, the last window's refusal or None: not enough data)."""
    if since_idx is None:
        data = ring.latest(n)
        windows = [slice(0, n)]
    else:
        data = ring.latest(ring.capacity)
        held = np.flatnonzero(np.nan_to_num(data["idx"], nan=-1.0) >= since_idx)
        first = int(held[0]) if len(held) else len(data["t_s"])
        step = max(1, round(0.1 * fs_hz))
        windows = [slice(e - n, e) for e in range(first + n, len(data["t_s"]) + 1, step)]
    refused: CalibrationError | None = None  # the last window's (the UI shows its figures)
    for w in windows:
        # n rows of the ring are n samples of the unit's clock: a lost frame is a row too
        # (NaN), and losses are not movement: the samples received are judged and used
        acc = data["acc_ms2"][w]
        lost = data["lost"][w] > 0
        if len(acc) < n or np.isnan(acc[~lost]).any() or lost.all():
            continue
        # the ring holds bias-corrected rates: add the bias in force back for the true rate
        gyro = data["gyro_rad_s"][w] + bias
        try:
            cal = standing_calibration(acc, gyro, lost, fs_hz=fs_hz)
        except CalibrationError as exc:
            refused = exc
            continue
        return (cal, int(data["idx"][w.stop - 1]) + 1), None
    return None, refused
