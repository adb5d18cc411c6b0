"""De-identification details (issue 26, item 5): gaitmon's own words are never rewritten,
the re-identification key is private from its creation, a de-identified export does not say
when it was made, and two patient ids that make one BIDS subject label are refused."""

from __future__ import annotations

import csv
import datetime as dt
import hashlib
import io
import json
import os
import shutil
import stat
import time
from pathlib import Path

import h5py
import pytest

from gaitmon.batch import run_batch
from gaitmon.cli import main
from gaitmon.finish import reprocess


def read_csv(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text(encoding="utf-8"))))


# -- (a) gaitmon's own words -------------------------------------------------------------------


@pytest.fixture(scope="module")
def common_word_study(tmp_path_factory, record_simulated) -> Path:
    """A one-leg session and a two-leg session named "both.h5" whose patient is "both"."""
    root = tmp_path_factory.mktemp("words")
    record_simulated(root / "a.h5", "--patient", "legs", duration_s=8)
    assert main(["record", "--simulate-bilateral", "--duration", "8", "--speed", "8", "-o",
                 str(root / "both.h5"), "--patient", "both", "-q"]) == 0  # fmt: skip
    return root


def test_a_deidentified_batch_does_not_rewrite_its_own_message(common_word_study, tmp_path,
                                                               capsys):  # fmt: skip
    """The file "both.h5" of patient "both" was skipped as "a session of S0002 legs"."""
    out = tmp_path / "out"
    # --jobs 1: what is shared is made the same with a pool (test_batch); no 2 spawned workers
    assert main(["batch", str(common_word_study), "-o", str(out), "--deidentify", "--jobs",
                 "1", "-q"]) == 0  # fmt: skip
    rows = {r["session"]: r for r in read_csv(out / "summary.csv")}
    assert rows["S0002"]["status"] == "skipped"
    assert rows["S0002"]["reason"].startswith("a session of both legs: gaitmon batch"), rows
    assert "a session of both legs" in capsys.readouterr().err
    # ... and the file name and patient id are still gone from what is shared
    text = (out / "summary.csv").read_text()
    assert "both.h5" not in text and "a.h5" not in text


