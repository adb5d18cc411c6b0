"""Closing a recording finished: :func:`close_recording` stores a raw recording's derived
datasets (``/smoothed``, the zero-lag angles; ``/strides``, the foot IMU's stride measures)
before the file is marked complete and its journal deleted.

The format's writer stores only (:meth:`gaitmon.io.session.SessionWriter.close`); whoever stops
a recording (the engine's recorder, the two-leg recorder, the benchmarks) closes it through
here, so every reader finds the best estimate stored. A crash while they are computed leaves
the journal, and recovery computes them again (:mod:`gaitmon.finish.recovery`).
"""

from __future__ import annotations

import logging
from pathlib import Path

import h5py
import numpy as np

from gaitmon.io.session.header import SessionHeader
from gaitmon.io.session.writer import SessionWriter

log = logging.getLogger("gaitmon.session")


def derive_on_close(f: h5py.File, header: SessionHeader, fs_hz: float) -> None:
    """Compute and store ``/smoothed`` and ``/strides`` of the raw recording open in ``f``
    (every row, event and calibration change written): a disk error raises (the close fails
    as any write does: the journal stays and recovery stores them); bad data only leave them
    to be computed when read (logged)."""
    from gaitmon.finish.smoothed import smooth_into
    from gaitmon.finish.strides import store_strides
    from gaitmon.io.session.attributes import described_once

    with described_once(f):
        try:
            smooth_into(f, header.table, header.calibration, fs_hz)
        except (ValueError, FloatingPointError, np.linalg.LinAlgError) as e:
            log.warning("smoothed angles not stored in %s: %s", Path(f.filename).name, e)
        store_strides(f, header.table, header.calibration, fs_hz)


def close_recording(writer: SessionWriter, *, stop_reason: str = "user") -> None:
    """Close ``writer`` (:meth:`SessionWriter.close`) with its derived datasets stored."""
    writer.close(stop_reason=stop_reason, derive=derive_on_close)
