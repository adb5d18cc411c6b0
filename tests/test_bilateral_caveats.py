"""What may make a two-leg session's figures misleading is said wherever they are shown.

A two-leg file whose clock fits disagreed (a host that read one unit's link late: its fit was
refitted and ``/sync``'s ``warning`` says why) and one whose legs were recorded together for a
few seconds only are made from the kept two-leg recording (``tests/data/golden/two_legs.h5``)
with receive times set by the test (``helpers.two_legs_with_caveat``), so each has its caveat
for certain. ``gaitmon info``, the PDF report (read back with ``pdftotext``), the review
window's Both legs tab and every export's metadata say it, in the words of
``gaitmon.finish.bilateral.caveats``; the kept recording itself has none, and says none.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from helpers import TWO_LEGS, two_legs_with_caveat

from gaitmon.cli import main
from gaitmon.finish.bilateral import TOGETHER_SHARE, Caveat, open_bilateral

WAIT_MS = 30_000
MM = 72 / 25.4  # PDF points per millimetre
FOOTER = ("Sagittal-plane angles from body-worn inertial sensors; for review by a clinician "
          "alongside the full recording. page 1 of 2")  # fmt: skip
OLD_COMMON_TIME = {"definition", "host_s_per_common_s", "clock_ppm", "receive_delay_p95_ms"}


@pytest.fixture(scope="module")
def late(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The right unit's data read late: its clock fit refitted, with the file's warning."""
    return two_legs_with_caveat(tmp_path_factory.mktemp("late"), "R")


