"""A disk that fills while `gaitmon record --simulate` stores the simulator's ground truth
(``/truth``, written into the finished file): one line and exit 2, the recording complete and
readable as it was. Before the fix h5py's write error escaped as an internal error (exit 1,
its text in the message) and the process could then die of a segmentation fault at exit
(HDF5 failing inside its own close)."""

from __future__ import annotations

import subprocess
import sys

import h5py
import pytest

from gaitmon.finish import open_session
from gaitmon.io.journal import journal_path

# The real `gaitmon record`, with the file size limit lowered to the finished file's size at
# the moment the ground truth is attached: the kernel refuses every byte the truth would add
# (EFBIG, as a full disk's ENOSPC), nothing is mocked past that moment.
_FULL_AT_TRUTH = """
import os, resource, signal, sys
import gaitmon.io.sim.truth as st
from gaitmon.cli import main

real = st.attach_ground_truth

def attach(path, unit, *a, **k):
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG)
    limit = os.path.getsize(path) + int(sys.argv[1])
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))
    return real(path, unit, *a, **k)

st.attach_ground_truth = attach
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.skipif(sys.platform == "win32", reason="file size limits are POSIX")
@pytest.mark.parametrize("room_bytes", [0, 60_000])  # none; part of the truth's ~180 kB
def test_disk_full_while_the_truth_is_stored_one_line_and_the_recording_kept(tmp_path, room_bytes):
    out = tmp_path / "walk.h5"
    r = subprocess.run(
        [sys.executable, "-c", _FULL_AT_TRUTH, str(room_bytes), "record", "--simulate",
         "--speed", "max", "--duration", "30", "-o", str(out), "-q"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    line = lines[0]
    assert "Traceback" not in line and "errno =" not in line and "internal error" not in line
    assert "disk full" in line and "ground truth" in line and "File too large" in line, line
    assert "3000 rows, 30.0 s" in line, line  # what the file holds, as a reader gets it
    assert "free some space" in line, line  # what to do
    assert not journal_path(out).exists()  # the recording was finished before the truth
    with open_session(out) as s:
        assert s.complete and not s.recovered and s.n_samples == 3000
        assert s.duration_s == pytest.approx(30.0)
        assert s.heel_strike_idx.size > 20  # the recording's own data, all there
    with h5py.File(out, "r") as f:
        assert "truth" not in f  # nothing half-written


_RESERVE = """
import errno, os, resource, signal, sys
from gaitmon.io.session.truth import reserve_space

path, how = sys.argv[1], sys.argv[2]
if how == "zeros":  # as on Windows, which has no posix_fallocate
    del os.posix_fallocate
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
size = os.path.getsize(path)
resource.setrlimit(resource.RLIMIT_FSIZE, (size + 100_000, resource.RLIM_INFINITY))
reserve_space(path, 90_000)  # fits
assert os.path.getsize(path) == size + 90_000
os.truncate(path, size)
try:
    reserve_space(path, 3_000_000)  # does not fit: the kernel's EFBIG, the file as it was
except OSError as e:
    assert e.errno == errno.EFBIG, e
    assert os.path.getsize(path) == size
    print("refused")
"""


@pytest.mark.skipif(sys.platform == "win32", reason="file size limits are POSIX")
@pytest.mark.parametrize("how", ["fallocate", "zeros"])
def test_reserve_space_claims_the_bytes_or_leaves_the_file_as_it_was(tmp_path, how):
    import numpy as np

    f = tmp_path / "f.h5"
    with h5py.File(f, "w") as h:
        h["x"] = np.arange(1000)
    r = subprocess.run([sys.executable, "-c", _RESERVE, str(f), how], capture_output=True,
                       text=True, timeout=60)  # fmt: skip
    assert r.returncode == 0 and r.stdout.strip() == "refused", r.stderr
    with h5py.File(f, "r") as h:
        assert h["x"][-1] == 999


def test_the_claimed_space_is_given_back_the_truth_takes_its_bytes_only(tmp_path, monkeypatch):
    import os

    import gaitmon.io.session.truth as session_truth
    import gaitmon.io.sim.truth as sim_truth
    from gaitmon.cli import main

    seen: dict[str, int] = {}
    real_attach, real_reserve = sim_truth.attach_ground_truth, session_truth.reserve_space

    def reserve(path, nbytes):
        seen["reserved"] = nbytes
        return real_reserve(path, nbytes)

    def attach(path, unit, *a, **k):
        seen["before"] = os.path.getsize(path)
        return real_attach(path, unit, *a, **k)

    monkeypatch.setattr(session_truth, "reserve_space", reserve)
    monkeypatch.setattr(sim_truth, "attach_ground_truth", attach)
    out = tmp_path / "walk.h5"
    assert main(["record", "--simulate", "--speed", "max", "--duration", "10", "-o", str(out),
                 "-q"]) == 0  # fmt: skip
    grew = os.path.getsize(out) - seen["before"]
    with h5py.File(out, "r") as f:
        raw = sum(d.id.get_storage_size() for d in f["truth"].values())
        n_hs, n_to = len(f["truth/heel_strike"]), len(f["truth/toe_off"])
        assert f["truth/sample_idx"].shape == (1000,) and n_hs > 2
    # per row: int64 sample + 11 float32; per event an int64 row; per stride 3 float64
    assert raw == 1000 * 52 + 8 * (n_hs + n_to) + 24 * n_hs
    assert raw < grew < raw + 30_000  # and HDF5's own: headers, attributes (~10 kB)
    assert seen["reserved"] > grew + 200_000  # claimed with room to spare, the rest given back
