"""Ground truth of a simulated recording, stored in the session file as ``/truth``.

Only sessions recorded from the simulated unit have it. Every row of the session is mapped back
to the sample the unit generated (through the unit's frame log: the file's unwrapped sequence
number is the unit's frame number), so researchers can score any filter against what really
happened. The ``/truth`` layout and the writing belong to :mod:`gaitmon.io.session.truth`.

Besides the per-row truth and the events, ``stride_length_m``, ``stride_time_s`` and
``foot_clearance_m`` hold, for each ``heel_strike`` row, the true stride it opens
(gaitmon.io.sim.kinematics.GaitModel.strides).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gaitmon.io.session.opening import read_stored
from gaitmon.io.session.truth import truth_writer
from gaitmon.io.sim.unit import SimulatedUnit


def row_samples(seq: np.ndarray, unit: SimulatedUnit) -> np.ndarray:
    """Sample index of each recorded row (-1 where the frame is not in the unit's log)."""
    frame_no, sample_idx, _ = unit.frame_log()
    return _samples_of(seq, frame_no, sample_idx)


# Rows of the per-row truth computed at once, and samples of the events' strides: the
# simulator's truth costs ~1.5 kB of temporaries a sample (its kinematics, each stride's 201-point
# foot path), so the truth of a whole record at once made finishing a `record --simulate` peak
# at 503 MB for 20 minutes, 919 MB for 1 h, 5.1 GB for 2 h (issue 26). 10,000 rows: ~15 MB; the
# peak no longer grows with the record beyond the row map (each row's sample, 8 bytes a row).
# The values are the same: the truth is a function of the sample index
# (tests/test_recorder_memory.py compares blocked and whole).
TRUTH_BLOCK_ROWS = 10_000


def attach_ground_truth(path: str | Path, unit: SimulatedUnit,
                        block_rows: int = TRUTH_BLOCK_ROWS) -> int:  # fmt: skip
    """Write ``/truth`` into a finished session file, ``block_rows`` rows at a time; returns
    the number of rows mapped."""
    frame_no, sample_idx, _ = unit.frame_log(copy=False)  # the unit produces no more
    with read_stored(Path(path)) as s:
        n = s.n_samples
        samples = np.empty(n, np.int64)
        for a in range(0, n, block_rows):
            seq = s.read_range(a, a + block_rows, ["timeline/seq"])["timeline/seq"]
            samples[a : a + len(seq)] = _samples_of(seq, frame_no, sample_idx)
    del frame_no, sample_idx
    valid = samples >= 0
    n_valid = int(valid.sum())
    if not n_valid:
        return 0
    # the rows mapped and their samples (every row, usually: then no copies)
    valid_rows = None if n_valid == n else np.flatnonzero(valid)
    recorded = samples if valid_rows is None else samples[valid_rows]
    del valid
    lo, hi = int(recorded.min()), int(recorded.max()) + 1

    # the events and the strides they open, piece by piece over the samples (each stride is
    # one heel strike's: the pieces partition them)
    parts = [unit.true_events(a, min(a + block_rows, hi)) for a in range(lo, hi, block_rows)]
    hs = np.concatenate([p[0] for p in parts])
    to = np.concatenate([p[1] for p in parts])
    strides = {k: np.concatenate([getattr(p[2], k) for p in parts])
               for k in ("stride_length_m", "stride_time_s", "foot_clearance_m")}  # fmt: skip
    events: dict[str, np.ndarray] = {}
    for name, ev in (("heel_strike", hs), ("toe_off", to)):
        k = np.searchsorted(recorded, ev)  # first recorded row at/after each event
        k = k[k < n_valid]
        events[name] = (k if valid_rows is None else valid_rows[k]).astype(np.int64)
    kept = np.searchsorted(recorded, hs) < n_valid  # the stride each recorded hs opens
    del valid_rows, recorded, parts
    with truth_writer(path, np.degrees(unit.truth(0, 0).mount_offset_rad)) as g:
        g.put("sample_idx", samples)
        out = {name: g.rows(name, n, cols) for name, cols in _PER_ROW.items()}
        for a in range(0, n, block_rows):
            for name, data in _per_row(unit, samples[a : a + block_rows]).items():
                out[name][a : a + len(data)] = data
        for name, data in events.items():
            g.put(name, data)
        for name, data in strides.items():
            g.put(name, data[kept])
        return n_valid


_PER_ROW = {"tilt_deg": 4, "joint_deg": 3, "gyro_bias_rad_s": 4}


def _samples_of(seq: np.ndarray, frame_no: np.ndarray, sample_idx: np.ndarray) -> np.ndarray:
    """:func:`row_samples` of rows ``seq`` from the unit's frame log (taken once)."""
    if len(frame_no) == 0:
        return np.full(len(seq), -1, dtype=np.int64)
    if len(frame_no) > 1 and not bool(np.all(frame_no[1:] > frame_no[:-1])):
        order = np.argsort(frame_no)
        frame_no, sample_idx = frame_no[order], sample_idx[order]
    pos = np.clip(np.searchsorted(frame_no, seq), 0, len(frame_no) - 1)
    return np.where(frame_no[pos] == seq, sample_idx[pos], -1)


def _per_row(unit: SimulatedUnit, samples: np.ndarray) -> dict[str, np.ndarray]:
    """The per-row truth (float32, NaN on unmapped rows) of rows whose samples are
    ``samples``."""
    valid = samples >= 0
    if not valid.any():
        return {name: np.full((len(samples), cols), np.nan, np.float32)
                for name, cols in _PER_ROW.items()}  # fmt: skip
    lo, hi = int(samples[valid].min()), int(samples[valid].max()) + 1
    truth = unit.truth(lo, hi)
    idx = np.clip(samples - lo, 0, hi - lo - 1)
    out = {}
    for name, arr in (("tilt_deg", np.degrees(truth.tilt_rad)),
                      ("joint_deg", np.degrees(truth.joint_rad)),
                      ("gyro_bias_rad_s", truth.gyro_bias_rad_s)):  # fmt: skip
        rows = arr[idx].astype(np.float32)
        rows[~valid] = np.nan
        out[name] = rows
    return out
