"""The log file on a full disk: one line on the terminal, once, naming the file, and the command
carries on. Before, Python's logging printed "--- Logging error ---" and a traceback to stderr
for every record the file could not take (``logging.Handler.handleError``)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import gaitmon

# The real handler set up by `gaitmon` (``logs.setup``), then the file size limit lowered to the
# log's size: the kernel refuses every byte more (EFBIG, as a full disk's ENOSPC); nothing is
# mocked. Records go to the file only (INFO; the terminal shows warnings), so stderr holds only
# what the handler says of the failure. The last line of stdout says the process carried on.
_FULL_LOG = """
import logging, os, resource, signal, sys
from gaitmon import logs

path = logs.setup()
log = logging.getLogger("gaitmon.test")
log.info("before the disk fills")
for h in logging.getLogger("gaitmon").handlers:
    h.flush()
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG)
resource.setrlimit(resource.RLIMIT_FSIZE, (os.path.getsize(path), resource.RLIM_INFINITY))
for i in range(5):
    log.info("record %d, after the disk filled", i)
logs.setup()  # a second setup closes the handler (its flush fails too)
print("carried on", path)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="file size limits are POSIX")
def test_a_log_file_that_cannot_be_written_is_said_once_in_one_line(tmp_path):
    tested = Path(gaitmon.__file__).parents[1]  # the gaitmon this run imports
    env = {"HOME": str(tmp_path), "XDG_STATE_HOME": str(tmp_path / "state"),
           "PATH": "/usr/bin:/bin", "PYTHONPATH": str(tested)}  # fmt: skip
    r = subprocess.run([sys.executable, "-c", _FULL_LOG], capture_output=True, text=True,
                       timeout=60, env=env)  # fmt: skip
    assert r.returncode == 0, r.stderr
    log = tmp_path / "state" / "gaitmon" / "log" / "gaitmon.log"
    assert r.stdout.strip() == f"carried on {log}"
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr  # once, for the five records and the close
    line = lines[0]
    assert "Traceback" not in line and "Logging error" not in line
    assert str(log) in line and "disk full or not writable" in line, line
    assert "File too large" in line, line  # the system's own words for the failure
    text = log.read_text(encoding="utf-8")
    assert "before the disk fills" in text and "after the disk filled" not in text
