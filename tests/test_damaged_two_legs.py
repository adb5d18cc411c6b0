"""Damaged files of both legs and crashed recordings: every command answers in one line and
leaves no half-written file (issue 26, item 8).

The files are real recordings (``gaitmon record --simulate-bilateral``, a ``kill -9`` of
``gaitmon record --simulate``) damaged as disks and copies damage them: 512 zero bytes at
offset 512 (the root's object header), a compressed chunk of one leg overwritten, a clock fit
of another shape, the journal of a crashed recording lost.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.cli import main
from gaitmon.export import FORMATS
from gaitmon.finish import open_session
from gaitmon.io.journal import journal_path

ROOT = Path(__file__).resolve().parents[1]
LEFTOVER = (".partial", ".recovering", ".combining")


@pytest.fixture(scope="module")
def both(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A complete recording of both legs (read-only: copy it before damaging it)."""
    out = tmp_path_factory.mktemp("both") / "both.h5"
    rc = main(["record", "--simulate-bilateral", "--duration", "8", "--speed", "10", "-o",
               str(out), "--standing-s", "2", "--patient", "P1", "-q"])  # fmt: skip
    assert rc == 0
    return out


def _commands(f: Path, w: Path) -> dict[str, list[str]]:
    cmds = {"info": ["info", str(f)],
            "report": ["report", str(f), "-o", str(w / "r.pdf"), "-q"],
            "process": ["process", str(f), "-o", str(w / "p.h5"), "-q"]}  # fmt: skip
    for fmt, spec in FORMATS.items():
        cmds[f"export {fmt}"] = ["export", str(f), "--format", fmt, "-q", "-o",
                                 str(w / f"out{spec.suffix}")]  # fmt: skip
    return cmds


def _one_line_everywhere(f: Path, w: Path, capsys: pytest.CaptureFixture[str],
                         must_say: str) -> dict[str, str]:  # fmt: skip
    """Every command that reads ``f``: exit 2, one error line naming the file, no traceback,
    no partial output left in ``w``. Returns each command's line."""
    said: dict[str, str] = {}
    for cmd, argv in _commands(f, w).items():
        rc = main(argv)
        err = capsys.readouterr().err
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert rc == 2, (cmd, err)
        assert len(lines) == 1 and "error:" in lines[0], (cmd, err)
        assert f.name in lines[0] and must_say in lines[0], (cmd, lines[0])
        left = [p.name for p in w.rglob("*") if p.name.endswith(LEFTOVER)]
        assert not left, (cmd, left)
        said[cmd] = lines[0]
    return said


def _damaged_copy(both: Path, tmp_path: Path) -> tuple[Path, Path]:
    f = tmp_path / "in" / "both.h5"
    f.parent.mkdir()
    shutil.copyfile(both, f)
    w = tmp_path / "out"
    w.mkdir()
    return f, w


def test_zeroed_root_header_is_one_line_for_every_command(
    qapp: object, both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:  # qapp: a report draws with pytest-qt's application, not its own
    # the root object's header lives here: h5py opens the file, then reading the root's
    # attributes raised KeyError in parts.is_bilateral for every command
    f, w = _damaged_copy(both, tmp_path)
    data = bytearray(f.read_bytes())
    data[512:1024] = bytes(512)
    f.write_bytes(bytes(data))
    with h5py.File(f, "r") as h, pytest.raises(KeyError):
        dict(h.attrs)  # (the damage this test is about)
    _one_line_everywhere(f, w, capsys, "damaged")


def _garble_chunk(f: Path, dataset: str) -> None:
    """Overwrite the first stored chunk of ``dataset`` with other bytes (its compression
    fails to decode): what a flipped sector does to a file of both legs."""
    with h5py.File(f, "r") as h:
        info = h[dataset].id.get_chunk_info(0)
    with f.open("r+b") as fh:
        fh.seek(info.byte_offset)
        fh.write(np.random.default_rng(3).integers(0, 256, info.size, np.uint8).tobytes())


@pytest.mark.parametrize("fmt", ["mat", "c3d", "bids", "csv"])
def test_a_damaged_chunk_of_one_leg_exports_as_one_line(
    both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], fmt: str
) -> None:
    # the file opens; the damage shows only when the analysis reads the left leg's angles:
    # mat, c3d and bids of both legs raised that SessionError uncaught (csv said one line)
    f, w = _damaged_copy(both, tmp_path)
    _garble_chunk(f, "units/L/smoothed/tilt_deg")
    rc = main(["export", str(f), "--format", fmt, "-q", "-o", str(w / f"x{FORMATS[fmt].suffix}")])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2, err
    assert len(lines) == 1 and "both.h5 is damaged" in lines[0], err
    assert not [p for p in w.rglob("*") if p.is_file()]  # nothing half-written stays


def test_a_clock_fit_of_another_shape_is_one_line(
    qapp: object, both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:  # qapp: a report draws with pytest-qt's application, not its own
    f, w = _damaged_copy(both, tmp_path)
    with h5py.File(f, "r+") as h:
        del h["sync/L/segments"]
        h["sync/L"].create_dataset("segments", data=np.arange(4.0))  # was IndexError
    said = _one_line_everywhere(f, w, capsys, "damaged")
    assert set(said) == set(_commands(f, w))  # every command was run and refused it
    assert all(line.startswith(f"gaitmon {cmd.split()[0]}") for cmd, line in said.items()), said


@pytest.fixture(scope="module")
def crashed_early(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A one-unit recording killed with -9 before its first rows reached the HDF5 file (they
    were only in its journal), its journal then lost: a file of 0 rows."""
    out = tmp_path_factory.mktemp("crashed") / "early.h5"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "record", "--simulate", "--duration", "600",
         "--speed", "8", "-o", str(out), "-q", "--standing-s", "2"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 60.0
        j = journal_path(out)
        while not (j.exists() and j.stat().st_size > 20_000):
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    journal_path(out).unlink()
    return out


def test_process_of_a_crashed_file_without_journal(
    crashed_early: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src = tmp_path / "early.h5"
    shutil.copyfile(crashed_early, src)
    with open_session(src) as s:
        assert s.n_samples == 0 and not s.complete  # (the case: rows only in the lost journal)
    dst = tmp_path / "p.h5"
    # raised "ValueError: Chunk shape ... (1, 4) is not compatible with (0, 4)" and left
    # p.h5.partial behind
    assert main(["process", str(src), "-o", str(dst), "-q"]) == 0, capsys.readouterr().err
    assert not dst.with_name("p.h5.partial").exists()
    with open_session(dst) as s:
        assert s.n_samples == 0
    with h5py.File(dst, "r") as h:
        assert h["smoothed/tilt_deg"].shape == (0, 4)
    assert main(["info", str(dst)]) == 0
    assert "0 frames" in capsys.readouterr().out


def test_a_failed_reprocessing_never_leaves_its_partial_file(
    both: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # damage found while the pipeline is replayed (the raw counts of one leg): one line, and
    # the half-built NEW.partial is deleted whatever the error
    f, w = _damaged_copy(both, tmp_path)
    _garble_chunk(f, "units/R/raw/adc")
    rc = main(["process", str(f), "-o", str(w / "p.h5"), "-q"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert not list(w.iterdir())
