"""The recording's side of ``Engine`` (``engine/core.py``): opening a session file with the
header the first recorded block is processed with, and handing processed blocks to the
recorder thread (``engine/recorder.py``) through the row map (``engine/rows.py``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineBlock, PipelineConfig
from gaitmon.engine.errors import EngineError
from gaitmon.engine.messages import AppendBlock
from gaitmon.engine.recorder import Recorder
from gaitmon.engine.rows import slice_pipeline, slice_samples
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import Identity

if TYPE_CHECKING:
    from gaitmon.io.session.header import SessionMeta


def open_recorder(
    path: str | Path, meta: SessionMeta | None, *, overwrite: bool, mode: str, fs_hz: float,
    identity: Identity | None, transport_label: str, config: PipelineConfig,
    calibration: Calibration, queue_blocks: int, limit_samples: int | None,
) -> Recorder:  # fmt: skip
    """A session file with this header and its recorder thread (``EngineError``: the file
    cannot be created)."""
    from gaitmon.io.session import (
        SessionError,
        SessionHeader,
        SessionMeta,
        SessionWriter,
        device_info,
    )

    header = SessionHeader(
        mode=mode,
        sample_rate_hz=fs_hz,
        meta=meta or SessionMeta(),
        device=device_info(identity, transport_label),
        config=config,
        calibration=calibration,
    )
    try:
        writer = SessionWriter(path, header, overwrite=overwrite)
    except SessionError as exc:
        raise EngineError(str(exc)) from exc
    except OSError as exc:  # the output's problem, said as every output says it
        from gaitmon.errors import output_error_text

        raise EngineError(output_error_text(exc, path)) from exc
    return Recorder(writer, queue_blocks, header.config, calibration, limit_samples=limit_samples)


def hand_over(
    rec: Recorder, block: SampleBlock, p: PipelineBlock | None, gap_reason: str,
    t_s: np.ndarray, fs_hz: float, offset: int, start: int,
) -> None:  # fmt: skip
    """Queue a block for the recorder, with the frames not recorded before it as lost
    (see ``RowMap.outgoing``); if the queue is full, the row map notes the drop. A
    recording with a ``limit_s`` gets only the rows before it (``t_s``: the block's).
    ``offset``, ``start``: its pipeline's offset and its first engine index."""
    k = np.rint(t_s * fs_hz).astype(np.int64)
    n = rec.rows_within_limit(k)
    try:
        _hand_over_rows(rec, block, p, gap_reason, n, offset, start)
    finally:  # after the rows are queued: a caller that sees it and stops loses none
        rec.k_seen = int(k[-1])


def _hand_over_rows(
    rec: Recorder, block: SampleBlock, p: PipelineBlock | None, gap_reason: str,
    n: int, offset: int, start: int,
) -> None:  # fmt: skip
    if n == 0:
        return
    if n < len(block):
        block, p = slice_samples(block, 0, n), None if p is None else _first_rows(p, n)
    out, p_rows, first_reason = rec.row_map.outgoing(block, p, offset)
    if rec.put_block(AppendBlock(out, p_rows, 0, gap_reason, first_reason)):
        rec.row_map.handed_over(with_events=p is not None)
        return
    # the queue is full (a stalled disk)
    rec.row_map.dropped(block, p, offset, start)


def _first_rows(p: PipelineBlock, n: int) -> PipelineBlock:
    """The first ``n`` rows of a pipeline block, with the events on them (the last rows of a
    recording that ends within the block)."""
    out = slice_pipeline(p, 0, n, with_events=True)
    end = p.start_idx + n
    return dataclasses.replace(
        out,
        heel_strike_idx=p.heel_strike_idx[p.heel_strike_idx < end],
        toe_off_idx=p.toe_off_idx[p.toe_off_idx < end],
        gyro_heel_strike_idx=tuple(i for i in p.gyro_heel_strike_idx if i < end),
        gyro_toe_off_idx=tuple(i for i in p.gyro_toe_off_idx if i < end),
    )
