"""The recorder under faults the outside campaign of issue 26 found: a disk full at the file's
creation, and blocks the recorder queue had to drop (each one reported, with its cause).

Real parts throughout: `gaitmon record` in a child process, a real Engine over the simulated
unit, real HDF5 files; the one stand-in is a session writer whose ``append`` waits (a stalled
disk), as tests/test_robustness.py does.
"""

from __future__ import annotations

import resource
import signal
import subprocess
import sys

import pytest

GAITMON = [sys.executable, "-m", "gaitmon"]


def _file_size_limit(limit: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.mark.timeout(120)
@pytest.mark.parametrize("limit", [4096, 8192])
def test_a_disk_full_at_creation_is_one_line_exit_2_and_leaves_nothing(tmp_path, limit):
    # 8 KiB: HDF5 failed writing the file it was creating, printed two "Exception ignored"
    # tracebacks and the process died of a segfault (exit 139) after the message
    out = tmp_path / "g.h5"
    r = subprocess.run(
        [*GAITMON, "record", "--simulate", "--speed", "max", "--duration", "600", "-o",
         str(out), "-q"], preexec_fn=_file_size_limit(limit), capture_output=True, text=True,
        timeout=100,
    )  # fmt: skip
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr[-2000:]
    assert lines[0].startswith("gaitmon record: error: cannot create g.h5: "), lines
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no file, no journal
