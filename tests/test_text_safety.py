"""Free text from outside (marker labels, exclusion reasons, file names) made safe to store,
show and open in a spreadsheet (issue 26): ``gaitmon.text.clean_label`` and
``gaitmon.text.spreadsheet_cell``, and the files that use them."""

from __future__ import annotations

import csv
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon import export as ex
from gaitmon.cli import main
from gaitmon.finish import open_session
from gaitmon.text import MAX_LABEL_CHARS, TRUNCATED, clean_label, spreadsheet_cell
from tests.test_export import write_session


@pytest.mark.parametrize(
    ("raw", "clean"),
    [
        ("a\x00b", "a\\x00b"),
        ("\x1b[31mred\x1b[0m", "\\x1b[31mred\\x1b[0m"),
        ("line\nbreak\ttab\r", "line\\x0abreak\\x09tab\\x0d"),
        ("abc\u202edcba", "abc\\u202edcba"),  # a bidi override that reverses what is shown
        ("lone \ud800 surrogate", "lone \\ud800 surrogate"),
        ("Gehen 👨‍👩‍👧 ok", "Gehen 👨‍👩‍👧 ok"),  # emoji joiners kept
        ("start walk", "start walk"),
        (12, "12"),
    ],
)
def test_clean_label_escapes_controls_visibly_and_is_idempotent(raw, clean):
    got = clean_label(raw)
    assert got == clean
    assert clean_label(got) == got
    got.encode("utf-8")  # storable: HDF5 takes it


@pytest.mark.parametrize("n", [MAX_LABEL_CHARS, MAX_LABEL_CHARS + 1, 10_000, 1_000_000])
def test_clean_label_bounds_the_length_with_a_visible_mark(n):
    got = clean_label("x" * n)
    if n <= MAX_LABEL_CHARS:
        assert got == "x" * n
    else:
        assert len(got) == MAX_LABEL_CHARS and got.endswith(TRUNCATED)
        assert got == "x" * (MAX_LABEL_CHARS - len(TRUNCATED)) + TRUNCATED
    assert clean_label(got) == got


@pytest.mark.parametrize(
    ("cell", "safe"),
    [
        ('=HYPERLINK("http://x","y")', '\'=HYPERLINK("http://x","y")'),
        ("+cmd|' /C calc'!A0", "'+cmd|' /C calc'!A0"),
        ("-2+3", "'-2+3"),
        ("@SUM(A1)", "'@SUM(A1)"),
        ("\t=1", "'\t=1"),
        ("\r=1", "'\r=1"),
        ("-12.5", "-12.5"),  # numbers stay numbers
        ("+3", "+3"),
        ("-1e-3", "-1e-3"),
        ("-", "-"),  # a lone dash (the strides table's missing value): no formula
        ("start walk", "start walk"),
        ("", ""),
    ],
)
def test_spreadsheet_cell_neutralises_formulas_only(cell, safe):
    assert spreadsheet_cell(cell) == safe


def _with_markers(path: Path, labels: list[str]) -> None:
    """Replace the file's markers (as a file written before labels were cleaned may hold)."""
    with h5py.File(path, "r+") as h:
        dt = h["markers"].dtype
        rows = np.array([(100 + 50 * i, 1.0 + 0.5 * i, lab) for i, lab in enumerate(labels)],
                        dtype=dt)  # fmt: skip
        del h["markers"]
        h.create_dataset("markers", data=rows)


def test_csv_export_neutralises_formula_labels_and_old_escapes(tmp_path, capsys):
    src = tmp_path / "s.h5"
    write_session(src, "raw", n=600)
    labels = ['=HYPERLINK("http://example.invalid","x")', "@SUM(A1:A9)", "-12.5",
              "\x1b[2Jcleared", "y" * 5000]  # fmt: skip
    _with_markers(src, labels)
    with open_session(src) as s:  # read back clean, whatever the file holds
        got = [m.label for m in s.markers]
    assert got[3] == "\\x1b[2Jcleared"
    assert len(got[4]) == MAX_LABEL_CHARS and got[4].endswith(TRUNCATED)

    res = ex.export_session(src, "csv", tmp_path / "out.csv")
    data = res.paths[0].read_bytes()
    assert b"\x1b" not in data
    with open(res.paths[0], newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    col = rows[0].index("marker")
    cells = {i - 1: r[col] for i, r in enumerate(rows) if i and r[col]}
    assert cells == {
        100: "'=HYPERLINK(\"http://example.invalid\",\"x\")",
        150: "'@SUM(A1:A9)",
        200: "-12.5",  # a number stays a number
        250: "\\x1b[2Jcleared",
        300: got[4],
    }
    assert main(["info", str(src)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\\x1b[2Jcleared" in out