def test_a_damaged_files_name_still_becomes_its_label(tmp_path, record_simulated):
    """A message quoting the file's path names the session by its label, and a patient id
    in a quoted path is removed."""
    root = tmp_path / "study" / "PAT9"
    root.mkdir(parents=True)
    (root / "PAT9_walk.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 600)
    record_simulated(root / "ok.h5", "--patient", "PAT9", duration_s=8)
    result = run_batch(tmp_path / "study", tmp_path / "out", deidentify=True)
    assert [o.status for o in result.outcomes] == ["damaged", "ok"]
    text = (tmp_path / "out" / "summary.csv").read_text()
    assert "PAT9" not in text and "walk" not in text
    assert "S0001" in read_csv(tmp_path / "out" / "summary.csv")[0]["reason"]


def test_a_deidentified_export_keeps_gaitmons_words(tmp_path, record_simulated):
    """A patient id that is also one of gaitmon's words ("raw") is removed from a file name
    that gaitmon's stop reason quotes, but the file's mode stays "raw", in the metadata and
    in the words of that stop reason."""
    path = record_simulated(tmp_path / "s.h5", "--patient", "raw", duration_s=8)
    with h5py.File(path, "r+") as f:
        f.attrs["stop_reason"] = "imported from /data/raw/raw_walk.xdf (raw mode)"
    out = tmp_path / "d.csv"
    assert main(["export", str(path), "--format", "csv", "--deidentify", "-o", str(out),
                 "-q"]) == 0  # fmt: skip
    meta = json.loads(out.with_suffix(".meta.json").read_text())
    assert meta["root"]["mode"] == "raw" and meta["mode"] == "raw"
    assert meta["root"]["stop_reason"] == (
        "imported from /data/[removed]/[removed]_walk.xdf (raw mode)"
    )
    assert meta["session"]["patient_id"] == ""


# -- (b) the key folder is private from its creation -----------------------------------------


def _modes(top: Path) -> dict[str, int]:
    return {str(p.relative_to(top.parent)): stat.S_IMODE(p.stat().st_mode)
            for p in [top, *top.rglob("*")]}  # fmt: skip


def test_the_key_folder_is_0700_and_its_files_0600(common_word_study, tmp_path):
    """The key (patient ids) was made 0755/0644 under the usual umask 022; the records, the
    key and the work files are its owner's only, also when a rerun adds to it."""
    old = os.umask(0o022)
    try:
        out = tmp_path / "shared"
        result = run_batch(common_word_study, out, deidentify=True)
        assert result.key is not None
        modes = _modes(result.key)
        assert any(k.endswith("key.csv") for k in modes) and len(modes) >= 4, modes
        bad = {k: oct(m) for k, m in modes.items()
               if m != (0o700 if (result.key.parent / k).is_dir() else 0o600)}  # fmt: skip
        assert bad == {}
        # a work file is 0600 while it is written (the copy of the identified session)
        seen: list[int] = []
        real_copy = reprocess._copy

        def spy(src: Path, tmp: Path, *a: object) -> None:
            seen.append(stat.S_IMODE(tmp.stat().st_mode))
            real_copy(src, tmp, *a)  # type: ignore[arg-type]

        reprocess._copy = spy  # type: ignore[assignment]
        try:
            shutil.rmtree(result.key / "records")
            run_batch(common_word_study, out, deidentify=True)
        finally:
            reprocess._copy = real_copy  # type: ignore[assignment]
        assert seen and set(seen) == {0o600}, seen
        assert set(_modes(result.key).values()) <= {0o700, 0o600}
    finally:
        os.umask(old)


# -- (c) a de-identified export does not say when it was made ---------------------------------


def _today_forms() -> list[bytes]:
    """Today's date as the formats write it: ISO, PDF (D:YYYYMMDD), asctime (MAT header)."""
    now = dt.datetime.now(dt.UTC)
    local = dt.datetime.now()
    forms = {now.strftime("%Y-%m-%d"), "D:" + now.strftime("%Y%m%d"), local.strftime("%Y-%m-%d"),
             "D:" + local.strftime("%Y%m%d"), time.asctime()[:10]}  # fmt: skip
    return [f.encode() for f in forms]


@pytest.fixture(scope="module")
def dated_session(tmp_path_factory, record_simulated) -> Path:
    d = tmp_path_factory.mktemp("dated")
    return record_simulated(d / "s.h5", "--patient", "PDATE", duration_s=15)


@pytest.mark.parametrize("fmt", ["mat", "csv"])
def test_a_deidentified_export_holds_no_export_date(dated_session, tmp_path, fmt):
    """The MAT header said "Created on: <now>"; the CSV side file "exported_utc"."""
    out = tmp_path / f"d.{fmt}"
    assert main(["export", str(dated_session), "--format", fmt, "--deidentify", "-o", str(out),
                 "-q"]) == 0  # fmt: skip
    for f in tmp_path.iterdir():
        data = f.read_bytes()
        assert [d for d in _today_forms() if d in data] == [], f
    if fmt == "mat":
        head = out.read_bytes()[:128]
        assert head.startswith(b"MATLAB 5.0 MAT-file") and b"Created on" not in head
        from scipy.io import loadmat

        assert loadmat(out)["session"].dtype.names  # still a MAT file scipy reads
    else:
        meta = json.loads(out.with_suffix(".meta.json").read_text())
        assert meta["deidentified"] is True and "exported_utc" not in meta
    # not de-identified: the date is there (the search is not blind)
    plain = tmp_path / f"n.{fmt}"
    assert main(["export", str(dated_session), "--format", fmt, "-o", str(plain), "-q"]) == 0
    found = b"".join(p.read_bytes() for p in tmp_path.glob("n.*"))
    assert any(d in found for d in _today_forms())


def test_a_deidentified_report_pdf_holds_no_date(dated_session, tmp_path, qapp):
    """QPdfWriter stamps CreationDate, ModDate and XMP dates; the footer said "report <now>"."""
    import subprocess

    pdf = tmp_path / "r.pdf"
    assert main(["report", str(dated_session), "-o", str(pdf), "--deidentify", "-q"]) == 0
    data = pdf.read_bytes()
    assert [d for d in _today_forms() if d in data] == []
    text = subprocess.run(["pdftotext", str(pdf), "-"], capture_output=True, text=True,
                          check=True).stdout  # fmt: skip
    assert [d for d in _today_forms() if d.decode() in text] == [] and "Gait analysis" in text
    info = subprocess.run(["pdfinfo", str(pdf)], capture_output=True, text=True, check=True)
    assert "CreationDate" not in info.stdout and info.stderr == ""  # (a sound PDF: no errors)
    plain = tmp_path / "n.pdf"
    assert main(["report", str(dated_session), "-o", str(plain), "-q"]) == 0
    assert any(d in plain.read_bytes() for d in _today_forms())


# -- (d) two patient ids, one BIDS subject -----------------------------------------------------


def _with_patient(src: Path, dst: Path, pid: str, unit: str = "") -> Path:
    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+") as f:
        for g in ([f"units/{s}/session" for s in ("L", "R")] if unit else ["session"]):
            f[g].attrs["patient_id"] = pid
    return dst


def _bids(path: Path, out: Path, *extra: str) -> int:
    return main(["export", str(path), "--format", "bids", "-o", str(out),
                 "--subject-from-patient-id", "-q", *extra])  # fmt: skip


def test_two_patient_ids_that_make_one_subject_are_refused(dated_session, tmp_path, capsys):
    """'a/b' and 'a-b' both became sub-ab: with --session 01/02 two patients silently became
    one subject. The second is refused in one line naming the subject and its id; the same
    patient's second session is still welcome."""
    ab = _with_patient(dated_session, tmp_path / "ab.h5", "a/b")
    other = _with_patient(dated_session, tmp_path / "other.h5", "a-b")
    out = tmp_path / "bids"
    assert _bids(ab, out, "--session", "01") == 0
    capsys.readouterr()
    assert _bids(other, out, "--session", "02") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "sub-ab" in err and "'a-b'" in err, err
    assert "Traceback" not in err
    assert not (out / "sub-ab" / "ses-02").exists()  # nothing of the other patient was written
    participants = read_tsv(out / "participants.tsv")
    assert [r["participant_id"] for r in participants] == ["sub-ab"]
    # the same patient again: a second session of the same subject
    again = _with_patient(dated_session, tmp_path / "again.h5", "a/b")
    assert _bids(again, out, "--session", "02") == 0
    assert (out / "sub-ab" / "ses-02").is_dir()
    # the label a user gives is theirs: --subject ab is not second-guessed
    assert main(["export", str(other), "--format", "bids", "-o", str(out), "--subject", "ab",
                 "--session", "03", "-q"]) == 0  # fmt: skip


def read_tsv(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text(encoding="utf-8")), delimiter="\t"))


def test_a_two_leg_export_is_checked_too(common_word_study, dated_session, tmp_path, capsys):
    out = tmp_path / "bids"
    assert _bids(_with_patient(dated_session, tmp_path / "one.h5", "x.y"), out) == 0
    both = _with_patient(common_word_study / "both.h5", tmp_path / "both.h5", "x_y", unit="LR")
    capsys.readouterr()
    assert _bids(both, out, "--session", "02") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "sub-xy" in err and "'x_y'" in err, err
    assert _bids(_with_patient(both, tmp_path / "same.h5", "x.y", unit="LR"), out,
                 "--session", "02") == 0  # fmt: skip
    rows = read_tsv(out / "participants.tsv")
    assert len(rows) == 1 and rows[0]["patient_id_sha256"] == hashlib.sha256(b"x.y").hexdigest()
