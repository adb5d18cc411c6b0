"""De-identification leaves no trace (issue 12, defect 8): every byte of every output of
``export --deidentify`` (all formats, default names) and ``report --deidentify`` is searched
for the patient id, operator, notes, device serial and recording date; and a journal left by a
crash holds none of the identity, which recovery restores from the file's header."""

from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import pytest

from gaitmon.cli import main
from gaitmon.export import FORMATS
from gaitmon.finish import open_session
from gaitmon.io.journal import journal_path

PATIENT = "PSECRET17"
OPERATOR = "DrOpSecret"
NOTES = "NoteSecret42 knee pain"
SERIAL = 987654321
CREATED = "2019-03-14T15:09:26Z"
# the date alone: the time of day could match the export's own time stamp (exported_utc)
SECRETS = (PATIENT, OPERATOR, "NoteSecret42", str(SERIAL), "2019-03-14")


@pytest.fixture(scope="module")
def session(tmp_path_factory, record_simulated) -> Path:
    """A real recording named after its patient, with a distinctive serial and date."""
    d = tmp_path_factory.mktemp("deid")
    path = record_simulated(d / f"{PATIENT}_walk.h5", "--patient", PATIENT, "--operator",
                            OPERATOR, "--notes", NOTES, duration_s=15)  # fmt: skip
    with h5py.File(path, "r+") as f:
        f["device"].attrs["serial"] = SERIAL
        f.attrs["created_utc"] = CREATED
    return path


# the serial as a number too: MAT and C3D store numbers in binary
SERIAL_BINARY = tuple(struct.pack(f, SERIAL) for f in ("<d", "<f", "<q", "<i"))


def _traces(data: bytes) -> list[str]:
    """Which secrets appear in these bytes, as UTF-8/ASCII, UTF-16 (MATLAB char arrays) or,
    for the serial, a binary number."""
    found = []
    for s in SECRETS:
        if s.encode() in data or s.encode("utf-16-le") in data:
            found.append(s)
    if str(SERIAL) not in found and any(b in data for b in SERIAL_BINARY):
        found.append(str(SERIAL))
    return found


def _export(session: Path, where: Path, fmt: str, *extra: str) -> list[Path]:
    """What the export made beside the session: its files, or its folder (BIDS)."""
    where.mkdir()
    src = where / session.name
    shutil.copyfile(session, src)
    before = set(where.iterdir())
    assert main(["export", str(src), "--format", fmt, "-q", *extra]) == 0
    return sorted(set(where.iterdir()) - before)


def _files(outs: list[Path]) -> list[Path]:
    """Every file written: the outputs, and everything inside an output folder."""
    return sorted(f for p in outs for f in ([p] if p.is_file() else p.rglob("*")) if f.is_file())


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_a_deidentified_export_holds_no_identifier_in_any_byte(session, tmp_path, fmt):
    outs = _export(session, tmp_path / "d", fmt, "--deidentify")
    assert outs
    for p in outs:
        assert PATIENT not in p.name and "walk" not in p.name, p.name  # default names too
        assert p.name.startswith("deidentified-")
    files = _files(outs)
    assert len(files) >= len(outs)
    for f in files:
        name = str(f.relative_to(tmp_path / "d")).encode()
        assert _traces(f.read_bytes()) == [] and _traces(name) == [], (f, _traces(f.read_bytes()))


# BIDS writes the patient id only when asked (--subject-from-patient-id), de-identified or not
FORMAT_NOT_DEIDENTIFIED = {"bids": ("--no-deidentify", "--subject-from-patient-id")}


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_the_search_finds_them_when_not_deidentified(session, tmp_path, fmt):
    """The same search over a normal export finds the secrets: the test above is not blind."""
    outs = _export(session, tmp_path / "n", fmt, *FORMAT_NOT_DEIDENTIFIED.get(fmt, ()))
    found = set()
    for f in _files(outs):
        found.update(_traces(f.read_bytes()))
    assert PATIENT in found and str(SERIAL) in found and "2019-03-14" in found, found
    assert any(p.name.startswith(f"{PATIENT}_walk") for p in outs)


