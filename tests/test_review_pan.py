"""What the review window draws after a pan is the file's data for the range in view, by the
documented rule (every row when they fit in the view's point budget, else the min and max of
consecutive bins of rows, both drawn at the bin's first row), checked against a brute-force
reading of the whole series, whichever way the range was answered: at once (a short range or
a built pyramid) or by the view worker (a long range read and decimated); and no answer to an
older range is ever drawn over a newer one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import write_simulated_session

from gaitmon.finish import open_session
from gaitmon.review.model import JOINT

WAIT_MS = 20_000
N_ROWS = 30_000  # 5 minutes at 100 Hz
KNEE = 1


@pytest.fixture(scope="module")
def session_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_simulated_session(tmp_path_factory.mktemp("pan") / "walk.h5", n=N_ROWS)


@pytest.fixture(scope="module")
def truth(session_file: Path) -> tuple[np.ndarray, np.ndarray]:
    """(t_s, knee angle) of every row, as the session reader decodes the whole series."""
    with open_session(session_file) as s:
        s.use_angles("smoothed")
        t = np.asarray(s.read_range(0, s.n_samples, ["timeline/t_s"])["timeline/t_s"])
        y = np.asarray(s.read_range(0, s.n_samples, [JOINT])[JOINT])[:, KNEE]
    return t, y


def _knee_points(tl) -> np.ndarray:
    lane = tl.lanes["knee"]
    tr = next(tr for spec, tr in lane.specs if spec.method == "kalman" and not spec.before)
    assert tr.visible and tr.path is not None
    path = tr.path
    return np.array([(path.elementAt(i).x, path.elementAt(i).y)
                     for i in range(path.elementCount())])  # fmt: skip


def _check_drawn(tl, truth: tuple[np.ndarray, np.ndarray]) -> str:
    """The knee trace against the rule for the view's range; "rows" or "bins"."""
    t, y = truth
    x0, x1 = tl.view_range()
    pts = _knee_points(tl)
    first = int(np.searchsorted(t, pts[0, 0]))
    assert t[first] == pts[0, 0]
    in_view = int(np.searchsorted(t, x1, "right") - np.searchsorted(t, x0, "left"))
    width = tl.master.getViewBox().width()
    budget = max(600, min(4000, 2 * width))  # the timeline's points per view
    if len(pts) >= in_view:  # every row: consecutive rows, each its own value
        rows = np.arange(first, first + len(pts))
        np.testing.assert_array_equal(pts[:, 0], t[rows])
        np.testing.assert_array_equal(pts[:, 1], y[rows].astype(np.float64))
        assert pts[0, 0] <= x0 and pts[-1, 0] >= x1
        return "rows"
    # bins: pairs (min, max) at the bin's first row, consecutive bins of `step` rows
    assert len(pts) <= budget + 2 and len(pts) % 2 == 0
    starts = np.searchsorted(t, pts[0::2, 0])
    np.testing.assert_array_equal(pts[0::2, 0], pts[1::2, 0])
    steps = np.diff(starts)
    step = int(steps[0])
    assert step > 1 and np.all(steps == step)
    assert step >= in_view / (budget / 2)  # at most ~2 points per pixel
    for j, a in enumerate(starts[:-1].tolist()):
        seg = y[a : a + step]
        assert pts[2 * j, 1] == np.float64(seg.min()), (j, a)
        assert pts[2 * j + 1, 1] == np.float64(seg.max()), (j, a)
    # the last bin may be short (the range read ends there): some k <= step rows
    a = int(starts[-1])
    ks = [k for k in range(1, step + 1) if pts[-2, 1] == np.float64(y[a : a + k].min())
          and pts[-1, 1] == np.float64(y[a : a + k].max())]  # fmt: skip
    assert ks, "the last bin is not the min and max of its rows"
    # the bins cover the view
    assert pts[0, 0] <= x0 and t[min(len(t) - 1, a + step - 1)] >= x1
    return "bins"


def _open(qtbot, w, path: Path) -> None:
    w.resize(1500, 950)
    with qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):
        w.open_file(path)
    qtbot.waitUntil(lambda: w.timeline.applied_requests > 0, timeout=WAIT_MS)


def _settle(qtbot, tl) -> None:
    qtbot.waitUntil(lambda: not tl.loader.busy, timeout=WAIT_MS)
    qtbot.wait(20)  # a delivered answer is applied on the next event-loop pass


def test_a_short_pan_is_drawn_at_once_with_the_rows_of_its_range(qtbot, review_win, session_file,
                                                                 truth) -> None:
    _open(qtbot, review_win, session_file)
    tl = review_win.timeline
    x0 = 60.0
    for _ in range(8):
        x0 += 2.7  # not a whole number of rows: the range's ends fall between samples
        n = tl.applied_requests
        tl.set_view(x0, x0 + 10.0)
        # answered before the next paint, without the worker
        assert tl.applied_requests == n + 1 and not tl.loader.busy
        assert _check_drawn(tl, truth) == "rows"


def test_a_wide_pan_draws_the_min_and_max_of_each_bin(qtbot, review_win, session_file,
                                                       truth) -> None:
    _open(qtbot, review_win, session_file)
    tl = review_win.timeline
    seen = set()
    for k in range(6):  # 2-minute views over the 5 minutes, the first ones by the worker
        n = tl.applied_requests
        tl.set_view(13.3 * k, 13.3 * k + 120.0)
        qtbot.waitUntil(lambda n=n: tl.applied_requests > n, timeout=WAIT_MS)
        _settle(qtbot, tl)
        seen.add(_check_drawn(tl, truth))
    assert seen == {"bins"}


def test_an_older_answer_is_never_drawn_over_a_newer_range(qtbot, review_win, session_file,
                                                          truth) -> None:
    """A wide view (read by the worker) then at once a short one (answered at once): the
    worker's answer, arriving after, must not replace the short view's rows."""
    _open(qtbot, review_win, session_file)
    tl = review_win.timeline
    for k in range(4):
        tl.set_view(20.0 + 31.7 * k, 20.0 + 31.7 * k + 200.0)  # rows enough for the worker
        tl.set_view(100.0 + k, 110.0 + k)
        _settle(qtbot, tl)
        assert tl.view_range() == pytest.approx((100.0 + k, 110.0 + k))
        assert _check_drawn(tl, truth) == "rows"
