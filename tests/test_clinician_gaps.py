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


def _pdf_pages(pdf: Path) -> list[str]:
    if not shutil.which("pdftotext"):
        pytest.skip("pdftotext (poppler-utils) is not installed")
    out = subprocess.run(["pdftotext", str(pdf), "-"], capture_output=True, text=True,
                         check=True).stdout  # fmt: skip
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
