"""gaitmon.io.overview (min/max decimation, pyramid, visible-range reads) against brute force,
and the review side file of user exclusions."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gaitmon.errors import Cancelled
from gaitmon.io.overview import PeakPyramid, SessionOverview, peak_decimate
from gaitmon.io.session import exclusions as excl


def _brute_bins(y: np.ndarray, start: int, step: int, n_bins: int):
    """min/max of each bin [start + j*step, start + (j+1)*step) by plain Python loops."""
    mins, maxs = [], []
    for j in range(n_bins):
        seg = y[start + j * step : start + (j + 1) * step]
        mins.append([min((v for v in seg[:, c] if v == v), default=np.nan)
                     for c in range(y.shape[1])])  # fmt: skip
        maxs.append([max((v for v in seg[:, c] if v == v), default=np.nan)
                     for c in range(y.shape[1])])  # fmt: skip
    return np.array(mins), np.array(maxs)


def _check_window(w, y):
    assert len(w.idx) == len(w.y)
    if len(w.y) == 0:
        assert w.stop - w.start <= w.step  # an empty range
        return
    if w.step == 1:
        np.testing.assert_array_equal(w.y, y[w.idx])
        return
    m = len(w.y) // 2
    assert np.all(w.idx[0::2] == w.idx[1::2])
    np.testing.assert_array_equal(np.diff(w.idx[0::2]), w.step)
    mins, maxs = _brute_bins(y, int(w.idx[0]), w.step, m)
    np.testing.assert_array_equal(w.y[0::2], mins)
    np.testing.assert_array_equal(w.y[1::2], maxs)


def test_peak_decimate_keeps_a_one_sample_spike_and_matches_brute_force():
    rng = np.random.default_rng(1)
    y = rng.normal(size=(10_007, 3)).astype(np.float32)
    y[5_001, 1] = 50.0  # a one-sample spike must survive decimation
    y[7_000, 2] = -40.0
    w = peak_decimate(y, 400, start=100)
    assert w.decimated and len(w.y) <= 400
    assert w.y[:, 1].max() == 50.0 and w.y[:, 2].min() == -40.0
    # rows are absolute: bin j starts at 100 + j * step
    assert w.idx[0] == 100
    _check_window(type(w)(w.idx - 100, w.y, w.step, 0, len(y)), y)


def test_peak_decimate_returns_every_row_when_they_fit():
    y = np.arange(10.0).reshape(-1, 1)
    w = peak_decimate(y, 20, start=5)
    assert w.step == 1
    np.testing.assert_array_equal(w.idx, np.arange(5, 15))
    np.testing.assert_array_equal(w.y, y)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 5000),
    a=st.integers(0, 5000),
    length=st.integers(0, 5000),
    max_points=st.integers(2, 300),
    nan_frac=st.sampled_from([0.0, 0.3, 1.0]),
)
def test_pyramid_query_equals_brute_force_min_max(n, a, length, max_points, nan_frac):
    rng = np.random.default_rng(n + a)
    y = rng.normal(size=(n, 2))
    y[rng.random(size=y.shape) < nan_frac] = np.nan
    pyr = PeakPyramid.build(lambda s, e: y[s:e], n, base_step=4, factor=3, chunk_rows=64)
    start, stop = min(a, n), min(n, a + length)
    w = pyr.query(start, stop, max_points)
    if stop > start:
        # the bins cover the requested rows, and at most max_points rows unless even the
        # coarsest level is finer than that
        assert w.start <= start and w.stop >= stop
        coarsest = len(pyr.levels) - 1
        assert len(w.y) <= max(max_points, 2 * len(pyr.levels[coarsest][0]))
    _check_window(w, y)


def test_pyramid_levels_equal_direct_decimation_of_the_whole_series():
    rng = np.random.default_rng(7)
    y = rng.normal(size=(100_000, 3)).astype(np.float32)
    pyr = PeakPyramid.from_array(y, base_step=16, factor=4)
    for level in range(len(pyr.levels)):
        step = pyr.step(level)
        mins, maxs = pyr.levels[level]
        m = len(y) // step
        full = y[: m * step].reshape(m, step, 3)
        np.testing.assert_array_equal(mins[:m], full.min(axis=1))
        np.testing.assert_array_equal(maxs[:m], full.max(axis=1))
        if len(y) % step:
            np.testing.assert_array_equal(mins[m], y[m * step :].min(axis=0))


def test_session_overview_reads_only_what_it_needs_and_builds_a_pyramid_for_long_ranges():
    rng = np.random.default_rng(3)
    data = {"a": rng.normal(size=(400_000, 2)).astype(np.float32)}
    reads: list[tuple[int, int]] = []

    def read(name, s, e):
        reads.append((s, e))
        return data[name][s:e]

    ov = SessionOverview(read, 400_000)
    w = ov.window("a", 1000, 2500, 2000)  # fits: raw rows, one read of exactly that range
    assert w.step == 1 and reads == [(1000, 2500)]
    _check_window(w, data["a"])
    reads.clear()
    w = ov.window("a", 0, 50_000, 2000)  # moderate: direct read + decimation, no pyramid
    assert w.decimated and not ov.has_pyramid("a") and reads == [(0, 50_000)]
    _check_window(w, data["a"])
    w = ov.window("a", 0, 400_000, 2000)  # long: the pyramid, built once
    assert ov.has_pyramid("a")
    _check_window(w, data["a"])
    assert w.y[:, 0].max() == data["a"][:, 0].max()
    n_reads = len(reads)
    w = ov.window("a", 100_000, 390_000, 1000)
    assert len(reads) == n_reads  # answered from memory
    _check_window(w, data["a"])


def test_pyramid_build_can_be_cancelled():
    y = np.zeros((1 << 18, 1))
    calls = []

    def progress(f):
        calls.append(f)
        return f < 0.5

    with pytest.raises(Cancelled):
        PeakPyramid.build(lambda a, b: y[a:b], len(y), chunk_rows=1 << 14, progress=progress)
    assert max(calls) < 0.6


def test_exclusions_merge_subtract_and_round_trip(tmp_path):
    e = excl.Exclusion
    merged = excl.merge([e(50, 60, "turn"), e(10, 20), e(15, 30), e(30, 35)])
    assert [(r.start_idx, r.stop_idx) for r in merged] == [(10, 35), (50, 60)]
    cut = excl.subtract(merged, 12, 14)
    assert [(r.start_idx, r.stop_idx) for r in cut] == [(10, 12), (14, 35), (50, 60)]
    f = tmp_path / "s.h5"
    f.write_bytes(b"")
    t = np.arange(100) / 100.0
    sp = excl.save(f, cut, "2026-01-01T00:00:00Z", 100, t)
    doc = json.loads(sp.read_text())
    assert sp.name == "s.h5.review.json" and doc["excluded_ranges"][2]["label"] == "turn"
    assert doc["excluded_ranges"][0]["stop_t_s"] == pytest.approx(0.11)
    back, problem = excl.load(f, "2026-01-01T00:00:00Z", 100)
    assert problem == "" and back == cut
    other, problem = excl.load(f, "2027-01-01T00:00:00Z", 100)
    assert other == [] and "another recording" in problem
    sp.write_text("{not json")
    bad, problem = excl.load(f, "2026-01-01T00:00:00Z", 100)
    assert bad == [] and "unreadable" in problem
    excl.save(f, [], "x", 100)
    assert not sp.exists()


def test_the_stored_overview_of_a_file_whose_mode_is_stored_as_bytes(gap_recording, tmp_path):
    """A file whose ``mode`` attribute is bytes (another writer's choice) gets the same joint
    overview as one whose mode is text: the mode was read as ``str(b'raw')`` ("b'raw'"), so
    the derived joints were looked for as stored, not found, and their overview left out."""
    import shutil

    import h5py

    from gaitmon.io.session.stored_overview import read_overview, write_overview

    path = tmp_path / "bytes.h5"
    shutil.copyfile(gap_recording, path)
    with h5py.File(path, "r+") as f:
        n = f["timeline/t_s"].shape[0]
        want = read_overview(f, "processed/joint_deg", n)
        assert want is not None
        f.attrs["mode"] = np.bytes_(b"raw")
        write_overview(f)
        got = read_overview(f, "processed/joint_deg", n)
    assert got is not None
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
