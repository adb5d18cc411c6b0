"""Issue 25, "Gaps a clinician stumbles over": foot clearance everywhere, a normal band that
reads as a band, and the clinician's comments box on every report.

* Foot clearance (mean ± SD over the included strides, cm) is one number, from
  ``gaitmon.analysis.spatial_summary``, in ``info``, the review's summary and stride table,
  the report (``pdftotext``) and ``compare``.
* The normal band's mean is a solid line of its own colour with a legend entry; the toe-off
  line stays dashed (review plot items; the report's drawing is read back from the PDF page
  image).
* "Clinician's comments" is on every report, on its last page (``pdftotext``), whatever the
  length of what comes before it: the notes' length is swept so the flow ends at every height
  of the first page.
"""

from __future__ import annotations

import dataclasses
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.conftest import write_simulated_session


def _pdf_pages(pdf: Path, layout: bool = False) -> list[str]:
    if not shutil.which("pdftotext"):
        pytest.skip("pdftotext (poppler-utils) is not installed")
    out = subprocess.run(["pdftotext", *(["-layout"] if layout else []), str(pdf), "-"],
                         capture_output=True, text=True, check=True).stdout  # fmt: skip
    return [p for p in out.split("\f") if p.strip()]


@pytest.fixture(scope="module")
def two_walks(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("clin")
    return (
        write_simulated_session(d / "short_normal.h5", pattern="normal", n=1500),
        write_simulated_session(d / "long_stiff.h5", pattern="stiff-knee", n=4000, seed=11),
    )


def test_comments_box_on_every_report_whatever_fills_the_page(
    qapp, two_walks: tuple[Path, Path], tmp_path: Path
) -> None:
    from gaitmon.report import report_from_file
    from gaitmon.ui.report_pdf import write_report_pdf

    seen_pages = set()
    for rec in two_walks:
        data = report_from_file(rec)
        # notes from none to a page's worth: the flow ends at every height of page 1 and 2
        for k in range(0, 40, 3):
            notes = " ".join(["Walked the hallway twice with a short rest."] * (k * 4))
            d = dataclasses.replace(data, session_notes=notes)
            out = tmp_path / f"{rec.stem}_{k}.pdf"
            write_report_pdf(d, out, dpi=150)
            pages = _pdf_pages(out)
            seen_pages.add(len(pages))
            text = [p.upper() for p in pages]
            assert "CLINICIAN'S COMMENTS" in text[-1], (rec.name, k, len(pages))
            assert sum(p.count("CLINICIAN'S COMMENTS") for p in text) == 1
            assert "SIGNATURE / DATE" in text[-1]
    assert {1, 2} <= seen_pages  # the sweep did cover one- and two-page reports


# ---- foot clearance: one number in info, review, report and compare ----


def test_foot_clearance_is_one_number_in_info_review_report_and_compare(
    qtbot, review_win, two_walks: tuple[Path, Path], tmp_path: Path, capsys
) -> None:
    import numpy as np

    from gaitmon.analysis import analyse_session
    from gaitmon.cli import main
    from gaitmon.finish import open_session

    rec, other = two_walks
    with open_session(rec) as s:
        an = analyse_session(s)
    inc = [r.foot_clearance_m for r in an.rows
           if r.included and np.isfinite(r.stride_length_m) and np.isfinite(r.foot_clearance_m)]
    assert len(inc) >= 3
    mean, sd = np.mean(inc) * 100.0, np.std(inc, ddof=1) * 100.0  # independent of the code
    text = f"{mean:.1f} ± {sd:.1f} cm"
    # info
    assert main(["info", str(rec)]) == 0
    assert f"foot clearance {text}" in capsys.readouterr().out
    # review: the summary and the stride table's column
    with qtbot.waitSignal(review_win.analysis_done, timeout=60_000):
        review_win.open_file(rec)
    assert f"Foot clearance</td><td>{text}" in review_win.summary.text().replace("&nbsp;", "")
    model = review_win.table.model()
    heads = [model.headerData(c, _horizontal()) for c in range(model.columnCount())]
    col = next(c for c, h in enumerate(heads) if "clear" in str(h))
    cells = [model.index(r, col).data() for r in range(model.rowCount())]
    expected = [f"{r.foot_clearance_m * 100:.1f}" for r in an.rows]
    assert [str(c) for c in cells if c not in ("", "-", None)] == [
        e for e in expected if e != "nan"]
    # report
    out = tmp_path / "r.pdf"
    assert main(["report", str(rec), "-o", str(out), "-q"]) == 0
    assert f"Foot clearance {text}" in " ".join(" ".join(_pdf_pages(out)).split())
    # compare: the row, the same mean (cm, 1 decimal) for this session
    cmp_pdf = tmp_path / "c.pdf"
    assert main(["compare", str(rec), str(other), "-o", str(cmp_pdf), "-q"]) == 0
    lines = [ln for p in _pdf_pages(cmp_pdf, layout=True) for ln in p.splitlines()
             if ln.strip().startswith("Foot clearance")]
    assert lines and f"{mean:.1f}" in lines[0], lines
    from gaitmon.compare import compare_sessions

    v = compare_sessions([rec, other]).sessions[0].values["foot_clearance"]
    assert f"{v.mean:.1f}" == f"{mean:.1f}" and f"{v.sd:.1f}" == f"{sd:.1f}"


def _horizontal():
    from PySide6.QtCore import Qt

    return Qt.Orientation.Horizontal


def test_two_leg_report_and_review_show_both_clearances_and_their_symmetry(
    qapp, tmp_path: Path, capsys
) -> None:
    import re

    from gaitmon.cli import main

    rec = tmp_path / "both.h5"
    assert main(["record", "--simulate-bilateral", "--duration", "12", "--speed", "12",
                 "--asymmetry", "hemiparetic", "--standing-s", "1.5", "-o", str(rec), "-q",
                 ]) == 0  # fmt: skip
    assert main(["info", str(rec)]) == 0
    info = capsys.readouterr().out
    per_leg = re.findall(r"foot clearance (\d+\.\d) ± (\d+\.\d) cm", info)
    assert len(per_leg) == 2, info  # one line per leg
    (lm, lsd), (rm, rsd) = per_leg
    sr = float(lm) / float(rm)
    out = tmp_path / "both.pdf"
    assert main(["report", str(rec), "-o", str(out), "-q"]) == 0
    text = " ".join(" ".join(_pdf_pages(out)).split())
    assert f"Foot clearance L {lm} ± {lsd} cm, R {rm} ± {rsd} cm; SR " in text
    got_sr = float(re.search(r"Foot clearance L .*? cm; SR (\d\.\d+)", text).group(1))
    assert got_sr == pytest.approx(sr, abs=0.02)  # of the unrounded means
    # each leg's column has its own line too
    assert text.count(f"Foot clearance {lm} ± {lsd} cm") == 1
    assert text.count(f"Foot clearance {rm} ± {rsd} cm") == 1
    # the review's Both legs tab: the same line in its headline
    from gaitmon.review.both_legs import both_legs
    from gaitmon.ui.review.both_legs_panel import BothLegsPanel

    panel = BothLegsPanel()
    panel.set_result(both_legs(rec))
    head = " ".join(panel.headline.text().split())
    assert f"Foot clearance L {lm} ± {lsd} cm, R {rm} ± {rsd} cm; SR {got_sr:.3f}" in head, head
    panel.deleteLater()


# ---- the normal band: a band, a solid mean with a legend entry, unlike the toe-off line ----

EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "normative-example.csv"


def test_review_normal_band_is_visible_and_unlike_the_toe_off_line(qtbot) -> None:
    from PySide6.QtCore import Qt

    from gaitmon.normative import load_normative
    from gaitmon.ui.review.cycles import ReviewCyclePlots
    from gaitmon.ui.theme import current_colours

    bands = load_normative(EXAMPLE)
    w = ReviewCyclePlots(current_colours())
    qtbot.addWidget(w)
    w.set_normative(bands)
    for j in range(3):
        mean_pen = w.norm_mean[j].opts["pen"]
        toe_pen = w.toe_off[j].pen
        assert toe_pen.style() == Qt.PenStyle.DashLine  # the toe-off line stays dashed
        assert mean_pen.style() == Qt.PenStyle.SolidLine
        assert mean_pen.widthF() >= 2 or mean_pen.width() >= 2
        mc, tc = mean_pen.color(), toe_pen.color()
        assert mc.alpha() == 255
        # another hue, not a grey like the event lines
        assert max(mc.red(), mc.green(), mc.blue()) - min(mc.red(), mc.green(), mc.blue()) > 100
        assert mc.rgb() != tc.rgb()
        # the band's fill: enough alpha to be seen, and drawn (edges hold the data)
        fill = next(it for it in w.plots[j].items if type(it).__name__ == "FillBetweenItem")
        assert fill.brush().color().alpha() >= 80
        assert len(w.norm_lower[j].getData()[0]) == len(bands.cycle_pct)
        assert w.toe_off[j].label is not None  # labelled
    assert w.toe_off[0].label.format == "toe off"
    # the legend entry
    assert w.legend is not None and w.legend.isVisible()
    texts = [label.text for _sample, label in w.legend.items]
    assert texts == [f"normal mean ± 1 SD ({bands.label})"] or (
        len(texts) == 1 and texts[0].startswith("normal mean ± 1 SD (")), texts
    w.set_normative(None)
    assert not w.legend.isVisible()


def test_report_normal_band_is_amber_with_a_solid_mean_and_a_legend(
    qapp, two_walks: tuple[Path, Path], tmp_path: Path
) -> None:
    import numpy as np

    from gaitmon.normative import load_normative
    from gaitmon.report import report_from_file
    from gaitmon.ui.report_pdf import render_report_image, write_report_pdf

    bands = load_normative(EXAMPLE)
    data = report_from_file(two_walks[0], normative=bands)
    out = tmp_path / "band.pdf"
    write_report_pdf(data, out, dpi=150)
    text = " ".join(" ".join(_pdf_pages(out)).split())
    assert f"normal mean ± 1 SD ({bands.label}" in text
    from PySide6.QtGui import QImage

    img = render_report_image(data, dpi=150).convertToFormat(QImage.Format.Format_RGB32)
    ptr = img.constBits()
    a = np.frombuffer(ptr, np.uint8, img.sizeInBytes()).reshape(img.height(),
                                                                img.bytesPerLine())  # fmt: skip
    px = a[:, : img.width() * 4].reshape(img.height(), img.width(), 4)
    b, g, r = px[..., 0].astype(int), px[..., 1].astype(int), px[..., 2].astype(int)
    amber = (abs(r - 0xD0) < 25) & (abs(g - 0x80) < 25) & (b < 40)  # the solid mean line
    assert amber.sum() > 600, amber.sum()  # three plots' solid lines (and the legend key)
    tinted = (r > 220) & (g > 190) & (g < 235) & (b < 215) & (r - b > 40)  # the band's fill
    assert tinted.sum() > 2000, tinted.sum()
