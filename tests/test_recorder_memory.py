"""Finishing a recording in bounded memory (issue 26 item 10): the simulator's ground truth is
attached to a finished file in row blocks, and gives the same datasets as the whole record at
once (the computation of the code before: ``unit.truth`` over every recorded sample).

A real recording: the simulated unit through the real engine and recorder into an HDF5 file.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from helpers import make_engine, wait_for

from gaitmon.io.sim.truth import attach_ground_truth, row_samples


def _whole_record_truth(path, unit) -> dict[str, np.ndarray]:
    """/truth as the code before issue 26 computed it: the truth of every sample at once."""
    from gaitmon.io.session.opening import read_stored

    with read_stored(path) as s:
        seq = s.read("timeline/seq")
    samples = row_samples(seq, unit)
    valid = samples >= 0
    lo, hi = int(samples[valid].min()), int(samples[valid].max()) + 1
    truth = unit.truth(lo, hi)
    idx = np.clip(samples - lo, 0, hi - lo - 1)
    out = {"sample_idx": samples}
    for name, arr in (("tilt_deg", np.degrees(truth.tilt_rad)),
                      ("joint_deg", np.degrees(truth.joint_rad)),
                      ("gyro_bias_rad_s", truth.gyro_bias_rad_s)):  # fmt: skip
        arr = arr[idx].astype(np.float32)
        arr[~valid] = np.nan
        out[name] = arr
    valid_rows = np.flatnonzero(valid)
    for name, ev in (("heel_strike", truth.heel_strike_idx), ("toe_off", truth.toe_off_idx)):
        k = np.searchsorted(samples[valid], ev)
        out[name] = valid_rows[k[k < len(valid_rows)]].astype(np.int64)
    kept = np.searchsorted(samples[valid], truth.heel_strike_idx) < len(valid_rows)
    for name in ("stride_length_m", "stride_time_s", "foot_clearance_m"):
        out[name] = getattr(truth, name)[kept]
    out["mount_offset_deg"] = np.degrees(truth.mount_offset_rad)
    return out


def _stored_truth(path) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as f:
        g = f["truth"]
        out = {name: g[name][()] for name in g}
        out["mount_offset_deg"] = np.asarray(g.attrs["mount_offset_deg"])
    return out


@pytest.mark.timeout(180)
def test_ground_truth_in_row_blocks_equals_the_whole_record_at_once(tmp_path):
    unit, eng = make_engine(seed=5, speed=40.0, standing_s=1.0)
    out = tmp_path / "walk.h5"
    with eng:
        wait_for(lambda: eng.samples_total >= 200, what="data")
        eng.start_recording(out)
        wait_for(lambda: eng.recording.rows >= 9000, what="rows", timeout_s=120)
        status = eng.stop_recording()
    assert status.error == "" and status.rows >= 9000
    whole = _whole_record_truth(out, unit)
    assert len(whole["heel_strike"]) > 50  # walking: strides cross the block boundaries
    # 997 rows a block: not a multiple of anything; boundaries fall mid-stride
    for block_rows in (997, 4096, 10**9):
        mapped = attach_ground_truth(out, unit, block_rows=block_rows)
        got = _stored_truth(out)
        assert mapped == int((whole["sample_idx"] >= 0).sum())
        assert sorted(got) == sorted(whole)
        for name, ref in whole.items():
            np.testing.assert_array_equal(got[name], ref, err_msg=f"{name} ({block_rows})")
            assert got[name].dtype == ref.dtype, name
