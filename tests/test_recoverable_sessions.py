"""Sessions that exist only as what a crash left are sessions everywhere (issue 26, item 11).

A recording killed with -9 leaves its journal (one unit) or its ``.L/.R.partial`` parts (both
legs); if its file is lost too, ``gaitmon info`` still recovers it. ``batch`` and ``compare``
must see the same session (one rule: :func:`gaitmon.io.session.parts.session_files`), and a
recovery that cannot be saved (a full disk) must never be called recovered.
"""

from __future__ import annotations

import csv
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from gaitmon.cli import main
from gaitmon.finish import open_session
from gaitmon.io.journal import journal_path
from gaitmon.io.session.parts import part_path

ROOT = Path(__file__).resolve().parents[1]


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def _killed(argv: list[str], ready: Callable[[], bool]) -> None:
    proc = subprocess.Popen([sys.executable, "-m", "gaitmon", *argv], env=_env(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    try:
        deadline = time.monotonic() + 60.0
        while not ready():
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)


@pytest.fixture(scope="module")
def crashed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Read-only: a one-unit recording killed with -9 (file and journal), one of both legs
    killed with -9 (its parts and their journals, no file), and a complete one-unit session
    of the same patient."""
    d = tmp_path_factory.mktemp("crashed")
    one = d / "one" / "visit2.h5"
    one.parent.mkdir()
    _killed(["record", "--simulate", "--duration", "600", "--speed", "8", "-o", str(one),
             "-q", "--standing-s", "2", "--patient", "P7"],
            lambda: journal_path(one).exists() and journal_path(one).stat().st_size > 150_000)
    both = d / "both" / "pair.h5"
    both.parent.mkdir()
    _killed(["record", "--simulate-bilateral", "--duration", "600", "--speed", "4", "-o",
             str(both), "-q", "--standing-s", "2", "--patient", "P7"],
            lambda: all(part_path(both, s).exists() and part_path(both, s).stat().st_size
                        > 50_000 for s in "LR"))  # fmt: skip
    good = d / "good" / "visit1.h5"
    good.parent.mkdir()
    assert main(["record", "--simulate", "--duration", "40", "-o", str(good), "--speed", "20",
                 "--standing-s", "2", "--quiet", "--patient", "P7"]) == 0  # fmt: skip
    return {"one": one, "both": both, "good": good}


def _journal_only(crashed: dict[str, Path], folder: Path) -> Path:
    """The one-unit crash with its file lost: only ``visit2.h5.journal`` in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    f = folder / crashed["one"].name
    shutil.copyfile(journal_path(crashed["one"]), journal_path(f))
    return f


def _parts_only(crashed: dict[str, Path], folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for p in crashed["both"].parent.iterdir():
        shutil.copyfile(p, folder / p.name)
    return folder / crashed["both"].name


def _recovered_rows(crashed: dict[str, Path], tmp_path: Path) -> int:
    """How many rows ``gaitmon info`` recovers from the journal alone (the reference)."""
    f = _journal_only(crashed, tmp_path / "ref")
    with open_session(f) as s:
        assert s.recovered
        return s.n_samples


def test_one_rule_names_a_session(crashed: dict[str, Path], tmp_path: Path) -> None:
    from gaitmon.io.session.parts import session_files, sessions_in

    j = _journal_only(crashed, tmp_path / "d")
    p = _parts_only(crashed, tmp_path / "d")
    shutil.copyfile(crashed["good"], tmp_path / "d" / "visit1.h5")
    (tmp_path / "d" / "out.h5.partial").write_bytes(b"half-written output")  # not a session
    (tmp_path / "d" / "old.h5.L.partial.damaged").write_bytes(b"set aside")  # nor this
    assert session_files(j) == [journal_path(j)]
    assert {x.name for x in session_files(p)} == {
        "pair.h5.L.partial", "pair.h5.L.partial.journal", "pair.h5.R.partial",
        "pair.h5.R.partial.journal"}  # fmt: skip
    assert session_files(tmp_path / "d" / "nothing.h5") == []
    assert [x.name for x in sessions_in(tmp_path / "d")] == ["pair.h5", "visit1.h5", "visit2.h5"]


def test_batch_gives_a_row_to_a_journal_and_to_parts(
    crashed: dict[str, Path], tmp_path: Path
) -> None:
    n = _recovered_rows(crashed, tmp_path)
    study = tmp_path / "study"
    _journal_only(crashed, study)
    _parts_only(crashed, study / "pairs")
    shutil.copyfile(crashed["good"], study / "visit1.h5")
    out = tmp_path / "out"
    # no row at all for visit2.h5 (only its journal) nor pairs/pair.h5 (only its parts)
    assert main(["batch", str(study), "-o", str(out), "--jobs", "1", "-q"]) == 0
    with (out / "summary.csv").open(encoding="utf-8") as f:
        rows = {r["session"]: r for r in csv.DictReader(f)}
    assert set(rows) == {"visit1.h5", "visit2.h5", "pairs/pair.h5"}
    # the journal's session recovered on the fly, as info recovers it: every row
    assert rows["visit2.h5"]["status"] == "ok", rows["visit2.h5"]
    assert float(rows["visit2.h5"]["duration_s"]) == pytest.approx(n / 100.0, abs=0.02)
    with open_session(out / "visit2.h5") as s:
        assert s.n_samples == n
    assert rows["pairs/pair.h5"]["status"] == "skipped"
    assert "both legs (interrupted" in rows["pairs/pair.h5"]["reason"]


def test_compare_accepts_a_session_left_as_its_journal(
    qapp: object, crashed: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:  # qapp: the comparison draws with pytest-qt's application, not its own
    f = _journal_only(crashed, tmp_path / "d")
    pdf = tmp_path / "c.pdf"
    # said "visit2.h5 does not exist"
    rc = main(["compare", str(crashed["good"]), str(f), "-o", str(pdf), "-q"])
    assert rc == 0, capsys.readouterr().err
    assert pdf.stat().st_size > 1000
    assert f.exists() and not journal_path(f).exists()  # recovered, as info does
    # the parts of a recording of both legs: what info says of both legs, not "does not exist"
    p = _parts_only(crashed, tmp_path / "p")
    assert main(["compare", str(crashed["good"]), str(p), "-o", str(pdf), "--force"]) == 2
    err = capsys.readouterr().err
    assert "does not exist" not in err and "both legs" in err, err


FULL_DISK_INFO = textwrap.dedent("""
    import resource, signal, sys
    from gaitmon.cli import main
    if len(sys.argv) > 3:  # a journal too large to recover in memory: the file read as it is
        import gaitmon.finish.recovery as recovery
        recovery.IN_MEMORY_MAX_JOURNAL_BYTES = 0
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG)
    resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[1]), int(sys.argv[1])))
    sys.exit(main(["info", sys.argv[2]]))
""")


def test_info_on_a_full_disk_never_says_recovered(
    crashed: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    n = _recovered_rows(crashed, tmp_path)
    f = tmp_path / "full" / "visit2.h5"
    f.parent.mkdir()
    shutil.copyfile(crashed["one"], f)
    shutil.copyfile(journal_path(crashed["one"]), journal_path(f))
    before = f.read_bytes()
    r = subprocess.run([sys.executable, "-c", FULL_DISK_INFO, "60000", str(f)],
                       capture_output=True, text=True, env=_env(), timeout=240)  # fmt: skip
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    head = r.stdout.splitlines()[0]
    # said "... recovered (the recording was interrupted; recovered now from its journal)"
    assert "recovered now" not in r.stdout and "not recovered" in head, head
    assert "the recovery could not be saved (" in head, head
    # why, in the OS's words or HDF5's translated (it can fail inside a compressed chunk)
    assert "File too large" in head or "file size limit is reached" in head, head
    assert "the journal is kept" in head
    assert f"{n} frames" in r.stdout  # every row of the journal, read in memory
    assert journal_path(f).exists() and f.read_bytes() == before  # nothing changed on disk
    assert not f.with_name(f.name + ".recovering").exists()
    # a journal too large to rebuild in memory: the file's last flush is shown, and still
    # never called recovered
    r = subprocess.run([sys.executable, "-c", FULL_DISK_INFO, "60000", str(f), "as-is"],
                       capture_output=True, text=True, env=_env(), timeout=240)  # fmt: skip
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    head = r.stdout.splitlines()[0]
    assert "not recovered: the recovery could not be saved (" in head, head
    assert journal_path(f).exists() and f.read_bytes() == before
    # with space again, the same command recovers and saves it
    assert main(["info", str(f)]) == 0
    out = capsys.readouterr().out
    assert "recovered now from its journal" in out and f"{n} frames" in out
    assert not journal_path(f).exists()