def test_deidentified_times_count_from_the_recordings_start(session, tmp_path):
    outs = _export(session, tmp_path / "t", "csv", "--deidentify")
    meta = json.loads(next(p for p in outs if p.name.endswith(".meta.json")).read_text())
    assert meta["deidentified"] is True
    assert "created_utc" not in meta["root"] and meta["wall_offset_s"] is None
    assert "serial" not in meta["device"] and "transport" not in meta["device"]
    csv = next(p for p in outs if p.suffix == ".csv")
    header, first = csv.read_text().splitlines()[:2]
    col = header.split(",").index("host_time_s")
    assert float(first.split(",")[col]) == 0.0  # shifted: the host clock says nothing either


def test_a_deidentified_report_holds_no_identifier(session, tmp_path, qapp):
    # qapp: the report draws with Qt; pytest-qt's QApplication, so later Qt tests find one
    pdf = tmp_path / "r.pdf"
    assert main(["report", str(session), "-o", str(pdf), "--deidentify", "-q"]) == 0
    assert _traces(pdf.read_bytes()) == []
    if shutil.which("pdftotext"):  # the page's text is compressed in the PDF: read it out
        text = subprocess.run(["pdftotext", str(pdf), "-"], capture_output=True, text=True,
                              timeout=60).stdout  # fmt: skip
        assert "Gait" in text or "gait" in text  # the text was read
        assert [s for s in SECRETS if s in text] == [], text
        plain = tmp_path / "plain.pdf"
        assert main(["report", str(session), "-o", str(plain), "-q"]) == 0
        text = subprocess.run(["pdftotext", str(plain), "-"], capture_output=True, text=True,
                              timeout=60).stdout  # fmt: skip
        assert PATIENT in text and "2019-03-14" in text  # the search can see them


# -- the journal -------------------------------------------------------------------------------

CRASH = textwrap.dedent(
    """
    import os, sys
    import numpy as np
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim.sensors import simulate

    counts = simulate(2000).counts
    meta = SessionMeta(patient_id=sys.argv[2], operator=sys.argv[3], notes=sys.argv[4])
    w = SessionWriter(sys.argv[1], SessionHeader("raw", meta=meta))
    pipe = Pipeline()
    for i in range(0, 2000, 10):
        blk = SampleBlock(FrameKind.RAW, np.arange(i, i + 10), np.zeros(10), 0.0,
                          adc=counts[i:i + 10])
        w.append(blk, pipe.process(counts[i:i + 10]))
    w.add_marker("turn")
    os._exit(0)  # a crash: no close, the journal stays
    """
)


def _crash(path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    r = subprocess.run([sys.executable, "-c", CRASH, str(path), PATIENT, OPERATOR, NOTES],
                       capture_output=True, text=True, timeout=120, env=env)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert journal_path(path).exists()


def test_a_crash_journal_holds_no_identity_and_recovery_restores_it(tmp_path):
    path = tmp_path / "crashed.h5"
    _crash(path)
    assert _traces(journal_path(path).read_bytes()) == []
    with open_session(path) as s:
        assert s.recovered and s.n_samples == 2000
        assert (s.meta.patient_id, s.meta.operator, s.meta.notes) == (PATIENT, OPERATOR, NOTES)
        assert [m.label for m in s.markers] == ["turn"]
    assert not journal_path(path).exists()


def test_recovery_without_a_readable_header_keeps_the_data_and_says_what_is_lost(tmp_path):
    path = tmp_path / "crashed.h5"
    _crash(path)
    path.write_bytes(b"")  # the file's header is lost; the journal alone remains
    with open_session(path) as s:
        assert s.recovered and s.n_samples == 2000
        assert s.meta.patient_id == "" and "lost" in s.meta.notes
