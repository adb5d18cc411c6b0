"""The bilateral report: ``gaitmon report FILE`` of a file that records both legs.

On a real recorded bilateral file (12 s, hemiparetic, through both units' real decoders): the
symmetry table in the PDF (read back with ``pdftotext``, an independent reading of the file)
says what ``gaitmon info`` prints for the same rows, and its numbers are ``analyse_bilateral``'s;
both legs' curves are the one-leg report's means and are drawn in their colours; each leg's
exclusions are honoured; the PDF is two pages and small; ``--side`` still gives one leg.
"""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from gaitmon.cli import main
from gaitmon.finish import open_session
from gaitmon.finish.bilateral import open_bilateral

needs_poppler = pytest.mark.skipif(
    shutil.which("pdftotext") is None or shutil.which("pdfinfo") is None,
    reason="poppler-utils (pdftotext, pdfinfo) not installed",
)


@pytest.fixture(scope="module")
def both(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bireport") / "both.h5"
    # 1.5 s standing (default 5, of which the recording keeps what is left once the units
    # connect: a warm process connects sooner and kept 3 of the 12 s walking, 3 strides)
    rc = main(["record", "--simulate-bilateral", "--duration", "12", "--speed", "4",
               "--asymmetry", "hemiparetic", "--standing-s", "1.5", "-o", str(out), "-q",
               "--patient", "P9"])  # fmt: skip
    assert rc == 0
    return out


@pytest.fixture(scope="module")
def pdf(qapp: object, both: Path) -> Path:  # qapp: pytest-qt's application, not the report's
    out = both.with_name("report.pdf")
    assert main(["report", str(both), "-o", str(out), "-q"]) == 0
    return out


def _text(pdf: Path) -> str:
    return subprocess.run(["pdftotext", "-layout", str(pdf), "-"], check=True,
                          capture_output=True, text=True).stdout  # fmt: skip


def _pages(pdf: Path) -> int:
    info = subprocess.run(["pdfinfo", str(pdf)], check=True, capture_output=True, text=True)
    return int(re.search(r"^Pages:\s+(\d+)", info.stdout, re.M).group(1))  # type: ignore[union-attr]


def _pdf_row(text: str, label: str) -> list[str]:
    """The symmetry table's row ``label`` as the PDF shows it: its six number cells."""
    rows = [ln.split() for ln in text.splitlines()
            if re.match(rf"\s*{label}\s{{2,}}[\d–]", ln)]  # fmt: skip
    assert len(rows) == 1, (label, rows)
    cells = rows[0][len(label.split()):]
    assert len(cells) == 6, cells
    return cells


def _info(both: Path, capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(["info", str(both)]) == 0
    return capsys.readouterr().out


@needs_poppler
def test_pdf_table_says_what_info_prints(
    both: Path, pdf: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = _text(pdf)
    out = _info(both, capsys)
    # the symmetry rows of info: measure, left s, right s, SR, SI
    sym = {}
    for ln in out.splitlines():
        m = re.match(r"\s+([a-z ]+?)\s+([\d.]+) s\s+([\d.]+) s\s+([\d.]+)\s+([\d.]+) %$", ln)
        if m:
            sym[m.group(1)] = m.groups()[1:]
    assert set(sym) == {"step time", "stride time", "stance", "swing", "single support",
                        "initial double support", "terminal double support"}  # fmt: skip
    for label, (left_s, right_s, sr, si) in sym.items():
        cells = _pdf_row(text, label)
        assert (cells[0], cells[2], cells[4], cells[5]) == (left_s, right_s, sr, si), label
    # the % of the stride and seconds lines of info: stance ... single support
    pct_lines = {"stance": "stance", "swing": "swing", "double supp. initial":
                 "initial double support", "terminal": "terminal double support",
                 "single supp.": "single support"}  # fmt: skip
    seen = 0
    for ln in out.splitlines():
        m = re.match(r"\s+(stance|swing|double supp\. initial|terminal|single supp\.)\s+L ([\d.]+) "
                     r"% \(([\d.]+) s\), R ([\d.]+) % \(([\d.]+) s\)", ln)  # fmt: skip
        if m:
            seen += 1
            lp, ls, rp, rs = m.groups()[1:]
            cells = _pdf_row(text, pct_lines[m.group(1)])
            assert (cells[0], cells[1], cells[2], cells[3]) == (ls, lp, rs, rp), m.group(1)
    assert seen == 5
    # measured cadence and each side's stride counts
    cad, nl, nr = re.search(r"cadence\s+(\d+) steps/min \(measured.*strides L (\d+), R (\d+)",
                            out).groups()  # type: ignore[union-attr]  # fmt: skip
    assert re.search(rf"Cadence \(measured\)\s+{cad} steps/min", text)
    counted = re.search(r"left (\d+) of (\d+), right (\d+) of (\d+)", text).groups()  # type: ignore[union-attr]
    assert (counted[0], counted[2]) == (nl, nr)
    totals = [re.search(r"strides\s+(\d+) included, (\d+) excluded", blk).groups()  # type: ignore[union-attr]
              for blk in out.split(" leg (")[1:3]]  # fmt: skip
    assert [counted[1], counted[3]] == [str(int(a) + int(b)) for a, b in totals]


@needs_poppler
def test_table_numbers_are_analyse_bilaterals_and_show_the_hemiparetic_step(
    both: Path, pdf: Path
) -> None:
    from gaitmon.analysis import analyse_bilateral
    from gaitmon.report import bilateral_report_from_file

    with open_bilateral(both) as b:
        g = analyse_bilateral(b).gait
    data = bilateral_report_from_file(both)
    for line in data.symmetry:
        assert line.left_s == g.left.mean(line.measure)
        assert line.right_s == g.right.mean(line.measure)
        if line.measure in ("step_s", "stride_s"):
            assert np.isnan(line.left_pct) and np.isnan(line.right_pct)
        else:  # % of each stride's own time, averaged: by hand from the rows
            v = 100 * getattr(g.left, line.measure) / g.left.stride_s
            assert line.left_pct == pytest.approx(np.nanmean(v), rel=1e-12)
        ref = next((s for s in g.symmetry if s.measure == line.measure), None)
        if ref is not None:
            assert (line.ratio, line.index_pct) == (ref.ratio, ref.index_pct)
        else:  # terminal double support: SR and SI by hand
            lv, rv = line.left_s, line.right_s
            assert line.ratio == pytest.approx(lv / rv)
            assert line.index_pct == pytest.approx(200 * abs(lv - rv) / (lv + rv))
    # stance = initial double support + single support + terminal double support, per side
    by = {ln.measure: ln for ln in data.symmetry}
    for side in ("left_s", "right_s"):
        parts = sum(getattr(by[m], side) for m in ("initial_double_support_s",
                    "single_support_s", "terminal_double_support_s"))  # fmt: skip
        assert parts == pytest.approx(getattr(by["stance_s"], side), abs=0.01)
    # the affected (left) leg's step is 0.85 of the other's: read from the PDF
    sr = float(_pdf_row(_text(pdf), "step time")[4])
    assert 0.78 < sr < 0.92
    assert sr == pytest.approx(g.symmetry_of("step_s").ratio, abs=5e-4 + 1e-12)  # 3 decimals


def test_both_legs_curves_are_the_one_leg_reports_and_are_drawn(qapp: object, both: Path) -> None:
    from PySide6.QtGui import QImage

    from gaitmon.report import MAX_FAINT_PER_SIDE, bilateral_report_from_file, report_from_file
    from gaitmon.ui.report_pdf.both_legs import STYLES, render_bilateral_image

    data = bilateral_report_from_file(both)
    assert [c.label for c in data.curves] == ["left", "right"]
    for side, c in zip(("L", "R"), data.curves, strict=True):
        one = report_from_file(both, side=side)  # the one-leg path
        assert c.n == one.n_included > 5
        np.testing.assert_array_equal(c.mean_deg, one.mean_deg)
        np.testing.assert_array_equal(c.sd_deg, one.sd_deg)
        assert c.toe_off_pct == one.toe_off_pct
        assert 0 < len(c.faint_deg) <= MAX_FAINT_PER_SIDE
    # the hemiparetic legs differ: the left knee's swing peak is lower (stiff knee)
    knee_peak = [float(c.mean_deg[:, 1].max()) for c in data.curves]
    assert knee_peak[0] < knee_peak[1] - 10
    # both legs' means are on the page, each in its colour: the pixels of a mean's colour
    # against the same page drawn without that mean (legend swatches and faint strides stay).
    # A difference, not a fixed count: how many strides the recording keeps varies with how
    # soon the units connect, and with them the faint lines' pixels.
    def near(d: object, side: str) -> int:
        img = render_bilateral_image(d, dpi=100).convertToFormat(QImage.Format.Format_RGB32)
        arr = np.frombuffer(img.constBits(), np.uint8).reshape(img.height(), img.width(), 4)
        rgb = arr[:, :, 2::-1].astype(int)  # BGRA -> RGB
        c = STYLES[side].mean
        return int((np.abs(rgb - np.array([c.red(), c.green(), c.blue()])).sum(axis=2) < 40).sum())

    for i, side in enumerate(("L", "R")):
        curves = list(data.curves)
        blank = np.full_like(curves[i].mean_deg, np.nan)
        curves[i] = dataclasses.replace(curves[i], mean_deg=blank)
        with_mean, without = near(data, side), near(dataclasses.replace(data, curves=curves), side)
        assert with_mean - without > 600, (side, with_mean, without)  # three plots' mean lines


@needs_poppler
def test_pdf_is_two_small_pages_with_both_legs(pdf: Path) -> None:
    assert _pages(pdf) == 2  # page 1: plots, symmetry, each leg; page 2: quality, settings
    assert pdf.stat().st_size < 1_000_000
    text = _text(pdf)
    page1 = text.split("\f")[0]
    for what in ("both legs", "Left leg (L)", "Right leg (R)", "STEPS, SUPPORT AND SYMMETRY",
                 "LEFT LEG (L)", "RIGHT LEG (R)", "Strides analysed", "Stride length, speed",
                 "Peak knee flexion in swing"):  # fmt: skip
        assert what in page1, what
    assert page1.replace(" ", "").count("n=L") == 3  # each plot's n, both legs
    assert "DATA QUALITY, LEFT LEG" in text and "DATA QUALITY, RIGHT LEG" in text


@needs_poppler
def test_side_still_gives_one_leg_and_deidentify_hides_who(qapp: object, both: Path) -> None:
    one = both.with_name("left.pdf")
    assert main(["report", str(both), "--side", "L", "-o", str(one), "-q"]) == 0
    text = _text(one)
    assert "one leg" in text and "STEPS, SUPPORT AND SYMMETRY" not in text
    anon = both.with_name("anon.pdf")
    assert main(["report", str(both), "-o", str(anon), "-q", "--deidentify"]) == 0
    text = _text(anon)
    assert "both legs" in text and "[removed]" in text
    for who in ("P9", "1001", "1002", "both.h5"):
        assert who not in text, who


def test_each_legs_exclusions_are_honoured(both: Path, tmp_path: Path) -> None:
    from gaitmon.analysis import analyse_bilateral
    from gaitmon.io.session.exclusions import Exclusion, save
    from gaitmon.report import bilateral_report_from_file, report_from_file

    before = bilateral_report_from_file(both)
    copy = tmp_path / "both.h5"
    shutil.copy(both, copy)
    with open_session(copy, side="L") as s:
        n, created = s.n_samples, s.created_utc
    save(copy.with_name("both.h5.L"), [Exclusion(n // 3, 2 * n // 3, "turn")], created, n)
    data = bilateral_report_from_file(copy)
    with open_bilateral(copy) as b:
        g = analyse_bilateral(b).gait
    assert data.strides_counted["L"] == int(np.isfinite(g.left.stride_s).sum())
    assert data.strides_counted["L"] < before.strides_counted["L"]
    assert data.strides_counted["R"] == before.strides_counted["R"]
    assert data.curves[0].n == report_from_file(copy, side="L").n_included < before.curves[0].n
    assert data.curves[1].n == before.curves[1].n
    assert data.left.excluded_spans and data.left.excluded_spans[0].reason == "turn"
    assert not data.right.excluded_spans


def test_a_heading_that_does_not_fit_under_the_head_moves_to_the_next_page() -> None:
    """The flow under page 1's fixed head: a heading and its first line that do not fit
    there go to page 2 together (the heading was left alone at the foot of page 1)."""
    from gaitmon.ui.report_pdf.flow import Block, paginate

    heading = Block(6.6, lambda _p, _y: None, keep_with_next=True)
    row = Block(4.0, lambda _p, _y: None)
    pages = paginate([heading, row], 272.0, 22.0, 282.0)
    assert [len(pg) for pg in pages] == [0, 2]
    assert pages[1][0] == (22.0, heading)
    # what fits stays
    assert [len(pg) for pg in paginate([heading, row], 270.0, 22.0, 282.0)] == [2]


def test_gap_sizes_past_the_listing_limit_are_counted_not_listed_empty(
    qapp: object, both: Path
) -> None:
    """More short gaps than MAX_LISTED: a size the list has no room left for says how many
    gaps of it there are (it read "2 frames (20 ms) lost at  s; and 15 more gaps ...")."""
    import dataclasses

    from PySide6.QtGui import QImage, QPainter

    from gaitmon.report import GapSpan, report_from_file
    from gaitmon.ui.report_pdf import sheet
    from gaitmon.ui.report_pdf.page import Page

    data = report_from_file(both, side="L")
    one = [GapSpan(0.1 * k, 0.1 * k + 0.01, 0.01, 1, "lost") for k in range(sheet.MAX_LISTED + 5)]
    two = [GapSpan(50.0 + k, 50.02 + k, 0.02, 2, "lost") for k in range(15)]
    data = dataclasses.replace(data, gaps=tuple(one + two))
    img = QImage(800, 1100, QImage.Format.Format_RGB32)
    painter = QPainter(img)
    try:
        p = Page(painter, img, img.width() / 210.0)
        for b in sheet._gap_list(p, data):
            b.draw(p, 0.0)
    finally:
        painter.end()
    text = " ".join(box[5] for box in p.boxes)
    assert "lost at  s" not in text and " at s;" not in text.replace("  ", " ")
    assert "5 more gaps of this size" in text
    assert "15 gaps of 2 frames (20 ms) each (0.30 s in total), not listed one by one" in text
