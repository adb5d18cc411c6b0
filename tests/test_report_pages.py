"""The report tells the whole story: notes, markers, excluded ranges and gaps, in full.

A session with long notes (with a word longer than the text column), 40 markers, a dozen
excluded ranges, two silences and 2 % random loss is recorded from the simulated unit; its
report must contain every item's text (``pdftotext``), continue on further pages rather than
cut anything short, and draw every word inside the page and above the footer, with no two
words on top of each other (word boxes from ``pdftotext -bbox-layout``, an independent reading
of the PDF). Pages are rendered with ``pdftoppm`` as well.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from gaitmon.cli import main
from gaitmon.finish import open_session
from gaitmon.io.session import Exclusion
from gaitmon.io.session import exclusions as excl
from gaitmon.report import report_from_file
from gaitmon.text import num

MM = 72 / 25.4  # PDF points per millimetre
NOTES = (
    "Patient walked with a single-point cane on the left during the first trials and without "
    "it afterwards; reported knee pain 3/10 before the session and 5/10 at the end. "
    "Shoes: own trainers. Sensor straps re-tightened after the second trial because the shank "
    "board had slipped by about two centimetres. Reference for the protocol: "
    "https://example.org/protocols/gait/very/long/path/that/cannot/be/broken/at/a/space/"
    "anywhere/in/the/column/at/all/index.html and see the previous visit. " * 3
).strip()
MARKER_LABELS = [
    *(f"m{k:02d} " + ("turn at cone B" if k % 3 else "walk start, hallway") for k in range(39)),
    "m39 " + "a long marker label that needs more than one line " * 3,
]
EXCL_REASONS = [f"x{k:02d} turn near the wall (operator)" for k in range(12)]


def _record(out: Path) -> Path:
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.engine import Engine
    from gaitmon.io.device import Device
    from gaitmon.io.session import SessionMeta
    from gaitmon.io.sim import FaultConfig, GaitConfig, SimulatedUnit
    from gaitmon.io.transport import InProcessTransport

    faults = FaultConfig(seed=2, loss_pct=2.0, silences=((9.0, 1.2), (21.0, 0.6)))
    unit = SimulatedUnit(GaitConfig(seed=2, standing_s=1.0), faults=faults, speed=10.0)
    eng = Engine(Device(InProcessTransport(unit)), "raw", PipelineConfig(), transport_label="sim")
    with eng:
        eng.start_recording(out, SessionMeta(patient_id="P042", side="L", notes=NOTES))
        deadline = time.monotonic() + 120
        for label in MARKER_LABELS:
            target = eng.recording.rows + 80
            while eng.recording.rows < target and time.monotonic() < deadline:
                time.sleep(0.005)
            eng.add_marker(label)
        while eng.recording.rows < 3600 and time.monotonic() < deadline:
            time.sleep(0.01)
        eng.stop_recording()
    with open_session(out) as s:
        n, created = s.n_samples, s.created_utc
        t_s = s.read("timeline/t_s")
        assert len(s.markers) == 40 and len(s.gaps) > 40
    ranges = [Exclusion(300 + 280 * k, 300 + 280 * k + 90, r) for k, r in enumerate(EXCL_REASONS)]
    assert ranges[-1].stop_idx < n
    excl.save(out, ranges, created, n, t_s)
    return out


@pytest.fixture(scope="module")
def busy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _record(tmp_path_factory.mktemp("busy") / "busy.h5")


def _tool(name: str) -> None:
    if not shutil.which(name):
        pytest.skip(f"{name} (poppler-utils) is not installed")


def _squash(text: str) -> str:
    return re.sub(r"\s+", "", text)


def _words(pdf: Path) -> list[tuple[int, float, float, float, float, float, float, str]]:
    """(page, page width, page height, xMin, yMin, xMax, yMax, word) in points."""
    html = subprocess.run(["pdftotext", "-bbox-layout", str(pdf), "-"], capture_output=True,
                          text=True, check=True).stdout  # fmt: skip
    out = []
    for k, page in enumerate(re.split(r"<page ", html)[1:]):
        w, h = (float(v) for v in re.match(r'width="([\d.]+)" height="([\d.]+)"', page).groups())
        for m in re.finditer(r'<word xMin="([\d.]+)" yMin="([\d.]+)" xMax="([\d.]+)" '
                             r'yMax="([\d.]+)">([^<]*)</word>', page):  # fmt: skip
            x0, y0, x1, y1 = (float(v) for v in m.groups()[:4])
            out.append((k, w, h, x0, y0, x1, y1, m.group(5)))
    return out


def test_busy_session_report_lists_everything_and_stays_inside_the_pages(
    qapp, busy: Path, tmp_path: Path
) -> None:
    _tool("pdftotext")
    out = tmp_path / "busy.pdf"
    assert main(["report", str(busy), "-o", str(out)]) == 0
    data = report_from_file(busy)
    text = subprocess.run(["pdftotext", "-raw", str(out), "-"], capture_output=True, text=True,
                          check=True).stdout  # fmt: skip
    flat = _squash(text)
    # the notes, whole (the unbreakable URL wraps inside the column)
    assert _squash(NOTES) in flat
    # every marker: its time and its label
    assert len(data.markers) == 40
    for m in data.markers:
        assert _squash(f"{num(m.t_s, 2)}{m.label}") in flat, m
    # every excluded range: from, to and reason
    assert len(data.excluded_spans) == 12
    for e in data.excluded_spans:
        assert _squash(f"{num(e.from_s, 2)}{num(e.to_s, 2)}{e.n_strides}{e.reason}") in flat, e
    # every gap: the silences with from, to and duration; the short ones by their start
    long = [g for g in data.gaps if g.duration_s > 0.05]
    assert len(long) == 2
    for g in long:
        assert _squash(f"{num(g.from_s, 2)}{num(g.to_s, 2)}{num(g.duration_s, 2)}") in flat
        assert g.from_s < g.to_s and g.duration_s == pytest.approx(g.n_lost / 100)
    for g in data.gaps:
        assert num(g.from_s, 2) in text
    # the data-quality line is whole, and nothing was elided
    assert "…" not in text and "CRC failure" in text
    assert f"{data.losses.frames_lost} frames lost in {len(data.gaps)} gaps" in text
    # more than one page, each numbered
    pages = int(re.search(r"page 1 of (\d+)", text).group(1))
    assert pages >= 2
    for k in range(1, pages + 1):
        assert f"page {k} of {pages}" in text

    words = _words(out)
    assert {w[0] for w in words} == set(range(pages))
    footer_y = (297 - 12) * MM
    for page, pw, ph, x0, y0, x1, y1, word in words:
        assert pw == pytest.approx(210 * MM, abs=1) and ph == pytest.approx(297 * MM, abs=1)
        # inside the page's margins (the text column is 14 mm in; a plot's last tick label
        # may stand out of it by half its width)
        assert x0 >= 10 * MM and x1 <= (210 - 10) * MM, (page, word, x0, x1)
        assert y0 >= 0 and y1 <= ph - 6 * MM, (page, word, y1)
        if y0 >= footer_y:  # the footer line itself
            assert word in ("Sagittal-plane angles from body-worn inertial sensors; for review "
                            f"by a clinician alongside the full recording. page {page + 1} of "
                            f"{pages}").split(), word  # fmt: skip
        else:
            assert y1 <= footer_y, (page, word, y1)
    # no word drawn over another (rotated axis labels come out as one box per glyph run)
    for page in range(pages):
        b = np.array([w[3:7] for w in words if w[0] == page])
        ix = np.minimum(b[:, None, 2], b[None, :, 2]) - np.maximum(b[:, None, 0], b[None, :, 0])
        iy = np.minimum(b[:, None, 3], b[None, :, 3]) - np.maximum(b[:, None, 1], b[None, :, 1])
        overlap = (ix > 0.5) & (iy > 0.5)
        np.fill_diagonal(overlap, False)
        bad = np.argwhere(overlap)
        names = [w[7] for w in words if w[0] == page]
        assert not len(bad), [(names[i], names[j]) for i, j in bad[:5]]

    if shutil.which("pdftoppm"):
        subprocess.run(["pdftoppm", "-r", "40", "-png", str(out), str(tmp_path / "p")],
                       check=True)  # fmt: skip
        assert len(list(tmp_path.glob("p-*.png"))) == pages


def test_deidentified_report_withholds_the_notes(qapp, busy: Path, tmp_path: Path) -> None:
    _tool("pdftotext")
    out = tmp_path / "anon.pdf"
    assert main(["report", str(busy), "-o", str(out), "--deidentify"]) == 0
    text = _squash(subprocess.run(["pdftotext", "-raw", str(out), "-"], capture_output=True,
                                  text=True, check=True).stdout)  # fmt: skip
    assert "cane" not in text and "P042" not in text
    assert "m00" in text  # markers are kept (as export keeps them)


def test_ranges_passed_by_review_keep_their_labels(busy: Path) -> None:
    from gaitmon.report import gather_report

    with open_session(busy) as s:
        data = gather_report(s, excluded_ranges=[Exclusion(1000, 1400, "turn at the wall")])
        t_s = s.read("timeline/t_s")
    (span,) = data.excluded_spans
    assert span.reason == "turn at the wall"
    assert (span.from_s, span.to_s) == (t_s[1000], t_s[1399])
    assert span.n_strides == sum(1 for r in data.rows if r.excluded == "excluded range")
