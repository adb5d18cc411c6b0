"""Finishing a recording holds nothing per row of the whole record (issue 26 item 10): the
frames lost before the rows are kept sparse (:class:`gaitmon.dsp.lost_frames.Losses`) where
the close derives ``/smoothed`` and ``/strides``, with the same numbers as the per-row
arrays they replace."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from gaitmon.dsp.lost_frames import (
    Losses,
    SamplePositions,
    bridge_max_samples,
    bridged_fill,
    bridged_losses,
    restart_rows,
)

FS = 100.0


def _lost(n: int, seed: int) -> np.ndarray:
    """Per-row losses: bridged ones, long ones (restarts), one at row 0 and at the last row."""
    rng = np.random.default_rng(seed)
    lost = np.zeros(n, dtype=np.int64)
    rows = rng.choice(n, size=n // 50, replace=False)
    lost[rows] = rng.integers(1, 3 * bridge_max_samples(FS), size=len(rows))
    lost[0] = 2
    lost[-1] = 1
    return lost


@pytest.mark.parametrize("seed", range(5))
def test_sparse_losses_decide_as_the_per_row_array(seed: int) -> None:
    n = 5_000
    lost = _lost(n, seed)
    sparse = Losses.of(lost)
    assert np.array_equal(restart_rows(sparse, FS), np.flatnonzero(lost > bridge_max_samples(FS)))
    fill = np.where((lost > 0) & (lost <= bridge_max_samples(FS)), lost, 0)
    fill[0] = 0  # nothing to fill from before row 0
    assert np.array_equal(bridged_fill(lost, FS), fill)
    assert bridged_losses(sparse, FS) == {int(r): int(fill[r]) for r in np.flatnonzero(fill)}

    pos = np.arange(n, dtype=np.int64) + np.cumsum(fill)  # the per-row map it replaces
    where = SamplePositions(sparse, n, FS)
    rows = np.arange(-3, n + 5)
    want = rows.copy()
    inside = (rows >= 0) & (rows < n)
    want[inside] = pos[rows[inside]]
    want[rows >= n] += pos[-1] - (n - 1)
    assert np.array_equal(where.samples_of(rows), want)
    for x in range(-2, int(pos[-1]) + 4):
        assert where.first_row_at(x) == int(np.searchsorted(pos, x, side="left")), x


def test_stride_measures_from_sparse_losses_equal_the_per_row_ones() -> None:
    """Blocks of a few strides (boundaries falling mid-stride, losses inside strides and on
    block edges) give bit for bit the measures of the per-row losses."""
    from gaitmon.dsp.stride_streaming import record_stride_measures

    rng = np.random.default_rng(7)
    n = 6_000
    t = np.arange(n) / FS
    ax = 9.81 * np.sin(2 * np.pi * t) + rng.normal(0, 0.3, n)
    az = 9.81 + rng.normal(0, 0.3, n)
    gy = 3 * np.sin(2 * np.pi * t + 0.3) + rng.normal(0, 0.1, n)
    hs = np.arange(37, n - 60, 103, dtype=np.int64)
    lost = np.zeros(n, dtype=np.int64)
    lost[hs[3:40:4] + 11] = 2  # bridged, mid-stride
    lost[hs[5]] = 1  # on a heel strike
    lost[hs[20] + 50] = 40  # a restart

    def read(a: int, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return ax[a:b], az[a:b], gy[a:b]

    for per in (1, 3, 7):
        dense = record_stride_measures(read, n, FS, hs, strides_per_block=per, lost_before=lost)
        sparse = record_stride_measures(read, n, FS, hs, strides_per_block=per,
                                        lost_before=Losses.of(lost))  # fmt: skip
        for name in ("heel_strike_idx", "stride_length_m", "foot_clearance_m", "stride_time_s",
                     "foot_flat_idx", "flags"):  # fmt: skip
            np.testing.assert_array_equal(getattr(sparse, name), getattr(dense, name), name)


def test_strides_stamp_hashed_in_blocks_equals_the_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    """``/strides``'s ``computed_from`` is what it was when the whole per-row fill was hashed
    (a stored ``/strides`` stays valid), whatever the block."""
    import json

    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import DEFAULT_TABLE
    from gaitmon.finish import strides

    n = 10_007
    lost = _lost(n, 3)
    fill = bridged_fill(lost, FS)
    old = {"filled_frames": int(fill.sum()),
           "filled_sha1": hashlib.sha1(fill.astype("<i8").tobytes()).hexdigest()}  # fmt: skip
    cal = Calibration.identity()
    for block in (1_000, 4_096, 1 << 20):
        monkeypatch.setattr(strides, "_STAMP_BLOCK_ROWS", block)
        for given in (lost, Losses.of(lost)):
            got = json.loads(strides.StrideInputs(n, FS, DEFAULT_TABLE, cal, [], given).stamp())
            assert {k: got[k] for k in old} == old


def _recording_with_losses(path, n: int = 9_000) -> None:
    """A raw recording of ``n`` rows closed as the recorder closes it, with bridged losses
    (mid-stride) and one long one (a restart) in its gap table."""
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.finish import close_recording
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
    from gaitmon.io.sim.sensors import simulate

    counts = simulate(n + 100, GaitModel(GaitConfig(seed=4)), SensorConfig(seed=4)).counts
    losses = {1_234: 2, 2_001: 1, 4_500: 30, 6_007: 3}  # row: frames lost before it
    pipe = Pipeline()
    seq0 = 0
    with SessionWriter(path, SessionHeader("raw")) as w:
        a = 0
        for b in (*sorted(losses), n):
            if a in losses:
                w.add_gap(losses[a], losses[a] / FS, "frames lost")
                seq0 += losses[a]
            lost = np.zeros(b - a, np.int64)
            lost[0] = losses.get(a, 0)
            seq = np.arange(a, b, dtype=np.int64) + seq0
            blk = SampleBlock(FrameKind.RAW, seq, 10.0 + seq / FS, 1.7e9, lost_before=lost,
                              adc=counts[seq])  # fmt: skip
            w.append(blk, pipe.process(counts[seq]))
            a = b
        close_recording(w)


def test_the_close_derives_without_a_per_row_loss_array(tmp_path, monkeypatch) -> None:
    """The close builds no per-row loss array (it fails here if it does: issue 26, finishing
    grew with the length), and stores the numbers the per-row arrays give."""
    import h5py

    from gaitmon.finish import smoothed, strides
    from gaitmon.io.session import rows
    from gaitmon.io.session.opening import read_stored

    def per_row(*a: object) -> None:
        raise AssertionError("a per-row loss array built while finishing")

    path = tmp_path / "lossy.h5"
    with monkeypatch.context() as m:
        for mod in (rows, smoothed):
            m.setattr(mod, "lost_before_from_gaps", per_row)
        _recording_with_losses(path)

    with read_stored(path) as s:
        header = s.header
    with h5py.File(path, "r") as f:
        assert len(f["gaps"]) == 4
        want = smoothed.smoothed_from_file(f, header.table, header.calibration, FS)  # per row
        from gaitmon.io.session.codec import encode

        np.testing.assert_array_equal(f["smoothed/tilt_deg"][()],
                                      encode("smoothed/tilt_deg", want["smoothed/tilt_deg"]))
        n = f["raw/adc"].shape[0]
        lost = rows.lost_before_from_gaps(f["gaps"][()], n)
        inputs = strides.StrideInputs(n, FS, header.table, header.calibration, [], lost)
        hs = strides.heel_strikes_used(f["events/heel_strike"][()], n)
        assert len(hs) > 20
        stored = strides.read_stored(f, inputs, hs)  # None unless the stamp is the per-row one
        assert stored is not None
        adc = f["raw/adc"]
        ref = strides.compute(lambda a, b: adc[a:b], inputs, hs)  # the per-row computation
        np.testing.assert_array_equal(stored.stride_length_m, ref.stride_length_m)
        np.testing.assert_array_equal(stored.foot_clearance_m, ref.foot_clearance_m)
        np.testing.assert_array_equal(stored.foot_flat_idx, ref.foot_flat_idx)


def test_the_overview_written_in_blocks_equals_it_written_whole(tmp_path, monkeypatch) -> None:
    import shutil

    import h5py

    from gaitmon.io.session import stored_overview

    path = tmp_path / "lossy.h5"
    _recording_with_losses(path)
    small = tmp_path / "small.h5"
    shutil.copy(path, small)
    monkeypatch.setattr(stored_overview, "_READ_ROWS", 48)  # 3 bins a block
    with h5py.File(small, "r+") as f:
        stored_overview.write_overview(f)
    with h5py.File(path, "r") as whole, h5py.File(small, "r") as blocks:
        names: list[str] = []
        whole["overview"].visit(names.append)
        assert any(n.endswith("/min") for n in names)
        for name in names:
            if isinstance(whole["overview"][name], h5py.Dataset):
                np.testing.assert_array_equal(blocks["overview"][name][()],
                                              whole["overview"][name][()], name)  # fmt: skip
