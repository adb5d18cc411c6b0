"""The batch passes ``gaitmon bench`` times: the pipeline streamed over a record as ``process``,
``batch`` and recovery replay it, the smoother, and both as ``process`` computes them. Shared by
the pipeline suite (:mod:`gaitmon.commands.bench`) and ``--suite whole``'s pipeline row."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.finish.smoothed import FirstPass, KeptFirstPass


def stream(counts: np.ndarray, config: PipelineConfig | None = None,
           kept: KeptFirstPass | None = None) -> None:
    """The pipeline over the whole record, streamed as `process`, `batch` and recovery replay
    it (a chunk at a time; any chunking gives the same numbers); its filter kept in ``kept``.
    As `process` runs it for a format-2 file: without the joint angles, which the file
    derives on read (``Pipeline(joints=False)``)."""
    from gaitmon.dsp import kernels
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.finish.reprocess import REPLAY_CHUNK_ROWS

    kernels.expect(len(counts))  # (as the replay, gaitmon.finish.replay.replay_pipeline)
    p = Pipeline(config, joints=False)
    for a in range(0, len(counts), REPLAY_CHUNK_ROWS):
        blk = p.process(counts[a : a + REPLAY_CHUNK_ROWS])
        if kept is not None:
            kept.add(a, blk.tilt_kalman_continuous_rad)


def smooth(counts: np.ndarray, first_pass: FirstPass | None = None, fs: float = 100.0) -> None:
    """The RTS smoother over the record, 4 segments (its own first pass unless given)."""
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import DEFAULT_TABLE
    from gaitmon.finish.smoothed import smoothed_blocks

    for _ in smoothed_blocks(lambda a, b: counts[a:b], len(counts), DEFAULT_TABLE,
                             Calibration.identity(), [], np.empty(0), fs,
                             first_pass):  # fmt: skip
        pass


def both(counts: np.ndarray) -> None:
    """What `gaitmon process` computes: the pipeline's filter kept for the smoother's first
    pass (in a temporary file, as there)."""
    from gaitmon.finish.smoothed import KeptFirstPass

    with KeptFirstPass() as kept:
        stream(counts, kept=kept)
        smooth(counts, kept.first_pass)


@contextmanager
def batch_loops() -> Iterator[str]:
    """The inner loops' form forced to long batch work's (numba's compiled loops where numba
    is installed, else interpreted: :mod:`gaitmon.dsp.kernels`); yields the form's name."""
    from gaitmon.dsp import kernels

    form = "compiled" if kernels.numba_available() else "python"
    with kernels.use(form):
        yield form
