"""One bilateral measure, one figure: the report, the review's Both legs tab and ``gaitmon
info`` show the same symmetry ratio and index for every row of the symmetry table.

Issue 25 #11: terminal double support's SR / SI read 0.290 / 110.1 % in a two-leg report, were
blank in the review's Both legs tab and absent from ``info`` (the report computed them itself;
the analysis's symmetry table left the measure out). The reference is independent of all three:
the per-side means of the analysis's own per-stride arrays, and SR = L / R, SI = 2|L-R|/(L+R).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from gaitmon.analysis import analyse_bilateral
from gaitmon.cli import main
from gaitmon.finish.bilateral import open_bilateral
from gaitmon.report import bilateral_report_from_file

GOLDEN = Path(__file__).parent / "data" / "golden" / "two_legs.h5"
WAIT_MS = 30_000
MEASURE = "terminal_double_support_s"
LABEL = "terminal double support"


@pytest.fixture
def two_legs(tmp_path: Path) -> Path:
    p = tmp_path / "two_legs.h5"  # a copy: review writes beside the file it opens
    shutil.copyfile(GOLDEN, p)
    return p


def _reference(path: Path) -> tuple[str, str]:
    """SR and SI of terminal double support, from the per-stride arrays themselves."""
    with open_bilateral(path) as b:
        g = analyse_bilateral(b).gait
    lv = float(np.nanmean(g.left.terminal_double_support_s))
    rv = float(np.nanmean(g.right.terminal_double_support_s))
    return f"{lv / rv:.3f}", f"{200.0 * abs(lv - rv) / (lv + rv):.1f}"


def _info_row(path: Path, capsys: pytest.CaptureFixture[str], label: str) -> list[str]:
    """The symmetry line of ``label`` in ``gaitmon info``: [left, right, SR, SI]."""
    capsys.readouterr()
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    head = next(i for i, ln in enumerate(out) if ln.strip().startswith("symmetry     measure"))
    rows = [ln for ln in out[head + 1:] if ln.strip().startswith(label + " ")]
    assert len(rows) == 1, f"no symmetry line for {label!r} in info:\n" + "\n".join(out)
    cells = rows[0].strip()[len(label):].split()
    return [cells[0], cells[2], cells[4], cells[5]]  # "0.123 s 0.456 s 0.290 110.1 %"


def test_terminal_double_support_symmetry_is_one_figure_everywhere(
    qtbot, review_win, two_legs, capsys
) -> None:
    sr, si = _reference(two_legs)
    assert float(sr) != pytest.approx(1.0, abs=0.05)  # an asymmetric walk: a telling figure
    # the report
    rep = next(ln for ln in bilateral_report_from_file(two_legs).symmetry if ln.measure == MEASURE)
    assert rep.cells()[-2:] == (sr, si)
    # gaitmon info
    assert _info_row(two_legs, capsys, LABEL)[2:] == [sr, si]
    # the review's Both legs tab, in the real window
    w = review_win
    with qtbot.waitSignal(w.legs.computed, timeout=WAIT_MS), \
            qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):  # fmt: skip
        w.open_file(two_legs)
    assert w.both_legs.cell(LABEL, "SR (L/R)") == sr
    assert w.both_legs.cell(LABEL, "SI") == f"{si} %"


def test_every_symmetry_row_of_the_report_is_in_info_and_review(
    qtbot, review_win, two_legs, capsys
) -> None:
    """No row of the report's symmetry table is missing from the other two, none differs."""
    rows = bilateral_report_from_file(two_legs).symmetry
    assert len(rows) == 7
    w = review_win
    with qtbot.waitSignal(w.legs.computed, timeout=WAIT_MS), \
            qtbot.waitSignal(w.analysis_done, timeout=WAIT_MS):  # fmt: skip
        w.open_file(two_legs)
    for line in rows:
        label, sr, si = line.label, line.cells()[-2], line.cells()[-1]
        assert w.both_legs.cell(label, "SR (L/R)") == sr, label
        assert w.both_legs.cell(label, "SI") == f"{si} %", label
        assert _info_row(two_legs, capsys, label)[2:] == [sr, si], label
