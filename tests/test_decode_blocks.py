"""Reading a long series decodes it a block of rows at a time (issue 28: an 8-hour session's
joint angles, derived from the stored int16 tilts, took ~250 MB of int32 and float64
temporaries when decoded whole), to the same float32 values bit for bit."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from gaitmon.io.session import codec

TILT = "processed/tilt_deg"


def _stored(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    s = rng.integers(-18000, 18001, size=(n, 4)).astype(np.int16)
    nan = np.iinfo(np.int16).min
    s[rng.choice(n, size=n // 100, replace=False), rng.integers(0, 4)] = nan  # NaN tilts
    s[[0, n - 1, 999, 1000], 2] = nan  # on block edges
    return s


def _whole_joints(stored: np.ndarray) -> np.ndarray:
    """The previous code: the whole series at once."""
    j = codec._dequantise(codec.joint_centideg(stored), codec.CENTIDEG)
    nan = stored == np.iinfo(np.int16).min
    plus = np.array([p for p, _ in codec.JOINT_PAIRS])
    minus = np.array([m for _, m in codec.JOINT_PAIRS])
    j[nan[:, plus] | nan[:, minus]] = np.nan
    return j


@pytest.mark.parametrize("block", [1000, 777, 1 << 16])
def test_joints_and_tilts_decoded_in_blocks_equal_the_whole_series(block, monkeypatch):
    monkeypatch.setattr(codec, "DECODE_BLOCK_ROWS", block)
    stored = _stored(5_003, block)
    got = codec.joints_from_stored_tilts(stored, TILT)
    want = _whole_joints(stored)
    assert got.dtype == np.float32 and got.shape == (5_003, 3)
    np.testing.assert_array_equal(got.view(np.int32), want.view(np.int32))  # bits, NaN too
    tilts = codec.dequantise(stored, codec.CENTIDEG)
    whole = codec._dequantise(stored, codec.CENTIDEG)
    assert tilts.dtype == np.float32
    np.testing.assert_array_equal(tilts.view(np.int32), whole.view(np.int32))
    one = codec.dequantise(stored[:, 0], codec.CENTIDEG)  # 1-D
    np.testing.assert_array_equal(one.view(np.int32), whole[:, 0].copy().view(np.int32))


def test_decoding_a_long_series_holds_little_beside_its_result():
    n = 600_000  # ~1.7 h
    stored = _stored(n, 1)
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        joints = codec.joints_from_stored_tilts(stored, TILT)
        peak_joints = tracemalloc.get_traced_memory()[1] - base
        del joints
        tracemalloc.reset_peak()
        tilts = codec.dequantise(stored, codec.CENTIDEG)
        peak_tilts = tracemalloc.get_traced_memory()[1] - base
        del tilts
    finally:
        tracemalloc.stop()
    # the results: 12 and 16 bytes a row; whole, the temporaries added > 60 and > 40 a row
    assert peak_joints < 30 * n, peak_joints
    assert peak_tilts < 30 * n, peak_tilts
