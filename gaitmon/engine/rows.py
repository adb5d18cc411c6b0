"""Which engine samples become which rows of a recording, and cutting blocks into rows.

The engine numbers every sample it processes (its "engine index"). A recording's row 0 is the
first sample of the first block handed to the recorder; after that a block the recorder queue
refuses (a stalled disk) is processed and shown but never becomes rows. ``RowMap`` keeps that
map for one recording, so the engine can hand over raw-mode events as file rows, and carries
what a row-less block leaves behind (its frames become a gap before the next row that is
recorded; events it confirmed on earlier rows go with the next block). Only the engine thread
uses a ``RowMap``; the recorder thread gets blocks already mapped.

``slice_samples`` and ``slice_pipeline`` cut a block at its gaps for the recorder thread.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from gaitmon.dsp.pipeline import PipelineBlock
from gaitmon.engine.stream import lost_in
from gaitmon.io.device import SampleBlock

_EVENT_KEYS = ("heel_strike_idx", "toe_off_idx")

# the gap reasons of frames received from the unit and not kept (docs/gaps-and-time.md): a
# block the recorder queue refused (a stalled disk, a machine too busy to write), and frames
# the Device's own receive queue dropped (nobody read them fast enough)
RECORDER_QUEUE_FULL = "frames lost: recorder queue full"
RECEIVE_QUEUE_FULL = "frames lost: receive queue full"


class RowMap:
    """The engine thread's map from engine indices to one recording's file rows."""

    def __init__(self) -> None:
        # engine sample index of row 0 (set at the first block handed over); engine index
        # ranges [start, end) processed but dropped from the file (a full queue); frames the
        # unit sent that will not be rows (carried into the next row's lost_before) and why;
        # event rows waiting for the next block
        self.record_offset: int | None = None
        self.drop_starts: list[int] = []
        self.drop_ends: list[int] = []
        self.drop_cum: list[int] = []  # samples dropped up to and including each range
        self.carry_lost = 0
        self.carry_reason = ""
        self.carry_events: dict[str, list[int]] = {k: [] for k in _EVENT_KEYS}

    def event_rows(self, idx: np.ndarray) -> np.ndarray:
        """File rows of events at engine indices ``idx`` (those on samples the file holds)."""
        assert self.record_offset is not None
        idx = np.asarray(idx, np.int64)
        rows = idx - self.record_offset
        keep = rows >= 0
        if self.drop_starts:
            ends = np.asarray(self.drop_ends)
            k = np.searchsorted(ends, idx, side="right")  # dropped ranges wholly before idx
            cum = np.concatenate([[0], np.asarray(self.drop_cum)])
            rows = rows - cum[k]
            starts = np.asarray([*self.drop_starts, np.iinfo(np.int64).max])
            keep &= ~(starts[k] <= idx)  # inside a dropped range: not in the file
        return rows[keep]

    def outgoing(
        self, block: SampleBlock, p: PipelineBlock | None, pipeline_offset: int
    ) -> tuple[SampleBlock, PipelineBlock | None, str]:
        """The block as the recorder gets it, and the reason of a gap before its first row.

        The frames carried from row-less blocks are added to its first ``lost_before``. Raw
        mode: the pipeline's events (pipeline index + ``pipeline_offset`` = engine index) are
        turned into file rows here (the engine alone knows which of its samples the file
        holds), after the event rows carried from a dropped block, so the writer gets them
        with offset 0."""
        first_reason = ""
        out = block
        if self.carry_lost:
            lost = (
                np.zeros(len(block), np.int64)
                if block.lost_before is None
                else np.asarray(block.lost_before, np.int64).copy()
            )
            lost[0] += self.carry_lost
            out = dataclasses.replace(block, lost_before=lost)
            first_reason = self.carry_reason
        p_rows = p
        if p is not None:
            hs, to = (
                np.concatenate(
                    [
                        np.asarray(self.carry_events[k], np.int64),
                        self.event_rows(getattr(p, k) + pipeline_offset),
                    ]
                )
                for k in _EVENT_KEYS
            )
            p_rows = dataclasses.replace(p, heel_strike_idx=hs, toe_off_idx=to)
        return out, p_rows, first_reason

    def handed_over(self, with_events: bool) -> None:
        """The block from ``outgoing`` is queued: what it carried is in the file now."""
        self.carry_lost, self.carry_reason = 0, ""
        if with_events:
            self.carry_events = {k: [] for k in self.carry_events}

    def dropped(
        self, block: SampleBlock, p: PipelineBlock | None, pipeline_offset: int, start: int
    ) -> None:
        """The queue refused the block (engine indices from ``start``): these rows will not
        exist; its frames become a gap before the next row that is recorded, and events it
        confirmed on rows already recorded go with the next block."""
        assert self.record_offset is not None
        if p is not None:
            for k in self.carry_events:
                idx = getattr(p, k) + pipeline_offset
                self.carry_events[k].extend(self.event_rows(idx[idx < start]).tolist())
        n = len(block)
        self.carry_lost += n + lost_in(block)
        self.carry_reason = self.carry_reason or RECORDER_QUEUE_FULL
        self.drop_starts.append(start)
        self.drop_ends.append(start + n)
        self.drop_cum.append((self.drop_cum[-1] if self.drop_cum else 0) + n)

    def not_recorded(self, block: SampleBlock, why: str) -> None:
        """A block that got no engine indices (not processed): its frames become a gap."""
        self.carry_lost += len(block) + lost_in(block)
        self.carry_reason = self.carry_reason or why


def slice_samples(b: SampleBlock, a: int, z: int) -> SampleBlock:
    """Rows a:z of a sample block."""
    changes = {
        f.name: getattr(b, f.name)[a:z]
        for f in dataclasses.fields(b)
        if isinstance(getattr(b, f.name), np.ndarray)
    }
    return dataclasses.replace(b, **changes)


def slice_pipeline(p: PipelineBlock, a: int, z: int, with_events: bool) -> PipelineBlock:
    """Rows a:z of a pipeline block; its (absolute-index) events go with the first part."""
    changes: dict[str, Any] = {
        f.name: getattr(p, f.name)[a:z]
        for f in dataclasses.fields(p)
        if isinstance(getattr(p, f.name), np.ndarray)
        and f.name not in ("heel_strike_idx", "toe_off_idx", "kalman_bias_rad_s", "restart_idx")
    }
    if not with_events:
        changes["heel_strike_idx"] = p.heel_strike_idx[:0]
        changes["toe_off_idx"] = p.toe_off_idx[:0]
        changes.update(gyro_heel_strike_idx=(), gyro_toe_off_idx=(), fsr_faults=())
    return dataclasses.replace(p, start_idx=p.start_idx + a, **changes)