@pytest.fixture(scope="module")
def apart(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The right leg's recording started 15 s after the left's (of about 21 s each)."""
    return two_legs_with_caveat(tmp_path_factory.mktemp("apart"), "", shift_s=15.0)


@pytest.fixture
def normal(tmp_path: Path) -> Path:
    p = tmp_path / "normal.h5"  # a copy: review writes beside the file it opens
    shutil.copyfile(TWO_LEGS, p)
    return p


def _sentences(path: Path) -> list[str]:
    with open_bilateral(path) as b:
        return [c.sentence for c in b.caveats()]


def _words(text: str) -> str:
    return " ".join(text.split())


# ---- the one place ----------------------------------------------------------------------------


def test_the_caveats_are_the_files_warning_and_a_brief_time_together(
    late: Path, apart: Path, normal: Path
) -> None:
    with open_bilateral(late) as b:
        assert b.clock_warning.startswith("the units' clock fits disagreed by")
        assert b.caveats() == (Caveat("warning", b.clock_warning),)
        assert b.caveats()[0].sentence == "T" + b.clock_warning[1:] + "."
    with open_bilateral(apart) as b:
        (c,) = b.caveats()
        spans = [b.span_s(s) for s in ("L", "R")]
        # independent of together_s: the stretch both legs' rows cover
        both = min(spans[0][1], spans[1][1]) - max(spans[0][0], spans[1][0])
        assert c.key == "together" and c.together_s == pytest.approx(both, abs=1e-9)
        assert both < TOGETHER_SHARE * min(hi - lo for lo, hi in spans)
        assert c.text.startswith(f"both legs recorded together for {both:.1f} s only: the "
                                 f"right unit's recording started {spans[1][0]:.1f} s after")
    with open_bilateral(normal) as b:
        assert b.caveats() == ()


def test_info_prints_each_caveat_on_its_line(
    late: Path, apart: Path, normal: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for path, label in ((late, "warning"), (apart, "together")):
        with open_bilateral(path) as b:
            (c,) = b.caveats()
        assert main(["info", str(path)]) == 0
        out = capsys.readouterr().out.splitlines()
        assert f"  {label:<12s} {c.text}" in out
    assert main(["info", str(normal)]) == 0
    out = capsys.readouterr().out
    assert "  warning " not in out and "  together " not in out


# ---- the report -------------------------------------------------------------------------------


needs_poppler = pytest.mark.skipif(
    shutil.which("pdftotext") is None or shutil.which("pdfinfo") is None,
    reason="poppler-utils (pdftotext, pdfinfo) not installed",
)


def _pdf_text(pdf: Path, page: int = 1) -> str:
    return subprocess.run(["pdftotext", "-f", str(page), "-l", str(page), str(pdf), "-"],
                          check=True, capture_output=True, text=True).stdout  # fmt: skip


def _below_footer_rule(pdf: Path) -> str:
    """Page 1's words that reach below 1 mm above the footer's rule (word boxes from
    ``pdftotext -bbox-layout``)."""
    from gaitmon.ui.report_pdf.sheet import FOOTER_MM

    html = subprocess.run(["pdftotext", "-f", "1", "-l", "1", "-bbox-layout", str(pdf), "-"],
                          check=True, capture_output=True, text=True).stdout  # fmt: skip
    words = re.finditer(r'<word xMin="[\d.]+" yMin="[\d.]+" xMax="[\d.]+" yMax="([\d.]+)">'
                        r"([^<]*)</word>", html)  # fmt: skip
    return " ".join(m[2] for m in words if float(m[1]) > (FOOTER_MM - 1.0) * MM)


def _pages(pdf: Path) -> int:
    info = subprocess.run(["pdfinfo", str(pdf)], check=True, capture_output=True, text=True)
    return int(next(ln.split()[1] for ln in info.stdout.splitlines() if ln.startswith("Pages:")))


@needs_poppler
def test_the_report_says_the_caveats_on_its_first_page(
    qapp: object, late: Path, apart: Path, normal: Path, tmp_path: Path
) -> None:
    normative = str(Path(__file__).resolve().parents[1] / "docs" / "normative-example.csv")
    for path, more in ((late, []), (late, ["--normative", normative]), (apart, []),
                       (normal, [])):  # fmt: skip
        pdf = tmp_path / f"{path.stem}{len(more)}.pdf"
        assert main(["report", str(path), "-o", str(pdf), "-q", *more]) == 0
        page1 = _words(_pdf_text(pdf))
        said = _sentences(path)
        for sentence in said:  # above the symmetry table, whole
            assert f"Caution: {_words(sentence)}" in page1, page1
            assert page1.index("Caution:") < page1.index("step time")
        if not said:
            assert "Caution" not in page1 and "clock fits" not in page1
        # the room the caveats take comes from the plots: the legs' tables stay on page 1,
        # above its footer
        assert "Peak knee flexion in swing" in page1
        assert _below_footer_rule(pdf) == FOOTER
        assert _pages(pdf) == 2
    assert len(_sentences(late)) == 1 and len(_sentences(apart)) == 1


# ---- the review window ------------------------------------------------------------------------


def test_the_both_legs_tab_says_the_caveats(qtbot, review_win, late: Path, normal: Path,
                                            tmp_path: Path) -> None:  # fmt: skip
    w = review_win
    w.resize(1500, 950)  # a laptop's screen: the tab is ~290 px high
    copy = tmp_path / "late.h5"  # review writes beside the file it opens
    shutil.copyfile(late, copy)
    panel = w.both_legs
    index = w.tabs.indexOf(panel)
    for path, said in ((copy, _sentences(late)), (normal, [])):
        with qtbot.waitSignal(w.legs.computed, timeout=WAIT_MS):
            w.open_file(path)
        assert panel.result is not None and panel.result.caveats == tuple(said)
        w.tabs.setCurrentIndex(index)
        if said:
            qtbot.waitUntil(panel.caveats.isVisible, timeout=WAIT_MS)
            assert panel.caveats.text() == "\n".join(f"Caution: {s}" for s in said)
            assert w.tabs.tabText(index) == "Both legs (caution)"
            assert said[0] in w.tabs.tabToolTip(index)
        else:
            assert panel.caveats.isHidden() and panel.caveats.text() == ""
            assert w.tabs.tabText(index) == "Both legs" and w.tabs.tabToolTip(index) == ""
        assert "cadence" in panel.headline.text()  # the figures are shown, with their caution
        # nothing drawn over the table (its labels squeezed onto its rows; the tab scrolls)
        def apart() -> bool:  # once the layout has settled
            t = panel.table.geometry()
            return (panel.table.isVisible() and panel.headline.geometry().bottom() < t.top()
                    and panel.note.geometry().top() > t.bottom()
                    and panel.table.minimumHeight() <= t.height())  # fmt: skip

        qtbot.waitUntil(apart, timeout=5_000)


# ---- the exports ------------------------------------------------------------------------------


def _csv_meta(path: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> tuple[dict, str]:
    assert main(["export", str(path), "--format", "csv", "-o", str(out / "walk.csv"), "-q"]) == 0
    err = capsys.readouterr().err
    meta = json.loads((out / "walk_bilateral.meta.json").read_text(encoding="utf-8"))
    return meta["common_time"], err


def test_the_csv_metadata_and_the_command_say_the_caveats(
    late: Path, apart: Path, normal: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for k, path in enumerate((late, apart, normal)):
        out = tmp_path / str(k)
        out.mkdir()
        common, err = _csv_meta(path, out, capsys)
        said = _sentences(path)
        for sentence in said:
            assert f"gaitmon export: warning: {path}: {sentence}" in err.splitlines()
        with open_bilateral(path) as b:
            if path is late:
                assert set(common) == OLD_COMMON_TIME | {"clock_warning"}
                assert common["clock_warning"] == said[0]
            elif path is apart:
                assert set(common) == OLD_COMMON_TIME | {"together_s", "together"}
                assert common["together_s"] == pytest.approx(b.together_s(), abs=5e-4)
                assert common["together"] == said[0]
            else:  # nothing to say: the metadata as it was
                assert set(common) == OLD_COMMON_TIME and said == [] and err == ""


def test_mat_bids_and_c3d_say_the_clock_warning(late: Path, tmp_path: Path) -> None:
    from scipy.io import loadmat

    (warning,) = _sentences(late)
    mat = tmp_path / "walk.mat"
    assert main(["export", str(late), "--format", "mat", "-o", str(mat), "-q"]) == 0
    m = loadmat(mat, squeeze_me=True, struct_as_record=False)
    assert m["bilateral"].common_time.clock_warning == warning
    study = tmp_path / "study"
    assert main(["export", str(late), "--format", "bids", "-o", str(study), "--subject", "03",
                 "-q"]) == 0  # fmt: skip
    own = sorted(study.rglob("*_gaitmon.json"))
    assert len(own) == 2  # one per tracking system
    for p in own:
        assert json.loads(p.read_text(encoding="utf-8"))["time_line"]["clock_warning"] == warning
    ezc3d = pytest.importorskip("ezc3d")
    c3d = tmp_path / "walk.c3d"
    assert main(["export", str(late), "--format", "c3d", "-o", str(c3d), "-q"]) == 0
    lines = ezc3d.c3d(str(c3d))["parameters"]["GAITMON"]["CAUTION"]["value"]
    assert _words(" ".join(lines)) == _words(warning)
