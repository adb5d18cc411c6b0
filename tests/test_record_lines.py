"""What ``gaitmon record`` says on standard error, one unit and both legs.

One recording path serves one unit and a pair (``gaitmon/commands/record.py``); the lines it
prints differ by design (one unit: rows, CRC errors and the file's size from its status; both
legs: each leg's seconds and counts, then the combined file). Each line is held to its exact
wording, and the counts it states to the file a reader opens.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from gaitmon.cli import main
from gaitmon.finish import open_session


def _lines(capsys: pytest.CaptureFixture[str]) -> list[str]:
    captured = capsys.readouterr()
    assert captured.out == ""  # everything goes to standard error
    return captured.err.splitlines()


def test_one_unit_says_zeroed_progress_and_what_it_wrote(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "one.h5"
    args = ["record", "--simulate", "--stand", "--zero", "--duration", "2", "--speed", "4"]
    assert main([*args, "-o", str(out)]) == 0
    lines = _lines(capsys)
    assert lines[0] == "gaitmon record: standing pose zeroed"
    progress = re.compile(
        r"recording one\.h5: +\d+\.\d / 2 s, \d+ frames, 0 lost, 0 CRC errors, link connected"
    )
    assert lines[1:-1] and all(progress.fullmatch(ln) for ln in lines[1:-1]), lines
    wrote = re.fullmatch(
        rf"gaitmon record: wrote (\d+) frames to {re.escape(str(out))} \(\d+\.\d MB\); "
        r"0 frames lost, 0 CRC failures, 0 reconnects",
        lines[-1],
    )
    assert wrote, lines[-1]
    with open_session(out) as s:
        assert s.n_samples == int(wrote.group(1)) >= 200
        assert s.calibration_changes == []  # zeroed before the first row: the header's


def test_both_legs_say_zeroed_each_legs_progress_and_counts_and_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "both.h5"
    # 40 s standing (10 s of wall time at 4x): time to start and zero both on a loaded machine
    args = ["record", "--simulate-bilateral", "--standing-s", "40", "--zero", "--duration", "2",
            "--speed", "4"]  # fmt: skip
    assert main([*args, "-o", str(out)]) == 0
    lines = _lines(capsys)
    assert lines[0] == "gaitmon record: standing pose zeroed on both legs"
    progress = re.compile(
        r"recording both\.h5: L +\d+\.\d s, 0 lost, link connected; "
        r"R +\d+\.\d s, 0 lost, link connected / 2 s"
    )
    assert lines[1:-3] and all(progress.fullmatch(ln) for ln in lines[1:-3]), lines
    counts = {}
    for side, line in zip("LR", lines[-3:-1], strict=True):
        m = re.fullmatch(
            rf"gaitmon record: {side} (\d+) frames, 0 frames lost, 0 CRC failures, 0 reconnects",
            line,
        )
        assert m, line
        counts[side] = int(m.group(1))
    assert re.fullmatch(
        rf"gaitmon record: wrote both legs to {re.escape(str(out))} \(\d+\.\d MB\)", lines[-1]
    ), lines[-1]
    for side in "LR":
        with open_session(out, side=side) as s:
            assert s.n_samples == counts[side] >= 200, side


def test_the_closing_line_states_the_recordings_own_losses_as_info_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 27: the closing line said "238 frames lost" where the file's gaps hold 213: it
    gave the link's totals, which also count the frames lost while the unit streamed before
    the recording started (here: the standing window of --zero) and after it stopped. Now
    it states the file's counts, as ``gaitmon info`` reads them."""
    out = tmp_path / "lossy.h5"
    args = ["record", "--simulate", "--zero", "--loss-pct", "5", "--corrupt-pct", "2",
            "--duration", "3", "--speed", "4", "-q"]  # fmt: skip
    assert main([*args, "-o", str(out)]) == 0
    lines = _lines(capsys)
    wrote = re.fullmatch(
        rf"gaitmon record: wrote (\d+) frames to {re.escape(str(out))} \(\d+\.\d MB\); "
        r"(\d+) frames? lost, (\d+) CRC failures?, (\d+) reconnects?",
        lines[-1],
    )
    assert wrote, lines[-1]
    said = tuple(int(g) for g in wrote.groups())
    with open_session(out) as s:
        in_gaps = sum(g.n_lost for g in s.gaps)
        file_counts = (s.n_samples, in_gaps, s.link["crc_failures"], s.link["reconnects"])
        assert s.link["frames_lost"] > in_gaps > 0  # the link lost frames outside the recording
    assert said == file_counts
    assert main(["info", str(out)]) == 0
    info = re.search(r"link +(\d+) frames? lost in \d+ gaps?, (\d+) CRC failures?, "
                     r"(\d+) reconnects?", capsys.readouterr().out)  # fmt: skip
    assert info, "no link line"
    assert tuple(int(g) for g in info.groups()) == said[1:]
