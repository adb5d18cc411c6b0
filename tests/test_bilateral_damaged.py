"""A damaged part never costs the intact leg.

A bilateral recording is killed (``kill -9``) while both parts are being written; then one
leg's part (and its journal) is damaged in the ways a disk or a copy damages files: random
bytes, cut short, the journal lost. The next ``gaitmon info FILE`` must combine what can be
combined: the intact leg, exactly as it recovers on its own (the reference: a copy of that
part recovered by the one-unit recovery), the damaged leg named as missing in one warning line
and in the file, and the damaged bytes kept, unchanged, as ``FILE.<side>.partial.damaged``.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.cli import main
from gaitmon.finish import open_session
from gaitmon.finish.bilateral import open_bilateral, part_path, parts_of
from gaitmon.io.journal import journal_path

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def killed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding the two parts (and journals) of a recording killed with -9."""
    folder = tmp_path_factory.mktemp("killed")
    out = folder / "both.h5"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "record", "--simulate-bilateral", "--duration",
         "600", "--speed", "4", "-o", str(out), "-q"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    # killed once each journal holds ~2,000 rows (48 bytes a raw row; the tests want more than
    # 500 recovered on each leg): waiting for the parts' size and then a second held only the
    # first flush's 500 rows on a loaded machine
    def journal_bytes(side: str) -> int:
        j = journal_path(part_path(out, side))
        return j.stat().st_size if j.exists() else 0

    try:
        deadline = time.monotonic() + 120.0
        while not all(journal_bytes(s) > 100_000 for s in "LR"):
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.1)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    assert set(parts_of(out)) == {"L", "R"}
    assert all(journal_path(part_path(out, s)).exists() for s in "LR")
    return folder


def _copy_parts(killed: Path, dst: Path) -> Path:
    for p in killed.iterdir():
        shutil.copy(p, dst / p.name)
    return dst / "both.h5"


def _random(p: Path) -> None:
    p.write_bytes(np.random.default_rng(7).bytes(p.stat().st_size))


def _cut(p: Path) -> None:  # within the header (a journal cut later still gives its rows)
    with p.open("r+b") as f:
        f.truncate(300)


def _gone(p: Path) -> None:
    p.unlink()


DAMAGE: dict[str, tuple[Callable[[Path], None], Callable[[Path], None]]] = {
    # (what is done to the part, to its journal)
    "random bytes": (_random, _random),
    "cut short": (_cut, _cut),
    "journal lost, part random": (_random, _gone),
    "journal random, part intact": (lambda p: None, _random),
}


def _digest(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest() if p.exists() else ""


def test_kill_9_during_a_bilateral_recording_then_info_recovers_one_file(
    killed: Path, tmp_path: Path
) -> None:
    """``kill -9`` of ``gaitmon record --simulate-bilateral`` (the ``killed`` recording, made
    once for this module), then ``gaitmon info`` as a process: one file, both legs recovered."""
    out = _copy_parts(killed, tmp_path)
    assert not out.exists() and set(parts_of(out)) == {"L", "R"}
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run(
        [sys.executable, "-m", "gaitmon", "info", str(out)],
        env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "bilateral session" in r.stdout and "recovered and combined" in r.stdout, r.stdout
    assert "step time" in r.stdout and "SR (L/R)" in r.stdout
    assert out.exists() and not parts_of(out)
    assert not list(tmp_path.glob("*.journal")) and not list(tmp_path.glob("*.partial"))
    with open_bilateral(out) as b:
        assert b.recovered and not b.complete
        for s in "LR":
            assert b.unit(s).n_samples > 100 and b.unit(s).recovered


@pytest.mark.parametrize("damage", list(DAMAGE))
@pytest.mark.parametrize("bad", ["R", "L"])
def test_a_damaged_part_leaves_the_other_leg_combined(
    killed: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], damage: str, bad: str
) -> None:
    good = "L" if bad == "R" else "R"
    out = _copy_parts(killed, tmp_path)
    to_part, to_journal = DAMAGE[damage]
    part, journal = part_path(out, bad), journal_path(part_path(out, bad))
    to_part(part)
    to_journal(journal)
    damaged = {p.name: _digest(p) for p in (part, journal) if p.exists()}
    # the reference: the good part recovered on its own by the one-unit recovery
    ref_dir = tmp_path / "ref"
    ref_dir.mkdir()
    ref = ref_dir / "good.h5"
    shutil.copy(part_path(out, good), ref)
    shutil.copy(journal_path(part_path(out, good)), journal_path(ref))
    with open_session(ref) as s:
        ref_rows = s.n_samples
        ref_adc = s.read("raw/adc")
    assert ref_rows > 500

    assert main(["info", str(out)]) == 0
    cap = capsys.readouterr()
    leg = {"L": "left", "R": "right"}
    warnings = [ln for ln in cap.err.splitlines() if "warning" in ln]
    assert len(warnings) == 1, cap.err
    assert f"the {leg[bad]} leg ({bad}) is missing" in warnings[0]
    assert f"both.h5.{bad}.partial.damaged" in warnings[0]
    assert f"({leg[good]} leg only: the {leg[bad]} leg is missing)" in cap.out
    assert "Traceback" not in cap.err + cap.out

    # the damaged bytes, set aside unchanged (a journal beside it as its journal)
    aside = tmp_path / f"both.h5.{bad}.partial.damaged"
    for name, digest in damaged.items():
        moved = aside if name.endswith(".partial") else journal_path(aside)
        assert _digest(moved) == digest, name
    assert not parts_of(out)
    with open_bilateral(out) as b:
        assert b.sides == (good,) and set(b.missing) == {bad}
        assert not b.complete
        u = b.unit(good)
        assert u.n_samples == ref_rows
        np.testing.assert_array_equal(u.read("raw/adc"), ref_adc)
    with h5py.File(out, "r") as f:
        assert f.attrs["missing"] == bad and f"sync/{good}" in f and f"sync/{bad}" not in f
    # the file stays what it is: opened again, the same, and still saying so
    assert main(["info", str(out)]) == 0
    again = capsys.readouterr()
    assert f"the {leg[bad]} leg is missing" in again.out and "warning" in again.err
    assert aside.exists()


def test_neither_leg_recoverable_is_one_line_and_keeps_both_parts(
    killed: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = _copy_parts(killed, tmp_path)
    for side in "LR":
        _random(part_path(out, side))
        _random(journal_path(part_path(out, side)))
    before = {p.name: _digest(p) for p in tmp_path.iterdir()}
    assert main(["info", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "neither leg can be recovered" in err
    assert {p.name: _digest(p) for p in tmp_path.iterdir()} == before


def test_a_finished_part_with_a_damaged_object_header_is_set_aside(
    killed: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A part whose file opens but one of whose objects' headers is damaged (the group copy
    into the combined file would fail on it): set aside like any other damaged part."""
    import h5py.h5o

    out = _copy_parts(killed, tmp_path)
    part = part_path(out, "R")
    with open_session(part) as s:  # recovered in place from its journal: a finished part
        assert s.recovered
    assert not journal_path(part).exists()
    with h5py.File(part, "r") as f:
        addr = h5py.h5o.get_info(f["events"].id).addr
    with part.open("r+b") as fh:  # the /events group's header: its version byte and more
        fh.seek(addr)
        fh.write(b"\xff" * 16)
    digest = _digest(part)
    assert main(["info", str(out)]) == 0
    cap = capsys.readouterr()
    assert "the right leg (R) is missing" in cap.err and "Traceback" not in cap.err
    assert "(left leg only: the right leg is missing)" in cap.out
    assert _digest(tmp_path / "both.h5.R.partial.damaged") == digest
