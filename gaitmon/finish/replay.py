"""Replaying the pipeline over a recording's raw counts from row 0, with its logged changes of
settings and calibration: ``gaitmon process``, ``batch`` and a recovery (:mod:`gaitmon.finish.
recovery`) replay this way. Its own module so that a replay loads none of the journal's record
layout or the link protocol (~7 ms of a short ``process``).
"""

from __future__ import annotations

import itertools
from collections.abc import Collection, Iterable, Iterator, Sequence
from typing import NamedTuple

import numpy as np

from gaitmon.dsp import kernels
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import DEFAULT_TABLE, ChannelTable
from gaitmon.dsp.fsr_check import FsrFault
from gaitmon.dsp.methods import feeds_smoother
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.io.session.layout import _RECOVERY_CHUNK_ROWS
from gaitmon.io.session.rows import (
    JOINT_ROWS,
    LazyRows,
    LostRows,
    fault_rows,
    rows_from_pipeline,
)

# rows replayed at a time by a recovery: the pipeline's block for 65 536 rows (the default,
# ``gaitmon process``'s cancel points) is ~50 MB with its temporaries; chunking does not change
# the pipeline's output (its contract)
RECOVERY_REPLAY_ROWS = 1 << 14


class ReplayChunk(NamedTuple):
    """Rows ``start:start + len`` of a replayed recording."""

    start: int
    rows: dict[str, np.ndarray]  # /processed rows
    heel_strike: np.ndarray  # rows
    toe_off: np.ndarray  # rows
    fsr_faults: list[tuple[int, int, str, str]]  # /events/fsr_faults records flagged here
    # (rows, 4) the offline smoother's first pass of these rows (rad), where the replayed
    # pipeline's filter is it (the gait-aware filter, no change of settings since row 0; see
    # gaitmon.dsp.smoother.CausalFirstPass); else None
    first_pass_rad: np.ndarray | None = None


def replay_pipeline(
    adc: np.ndarray | LazyRows,
    config: PipelineConfig,
    calibration: Calibration,
    changes: Sequence[tuple[int, PipelineConfig | Calibration]] = (),
    *,
    table: ChannelTable = DEFAULT_TABLE,
    chunk_rows: int = _RECOVERY_CHUNK_ROWS,
    lost_before: np.ndarray | LazyRows | LostRows | None = None,
    flagged_at_start: Sequence[tuple[str, str]] = (),
    only: Collection[str] | None = None,
) -> Iterator[ReplayChunk]:
    """Run the pipeline over a whole recording from row 0, applying logged changes at their rows.

    Yields a :class:`ReplayChunk` per chunk. A new
    calibration is applied with ``Pipeline.set_calibration`` (filter state kept); new settings
    start a fresh ``pipeline.successor(new_config)`` at that row (the stages are
    rebuilt, as they must be when the filter design changes). Changes at the same row apply in
    the given order. ``lost_before`` (frames lost before each row, see
    :func:`lost_before_from_gaps`) lets the pipeline restart after a long gap as it did live.
    Use it for recovery and for ``gaitmon process``. ``adc`` is only sliced a chunk at a time
    (a :class:`gaitmon.io.session.rows.LazyRows` reads each from the file or journal then).
    ``flagged_at_start``: force sensors (sensor, reason) known faulty when the recording started
    (:func:`flagged_at_start`): flagged from row 0 and listed among the first chunk's faults,
    as the live recorder did. ``only``: the ``/processed`` rows wanted (default all of
    :data:`gaitmon.io.session.rows.PIPELINE_ROWS`).
    """
    n = len(adc)
    kernels.expect(n)  # a long record runs numba's compiled loops where they are cached
    ordered = sorted(
        ((max(0, int(i)), k, c) for k, (i, c) in enumerate(changes)), key=lambda x: x[:2]
    )
    cuts = {0, n}
    cuts.update(range(0, n, chunk_rows))
    cuts.update(i for i, _, _ in ordered if i < n)
    bounds = sorted(cuts)
    # (joint angles only for a caller that stores them: a format-2 file derives its own)
    joints = only is None or any(path in only for path in JOINT_ROWS)
    pipeline = Pipeline(config, calibration, table, joints=joints)
    pipeline.flag_fsr_faults(flagged_at_start)
    first_pass = feeds_smoother(pipeline.method.name)  # until new settings start
    at_start = [(0, 0, f.sensor, f.reason) for f in pipeline.fsr_faults]  # (as seeded)
    base = 0
    k = 0
    for a, b in itertools.pairwise(bounds):
        while k < len(ordered) and ordered[k][0] <= a:
            change = ordered[k][2]
            if isinstance(change, Calibration):
                pipeline.set_calibration(change)
            else:
                pipeline = pipeline.successor(change)
                base = a
                first_pass = False
            k += 1
        blk = pipeline.process(adc[a:b], None if lost_before is None else lost_before[a:b])
        faults = fault_rows(blk.fsr_faults, blk.start_idx, a)
        if a == 0:
            faults = at_start + faults
        chunk = ReplayChunk(a, rows_from_pipeline(blk, only), blk.heel_strike_idx + base,
                            blk.toe_off_idx + base, faults,
                            blk.tilt_kalman_continuous_rad if first_pass else None)  # fmt: skip
        # the block (~740 bytes a row: every stage's series) goes before the next is made,
        # and the chunk once the caller has it: one chunk's worth alive at a time
        del blk
        yield chunk
        del chunk


def flagged_at_start(rows: Iterable[tuple[int, str, str]]) -> tuple[tuple[str, str], ...]:
    """(sensor, reason) of the ``/events/fsr_faults`` rows (decided row, sensor, reason) known
    at row 0: flagged before the recording started."""
    return tuple(dict.fromkeys((str(s), str(r)) for row, s, r in rows if int(row) == 0))


def flags_kept(
    faults: Iterable[FsrFault], recorded: PipelineConfig, config: PipelineConfig
) -> tuple[tuple[str, str], ...]:
    """The sensors a recording had flagged from row 0 that a reprocessing with ``config`` keeps
    flagged: all of them when it reads the force sensors as ``recorded`` did (as
    ``Pipeline.successor``), none otherwise (other settings may be what made one look dead)."""
    if not config.reads_fsrs_as(recorded):
        return ()
    return flagged_at_start((f.decided_idx, f.sensor, f.reason) for f in faults)
