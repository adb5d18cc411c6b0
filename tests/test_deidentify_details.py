"""De-identification details (issue 26, item 5): gaitmon's own words are never rewritten,
the re-identification key is private from its creation, a de-identified export does not say
when it was made, and two patient ids that make one BIDS subject label are refused."""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import stat
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
    assert main(["batch", str(common_word_study), "-o", str(out), "--deidentify", "-q"]) == 0
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
