"""``gaitmon batch``: a rerun resumes whatever the spelling of DIR and OUT, and a cancelled
batch has stopped writing when it returns (issue 27, "Batch and record summaries")."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gaitmon.batch import OK, run_batch
from tests.test_batch import SETTINGS, _alive, _workers, patient, write_session


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> Path:
    """Six sessions in two sub-folders (a copy of them is each test's study)."""
    root = tmp_path_factory.mktemp("six")
    for k in range(6):
        sub = root / ("site-a" if k % 2 else "site-b")
        sub.mkdir(exist_ok=True)
        write_session(sub / f"{patient(k)}_{k:02d}.h5", seed=300 + k, pid=patient(k))
    return root


def test_a_rerun_resumes_whatever_the_spelling_of_the_folders(sessions, tmp_path, monkeypatch):
    """``gaitmon batch study2 -o OUT4`` then ``gaitmon batch $PWD/study2 -o $PWD/OUT4``
    reported "0 already done" and did every session again (the record held OUT's spelling)."""
    shutil.copytree(sessions, tmp_path / "study2")
    monkeypatch.chdir(tmp_path)
    first = run_batch("study2", "OUT4", SETTINGS)
    assert first.count(OK) == 6 and first.n_resumed == 0
    stamps = {p: p.stat().st_mtime_ns for p in Path("OUT4").rglob("*.h5")}
    assert len(stamps) == 6
    summary = Path("OUT4/summary.csv").read_bytes()

    again = run_batch(tmp_path / "study2", tmp_path / "OUT4", SETTINGS)
    assert again.n_resumed == 6
    also = run_batch("./study2/../study2", "OUT4/", SETTINGS)
    assert also.n_resumed == 6
    assert {p: p.stat().st_mtime_ns for p in Path("OUT4").rglob("*.h5")} == stamps  # untouched
    assert Path("OUT4/summary.csv").read_bytes() == summary

    # the study and its OUT moved together (another disk, another machine) still resume
    (tmp_path / "moved").mkdir()
    for name in ("study2", "OUT4"):
        (tmp_path / name).rename(tmp_path / "moved" / name)
    moved = run_batch(tmp_path / "moved" / "study2", tmp_path / "moved" / "OUT4", SETTINGS)
    assert moved.n_resumed == 6
    assert (tmp_path / "moved" / "OUT4" / "summary.csv").read_bytes() == summary

    # and what must not resume still does not: an output deleted is done again
    gone = next((tmp_path / "moved" / "OUT4").rglob("*.h5"))
    gone.unlink()
    redo = run_batch(tmp_path / "moved" / "study2", tmp_path / "moved" / "OUT4", SETTINGS)
    assert redo.n_resumed == 5 and gone.exists()


def _tree(out: Path) -> dict[str, tuple[int, int]]:
    """Every file under OUT (records and half-written files too): size and time."""
    return {p.relative_to(out).as_posix(): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in out.rglob("*") if p.is_file()}  # fmt: skip


def _published(out: Path) -> set[str]:
    return {p.relative_to(out).as_posix() for p in out.rglob("*.h5")}


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads /proc (Linux)")
@pytest.mark.parametrize("to", ["batch", "group"])
def test_a_cancelled_batch_has_stopped_writing_when_it_returns(sessions, tmp_path, to):
    """After Ctrl-C a worker renamed another session into OUT seconds after the command had
    returned (the pool let every session handed to a worker finish and write). Now the
    workers are stopped before the command returns, and only the batch's own thread moves an
    output into place: no session appears in OUT after the interrupt, nothing changes there
    after the command has exited, and a rerun finishes the study.

    ``to="batch"``: SIGINT to the batch process alone (the old code let its workers finish
    their sessions and publish them: this variant fails on it every time); ``"group"``: to its
    whole process group, as a terminal's Ctrl-C does (workers leave it to the batch: the
    command says one line, no worker's traceback)."""
    study, out = tmp_path / "study", tmp_path / "out"
    shutil.copytree(sessions, study)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-m", "gaitmon", "batch", str(study), "-o", str(out),
                             "--jobs", "2", "-q"], env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            # Ctrl-C as a terminal's foreground command gets it: a test run
                            # started in the background of a shell without job control
                            # ignores SIGINT, and its children inherit that
                            preexec_fn=_default_sigint)  # fmt: skip
    try:
        workers: set[int] = set()
        deadline = time.monotonic() + 120
        # wait until two workers run and one is writing (a .partial output exists)
        while time.monotonic() < deadline and proc.poll() is None:
            workers |= _workers(proc.pid)
            if len(workers) >= 2 and list(out.rglob("*.partial")):
                break
            time.sleep(0.01)
        assert proc.poll() is None and len(workers) >= 2, "the batch ended before the interrupt"
        # the batch stopped while OUT is looked at: what is there was published before Ctrl-C
        os.kill(proc.pid, signal.SIGSTOP)
        before = _published(out)
        if to == "batch":
            os.kill(proc.pid, signal.SIGINT)
        else:
            os.killpg(proc.pid, signal.SIGINT)
        os.kill(proc.pid, signal.SIGCONT)
        _, err = proc.communicate(timeout=300)
        at_exit = _tree(out)
        deadline = time.monotonic() + 120  # a generous wait for workers that outlive it
        while time.monotonic() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.05)
        assert not any(_alive(w) for w in workers)
        assert _tree(out) == at_exit  # nothing written after the command returned
        assert _published(out) == before  # nor any session published after Ctrl-C
        assert len(before) < 6
        assert proc.returncode == 130
        assert err.decode().splitlines() == ["gaitmon batch: interrupted"]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        assert proc.stderr is not None
        proc.stderr.close()  # (left open by a failure above, a later test's gc warned of it)
    rerun = run_batch(study, out, None)  # what was cut short is done again
    assert rerun.count(OK) == 6 and len(_published(out)) == 6
