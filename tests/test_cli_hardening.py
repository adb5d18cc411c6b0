"""The command line under faults (issue 12): closed pipes, a full disk, a unit that stops,
`--speed max`, settings that cannot work, one spelling of each option, and HDF5's own words
kept from the user. Each test fails on the code before the fix."""

from __future__ import annotations

import re
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from gaitmon.cli import build_parser, main
from gaitmon.finish import open_session
from gaitmon.io.journal import journal_path

GAITMON = [sys.executable, "-m", "gaitmon"]
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def rec(tmp_path_factory, record_simulated) -> Path:
    return record_simulated(tmp_path_factory.mktemp("hard") / "walk.h5", duration_s=20)


# -- defect 5: a closed pipe -----------------------------------------------------------------


@pytest.mark.parametrize("command", ["info", "export"])
def test_a_closed_pipe_ends_quietly(rec, tmp_path, command):
    """`gaitmon info rec.h5 | head -0`: the reader is gone before gaitmon writes a byte."""
    args = ["info", str(rec)] if command == "info" else [
        "export", str(rec), "--format", "csv", "-o", str(tmp_path / "x.csv")]
    proc = subprocess.Popen([*GAITMON, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # before the child has imported gaitmon: its first write meets EPIPE
    _, err = proc.communicate(timeout=120)
    assert b"Traceback" not in err and b"BrokenPipe" not in err, err.decode()
    assert err == b""
    assert proc.returncode == 141  # as a program ended by SIGPIPE reports it


# -- defect 9: one spelling, honest choices, settings that cannot work ------------------------


@pytest.mark.parametrize("command", ["record", "export", "report", "process", "compare"])
def test_every_writing_command_has_force_and_q(command):
    p = build_parser(command)
    sub = next(a for a in p._actions if isinstance(a.choices, dict)).choices[command]
    helptext = sub.format_help()
    assert "--force" in helptext and "-q, --quiet" in helptext
    assert "--overwrite" not in helptext  # the old spelling is a hidden alias
    base = {"record": ["--simulate", "--duration", "1", "-o", "x.h5"],
            "export": ["f.h5", "--format", "csv"], "report": ["f.h5", "-o", "r.pdf"],
            "process": ["f.h5", "-o", "n.h5"],
            "compare": ["a.h5", "b.h5", "-o", "c.pdf"]}[command]  # fmt: skip
    for spelling in ("--force", "--overwrite"):
        assert p.parse_args([command, *base, spelling, "-q"]).force is True
    assert p.parse_args([command, *base]).force is False


def test_side_shows_no_empty_choice():
    helptext = build_parser("record").format_help() + _sub_help("record")
    assert "{L,R}" in helptext and "{L,R,}" not in helptext


def _sub_help(command: str) -> str:
    p = build_parser(command)
    return next(a for a in p._actions if isinstance(a.choices, dict)).choices[command].format_help()


@pytest.mark.parametrize(
    "option, value, words",
    [("--fsr-threshold", "99999", "below 4095"), ("--fsr-threshold", "4095", "below 4095"),
     ("--cutoff-hz", "0", "above 0"), ("--q-angle", "-1", "above 0"),
     ("--cutoff-hz", "80", "above 0 and below the Nyquist")],
)  # fmt: skip
def test_process_rejects_settings_that_cannot_work(rec, tmp_path, capsys, option, value, words):
    new = tmp_path / "new.h5"
    assert main(["process", str(rec), "-o", str(new), option, value]) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1, err
    assert not new.exists()


def test_process_warns_when_settings_find_no_strides(rec, tmp_path, capsys):
    new = tmp_path / "new.h5"
    assert main(["process", str(rec), "-o", str(new), "--cutoff-hz", "0.01", "-q"]) == 0
    err = capsys.readouterr().err
    # the FSRs find nothing at 0.01 Hz: the FSR check takes the events from the foot gyro,
    # and the warning says so (it used to say "0 heel strikes")
    assert "warning" in err and "never switch" in err and "foot gyro" in err, err
    assert err.count("\n") == 1, err
    with open_session(new) as s:  # the warning tells the truth: the heel stays in one state
        heel = s.read("processed/heel_loaded").astype(int)
        assert np.count_nonzero(np.diff(heel)) <= 2


def test_no_message_says_between_0_when_0_is_rejected():
    hits = [f"{p.relative_to(ROOT)}" for p in (ROOT / "gaitmon").rglob("*.py")
            if re.search(r"between 0(\.0)? and", p.read_text())]  # fmt: skip
    assert hits == []
    from gaitmon.dsp.filters import Butterworth

    with pytest.raises(ValueError, match="above 0"):
        Butterworth.check(0.0, 100.0, 2)


@pytest.mark.parametrize(
    "content, words",
    [(b"just some text\n" * 10, "is not a gaitmon session (not an HDF5 file)"),
     (b"", "is not a gaitmon session (an empty file)")],
)  # fmt: skip
def test_hdf5_library_text_never_reaches_the_user(tmp_path, capsys, content, words):
    f = tmp_path / "notes.h5"
    f.write_bytes(content)
    for args in (["info", str(f)], ["export", str(f), "--format", "csv"]):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert words in err, err
        assert "synchronously" not in err and "signature" not in err and "Unable" not in err


def test_a_truncated_file_is_named_damaged_in_plain_words(rec, tmp_path, capsys):
    cut = tmp_path / "cut.h5"
    cut.write_bytes(rec.read_bytes()[:50_000])
    assert main(["info", str(cut)]) == 2
    err = capsys.readouterr().err
    assert "cut.h5 is damaged" in err and "cut short" in err and "synchronously" not in err


# -- defect 4: --speed max and a unit that stops ----------------------------------------------


def _slow_unit(monkeypatch, *, stop_after_s: float | None = None, block: int = 5,
               delay_s: float = 0.02):
    """build_unit makes a unit that sends at most ``block`` frames per read, ``delay_s`` apart
    (a busy machine at `--speed max`), and goes silent after ``stop_after_s`` of wall time."""
    import gaitmon.io.sim.config as config

    real = config.build_unit

    class Slow:
        def __init__(self, unit):
            self._unit = unit
            unit.afap_block = block
            self._t0 = time.monotonic()

        def read(self, *a, **k):
            time.sleep(delay_s)
            if stop_after_s is not None and time.monotonic() - self._t0 > stop_after_s:
                return b""
            return self._unit.read(*a, **k)

        def wait_readable(self, timeout_s):
            if stop_after_s is not None and time.monotonic() - self._t0 > stop_after_s:
                time.sleep(timeout_s)
                return False
            return self._unit.wait_readable(timeout_s)

        def __getattr__(self, name):
            return getattr(self._unit, name)

    monkeypatch.setattr(config, "build_unit", lambda cfg: Slow(real(cfg)))


@pytest.mark.timeout(120)
def test_speed_max_records_the_whole_duration_however_long_it_takes(tmp_path, monkeypatch):
    """At ~250 frames/s, 30 s of data take ~12 s of wall time: the old watchdog (duration /
    speed + 10 s of wall time) stopped after 10 s, said "stopped sending" and exited 0."""
    _slow_unit(monkeypatch)
    out = tmp_path / "max.h5"
    rc = main(["record", "--simulate", "--speed", "max", "--duration", "30", "-o", str(out),
               "-q"])  # fmt: skip
    assert rc == 0
    with open_session(out) as s:
        assert s.n_samples == 3000 and s.complete  # exactly the duration (issue 25 item 8)


def test_speed_max_records_exactly_the_duration_every_time(tmp_path):
    """``--duration`` is the unit's time, not a wall-clock poll: at full speed five runs wrote
    30, 30, 31, 33 and 51 s for 30 (issue 25, item 8)."""
    for k in range(3):
        out = tmp_path / f"max{k}.h5"
        assert main(["record", "--simulate", "--speed", "max", "--duration", "10", "-o",
                     str(out), "-q"]) == 0  # fmt: skip
        with open_session(out) as s:
            assert s.n_samples == 1000 and s.complete


def test_two_legs_at_a_raised_speed_record_the_duration_on_each_leg(tmp_path):
    """Issue 26, item 12: ``--duration 30 --speed 10`` wrote 34.0 s of two legs (left 3,400,
    right 3,121 frames) where one leg wrote 30.7 s: each leg now stops at the unit's time."""
    out = tmp_path / "both.h5"
    assert main(["record", "--simulate-bilateral", "--speed", "10", "--duration", "12", "-o",
                 str(out), "-q"]) == 0  # fmt: skip
    for side in ("L", "R"):
        with open_session(out, side=side) as s:
            assert s.n_samples == 1200 and s.complete, side


@pytest.mark.timeout(120)
def test_a_unit_that_stops_sending_ends_the_recording_non_zero(tmp_path, monkeypatch, capsys):
    import gaitmon.commands.record as record

    monkeypatch.setattr(record, "STALL_S", 1.0)
    _slow_unit(monkeypatch, stop_after_s=2.0, block=20)
    out = tmp_path / "stall.h5"
    rc = main(["record", "--simulate", "--speed", "max", "--duration", "600", "-o", str(out),
               "-q"])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2, err
    line = next(ln for ln in err.splitlines() if "error:" in ln)
    assert "no data for 1 s" in line and "of 600 s" in line
    with open_session(out) as s:  # what was received is kept, complete
        assert s.complete and 0 < s.n_samples < 60000


# -- defect 6: a full disk ----------------------------------------------------------------------


def _file_size_limit(limit: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.mark.timeout(180)
def test_disk_full_one_message_whose_row_count_a_reader_gets_at_once(tmp_path):
    out = tmp_path / "full.h5"
    full = _file_size_limit(1_500_000)  # the disk stays full for the reader too
    r = subprocess.run(
        [*GAITMON, "record", "--simulate", "--speed", "20", "--duration", "300", "-o",
         str(out), "-q"], preexec_fn=full, capture_output=True, text=True, timeout=150,
    )  # fmt: skip
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "disk full" in lines[0], r.stderr  # said once
    stated = int(re.search(r"up to row (\d+)", lines[0]).group(1))
    assert journal_path(out).exists()
    info = subprocess.run([*GAITMON, "info", str(out)], preexec_fn=full, capture_output=True,
                          text=True, timeout=60)  # fmt: skip
    assert info.returncode == 0, info.stderr
    m = re.search(r", ([\d.]+) s, (\d+) frames", info.stdout)
    assert int(m.group(2)) == stated, info.stdout
    # not "0.0 s": info prints 0.1 s steps (rounding up to 0.05 s) of the last row's time
    # ((rows - 1) / 100 s): 29875 rows printed "298.8 s" once, 0.05 s from 298.75
    assert abs(float(m.group(1)) - stated / 100) <= 0.06 + 1e-9, info.stdout
    assert "different lengths" not in info.stdout
    assert journal_path(out).exists()  # nothing could be saved yet: the journal is kept
    with open_session(out) as s:  # once space is back (no limit here), the same rows
        assert s.recovered and s.n_samples == stated
    assert not journal_path(out).exists()


def test_an_unfinished_file_reports_its_duration(rec, tmp_path):
    """A file whose recorder died before it finished (attribute still 0.0 s) and whose journal
    is gone: the duration comes from its last row's time."""
    import shutil

    import h5py

    f = tmp_path / "unfinished.h5"
    shutil.copyfile(rec, f)
    with h5py.File(f, "r+") as h:
        h.attrs["complete"] = False
        h.attrs["duration_s"] = 0.0
    with open_session(f) as s:
        assert s.duration_s == pytest.approx(s.n_samples / 100, abs=0.05)


# -- defect 7: the file exists before the first frame is requested -----------------------------


def test_the_file_and_journal_exist_before_the_first_frame_is_requested(tmp_path, monkeypatch):
    from gaitmon.io.device import Device

    out = tmp_path / "early.h5"
    seen = []
    real = Device.start_stream

    def start_stream(self, *a, **k):
        seen.append((out.exists(), journal_path(out).exists()))
        return real(self, *a, **k)

    monkeypatch.setattr(Device, "start_stream", start_stream)
    assert main(["record", "--simulate", "--speed", "20", "--duration", "2", "-o", str(out),
                 "-q"]) == 0  # fmt: skip
    assert seen == [(True, True)]
    with open_session(out) as s:  # and it holds every frame the engine received
        assert s.n_samples >= 200 and s.complete


def test_a_start_that_fails_after_the_file_was_created_leaves_no_file(tmp_path, monkeypatch,
                                                                      capsys):
    from gaitmon.io.device import Device, DeviceError

    def start_stream(self, *a, **k):
        raise DeviceError("the unit refused to stream")

    monkeypatch.setattr(Device, "start_stream", start_stream)
    out = tmp_path / "never.h5"
    assert main(["record", "--simulate", "--duration", "2", "-o", str(out), "-q"]) == 2
    assert "refused to stream" in capsys.readouterr().err
    assert not out.exists() and not journal_path(out).exists()
