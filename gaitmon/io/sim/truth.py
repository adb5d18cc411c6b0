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
from gaitmon.io.session.truth import write_truth
from gaitmon.io.sim.unit import SimulatedUnit


def row_samples(seq: np.ndarray, unit: SimulatedUnit) -> np.ndarray:
    """Sample index of each recorded row (-1 where the frame is not in the unit's log)."""
    frame_no, sample_idx, _ = unit.frame_log()
    if len(frame_no) == 0:
        return np.full(len(seq), -1, dtype=np.int64)
    order = np.argsort(frame_no)
    frame_no, sample_idx = frame_no[order], sample_idx[order]
    pos = np.clip(np.searchsorted(frame_no, seq), 0, len(frame_no) - 1)
    return np.where(frame_no[pos] == seq, sample_idx[pos], -1)


def attach_ground_truth(path: str | Path, unit: SimulatedUnit) -> int:
    """Write ``/truth`` into a finished session file; returns the number of rows mapped."""
    with read_stored(Path(path)) as s:
        seq = s.read("timeline/seq")
    samples = row_samples(seq, unit)
    valid = samples >= 0
    if not valid.any():
        return 0
    lo, hi = int(samples[valid].min()), int(samples[valid].max()) + 1
    truth = unit.truth(lo, hi)
    idx = np.clip(samples - lo, 0, hi - lo - 1)
    per_row = {
        "tilt_deg": np.degrees(truth.tilt_rad)[idx],
        "joint_deg": np.degrees(truth.joint_rad)[idx],
        "gyro_bias_rad_s": truth.gyro_bias_rad_s[idx],
    }
    valid_rows = np.flatnonzero(valid)
    datasets: dict[str, np.ndarray] = {"sample_idx": samples}
    for name, arr in per_row.items():
        arr = arr.astype(np.float32)
        arr[~valid] = np.nan
        datasets[name] = arr
    true_events = {"heel_strike": truth.heel_strike_idx, "toe_off": truth.toe_off_idx}
    for name, events in true_events.items():
        k = np.searchsorted(samples[valid], events)  # first recorded row at/after each event
        datasets[name] = valid_rows[k[k < len(valid_rows)]].astype(np.int64)
    # the stride each recorded heel strike opens (same order as "heel_strike")
    k = np.searchsorted(samples[valid], truth.heel_strike_idx)
    recorded = k < len(valid_rows)
    datasets["stride_length_m"] = truth.stride_length_m[recorded]
    datasets["stride_time_s"] = truth.stride_time_s[recorded]
    datasets["foot_clearance_m"] = truth.foot_clearance_m[recorded]
    write_truth(path, datasets, np.degrees(truth.mount_offset_rad))
    return int(valid.sum())
