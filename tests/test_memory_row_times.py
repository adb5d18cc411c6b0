"""The stride analysis reads the true times of its events only, a bounded slice at a time
(issue 28: ``gaitmon info``, the report and a recovery's closing analysis read the whole
``/timeline/t_s``, 23 MB of an 8-hour record on top of the joint angles, and put recovery's
peak at ~267 MB), with the same strides as from the whole series. A real recording of the
simulated unit walking."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gaitmon.analysis import analyse_session, analyse_strides, session_gaps
from gaitmon.io.session import row_times
from gaitmon.io.session.row_times import RowValues


@pytest.fixture(scope="module")
def walk(tmp_path_factory, record_simulated) -> Path:
    """A 60-s recording of the simulated unit walking (6000 rows)."""
    return record_simulated(tmp_path_factory.mktemp("rows") / "walk.h5", duration_s=60)


def _logged_reads(s, monkeypatch) -> list[tuple[int, int, tuple[str, ...]]]:
    """Every ``s.read_range`` from now on, as (first row, end row, datasets)."""
    reads: list[tuple[int, int, tuple[str, ...]]] = []
    read_range = s.read_range

    def logged(a, b, names=None):
        reads.append((int(a), int(b), tuple(names or ())))
        return read_range(a, b, names)

    monkeypatch.setattr(s, "read_range", logged)
    return reads


def test_the_analysis_reads_the_timeline_in_bounded_slices_with_the_same_strides(
    walk, monkeypatch
):
    from gaitmon.finish import open_session

    monkeypatch.setattr(row_times, "SLICE_ROWS", 500)
    with open_session(walk) as s:
        whole_t = s.read("timeline/t_s")
        reads = _logged_reads(s, monkeypatch)
        an = analyse_session(s)
        monkeypatch.undo()  # (the reference below reads as before)
        # what the analysis computed before: the strides timed from the whole series
        want = analyse_strides(s.heel_strike_idx, s.toe_off_idx, s.sample_rate_hz,
                               an.joints_deg, session_gaps(s), [], t_s=whole_t)  # fmt: skip
    timeline = [(a, b) for a, b, names in reads if "timeline/t_s" in names]
    assert timeline, "the times were not read through the session"
    assert max(b - a for a, b in timeline) <= 500
    assert len(an.rows) > 20 and len(an.rows) == len(want)
    for got, ref in zip(an.rows, want, strict=True):
        assert got.stride == ref.stride  # the stride, stance and swing times to the bit
        assert got.excluded == ref.excluded


class _Series:
    def __init__(self, t: np.ndarray) -> None:
        self.t = t
        self.n_samples = len(t)
        self.reads: list[tuple[int, int]] = []

    def read_range(self, a, b, names=None):
        self.reads.append((a, b))
        return {names[0]: self.t[a:b]}


def test_row_values_are_the_series_at_the_rows_asked_and_refuse_others() -> None:
    t = np.cumsum(np.random.default_rng(3).uniform(0.009, 0.011, 10_000))
    src = _Series(t)
    rows = np.array([9999, 5, 5, 0, 2500, 12_000, -1, 7001, 7002, 2499])
    got = RowValues.read(src, "timeline/t_s", rows, slice_rows=1000)
    inside = [0, 5, 2499, 2500, 7001, 7002, 9999]
    assert len(got) == 10_000
    np.testing.assert_array_equal(got.take([2500, 0, 9999, 5]), t[[2500, 0, 9999, 5]])
    np.testing.assert_array_equal(got.take(inside), t.take(inside))
    assert all(b - a <= 1000 for a, b in src.reads)
    assert sum(b - a for a, b in src.reads) < 100  # only around the rows asked
    with pytest.raises(IndexError):
        got.take([6])
    empty = RowValues.read(src, "timeline/t_s", np.array([], np.int64))
    assert len(empty) == 10_000 and len(empty.take([])) == 0


def test_info_reads_the_joint_angles_in_bounded_slices_with_the_same_figures(walk, monkeypatch):
    """``gaitmon info``'s analysis (keep_joints=False) reads the joint angles a slice at a
    time and gives every stride the figures of the whole series (the report's analysis)."""
    from gaitmon.dsp import stride_extremes
    from gaitmon.finish import open_session

    monkeypatch.setattr(stride_extremes, "SLICE_ROWS", 700)
    with open_session(walk) as s:
        whole = analyse_session(s)
        reads = _logged_reads(s, monkeypatch)
        sliced = analyse_session(s, keep_joints=False)
    joints = [(a, b) for a, b, names in reads if "processed/joint_deg" in names]
    assert len(joints) > 3 and max(b - a for a, b in joints) <= 700
    assert sliced.joints_deg is None and whole.joints_deg is not None
    assert len(whole.rows) > 20
    assert repr(sliced.rows) == repr(whole.rows)  # every figure to the bit (NaN included)


def test_stride_extremes_in_slices_equal_those_of_the_whole_series() -> None:
    from gaitmon.dsp.stride_extremes import stride_extremes, stride_extremes_sliced

    rng = np.random.default_rng(7)
    n = 5000
    a = rng.normal(0, 30, (n, 3)).astype(np.float32)
    hs = np.array([0, 90, 200, 260, 1500, 1610, 4880, 4999, 5100])  # one stride past the end
    start, end = hs[:-1], hs[1:]
    toe = start + (end - start) // 2
    want = stride_extremes(a, start, end, toe)
    for step in (50, 111, 1000, 10**6):  # one stride longer than a slice, one ending last
        got = stride_extremes_sliced(n, lambda x, y: a[x:y], start, end, toe, step)
        assert repr(got) == repr(want), step
    assert np.isnan(want[0][-1]) and np.isfinite(want[0][-2])
