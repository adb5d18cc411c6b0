"""A BIDS dataset holding one-leg and two-leg recordings, checked against the BIDS schema's own
rules for sidecars and columns (bidsschematools, via tests/bids_schema_check.py), not only
its file names; the checker is shown to find what the old export wrote (``component`` n/a,
custom ``Gaitmon*`` keys, ``MISCChannelCount``); the effective sampling rate is checked
against a clock of known error; Authors and License only ever come from the user.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from test_export import FS, write_session

from gaitmon.cli import main

pytest.importorskip("bidsschematools")
pytest.importorskip("bids_validator")

from bids_schema_check import check_dataset

# RECOMMENDED fields gaitmon cannot know or leaves out on purpose, each with its reason
ALLOWED_MISSING = frozenset({
    "DeviceSerialNumber",  # de-identified exports leave the serial out
    "InstitutionName", "InstitutionAddress", "InstitutionalDepartmentName",  # not recorded
    "Instructions",  # what the patient was told is not recorded
    "HEDVersion",  # no HED tags
    "SourceDatasets",  # the source data are gaitmon session files, not a dataset
})  # fmt: skip


def _export(src: Path, out: Path, *extra: str) -> int:
    return main(["export", str(src), "--format", "bids", "-o", str(out), "-q", *extra])


@pytest.fixture(scope="module")
def both(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bids_both") / "both.h5"
    assert main(["record", "--simulate-bilateral", "--duration", "6", "--speed", "4", "-q",
                 "--standing-s", "1.5", "-o", str(out)]) == 0  # fmt: skip
    return out


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory, both: Path) -> Path:
    """One leg (right, de-identified), both legs, and one leg with a session level, not
    de-identified (serial and scans.tsv): one dataset."""
    work = tmp_path_factory.mktemp("bids_mixed")
    one = work / "one.h5"
    write_session(one, "raw", side="R")
    out = work / "study"
    assert _export(one, out, "--subject", "01", "--bids-authors", "Ann Lee; Bo Chen",
                   "--bids-license", "CC0") == 0  # fmt: skip
    assert _export(both, out, "--subject", "02") == 0
    assert _export(one, out, "--subject", "03", "--session", "pre", "--no-deidentify") == 0
    return out


def test_one_and_two_leg_recordings_in_one_dataset_meet_the_schema(dataset: Path) -> None:
    errors = check_dataset(dataset, ALLOWED_MISSING)
    assert errors == []
    # every kind of file was checked
    names = [p.name for p in dataset.rglob("*") if p.is_file()]
    for suffix in ("_motion.json", "_channels.tsv", "_channels.json", "_events.tsv"):
        assert sum(n.endswith(suffix) for n in names) >= 3, suffix


def test_one_unit_is_named_alike_in_one_and_two_leg_recordings(dataset: Path) -> None:
    systems = {p.name.split("_tracksys-")[1].split("_")[0]
               for p in dataset.rglob("*_motion.tsv")}  # fmt: skip
    assert systems == {"imuL", "imuR"}
    one = {p.name.replace("sub-01", "") for p in (dataset / "sub-01" / "motion").iterdir()}
    two = {p.name.replace("sub-02", "") for p in (dataset / "sub-02" / "motion").iterdir()}
    # the right leg's unit is the same set of files in both; the two-leg one adds the left's
    assert one < two and {n for n in two - one} == {n.replace("imuR", "imuL") for n in one
                                                    if "imuR" in n}  # fmt: skip
    for sub in ("sub-01", "sub-02"):
        for motion_json in (dataset / sub / "motion").glob("*_motion.json"):
            side = json.loads(motion_json.read_text(encoding="utf-8"))
            assert f"tracksys-{side['TrackingSystemName']}_" in motion_json.name
            assert not [k for k in side if k.startswith("Gaitmon")]
            own = json.loads(motion_json.with_name(motion_json.name.replace(
                "_motion.json", "_gaitmon.json")).read_text(encoding="utf-8"))
            assert own["mode"] == "raw" and own["angles"]["method"]
    assert "*_gaitmon.json" in (dataset / ".bidsignore").read_text().splitlines()


def test_the_readme_describes_every_kind_of_recording(dataset: Path, tmp_path: Path,
                                                      both: Path) -> None:
    text = (dataset / "README").read_text(encoding="utf-8")
    assert "Recordings of one leg" in text and "Recordings of both legs" in text
    # a dataset of one kind says only that kind; a later export of the other adds it
    one = tmp_path / "one.h5"
    write_session(one, "raw", side="L")
    out = tmp_path / "d"
    assert _export(one, out, "--subject", "01") == 0
    text = (out / "README").read_text(encoding="utf-8")
    assert "Recordings of one leg" in text and "Recordings of both legs" not in text
    assert _export(both, out, "--subject", "02") == 0
    assert "Recordings of both legs" in (out / "README").read_text(encoding="utf-8")


def test_authors_and_license_come_only_from_the_user(dataset: Path, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    desc = json.loads((dataset / "dataset_description.json").read_text(encoding="utf-8"))
    assert desc["Authors"] == ["Ann Lee", "Bo Chen"] and desc["License"] == "CC0"
    src = tmp_path / "s.h5"
    write_session(src, "raw")
    out = tmp_path / "d"
    capsys.readouterr()
    assert main(["export", str(src), "--format", "bids", "-o", str(out)]) == 0
    desc = json.loads((out / "dataset_description.json").read_text(encoding="utf-8"))
    assert "Authors" not in desc and "License" not in desc  # never invented
    hint = [x for x in capsys.readouterr().err.splitlines() if "Authors" in x]
    assert len(hint) == 1 and "--bids-authors" in hint[0]
    # the schema's checker reports what is missing, so the hint is about something real
    assert {e for e in check_dataset(out, ALLOWED_MISSING)} == {
        "dataset_description.json: recommended License missing",
        "dataset_description.json: recommended Authors missing"}


def test_the_checker_finds_what_the_old_export_wrote(dataset: Path, tmp_path: Path) -> None:
    """The checker is not a rubber stamp: the old export's faults, put back, are errors."""
    bad = tmp_path / "bad"
    shutil.copytree(dataset, bad)
    folder = bad / "sub-01" / "motion"
    side_path = folder / "sub-01_task-walk_tracksys-imuR_motion.json"
    side = json.loads(side_path.read_text(encoding="utf-8"))
    side["MISCChannelCount"] = side.pop("MiscChannelCount")
    side["GaitmonMode"] = "raw"
    side_path.write_text(json.dumps(side), encoding="utf-8")
    chans = folder / "sub-01_task-walk_tracksys-imuR_channels.tsv"
    lines = chans.read_text(encoding="utf-8").splitlines()
    lines = [ln.replace("\tz\tMISC\t", "\tn/a\tMISC\t") for ln in lines]
    chans.write_text("\n".join(lines) + "\n", encoding="utf-8")
    errors = check_dataset(bad, ALLOWED_MISSING)
    assert any("MISCChannelCount is deprecated" in e for e in errors)
    assert any("recommended MiscChannelCount missing" in e for e in errors)
    assert any("GaitmonMode is not a BIDS metadata field" in e for e in errors)
    assert sum("component 'n/a'" in e for e in errors) == 2  # heel and toe


def test_the_effective_rate_is_measured_from_the_receive_times(tmp_path: Path) -> None:
    """A unit whose clock runs 0.1 % slow against the computer's (and a lost stretch): its
    frames arrive at FS / 1.001 per host second; receive times jitter by up to 0.1 ms."""
    src = tmp_path / "s.h5"
    write_session(src, "raw", side="R")
    with h5py.File(src, "r+") as h:
        t = h["timeline/t_s"][:]
        jitter = np.random.default_rng(3).uniform(0, 1e-4, len(t))
        h["timeline/host_time_s"][...] = 5000.0 + t * 1.001 + jitter
    out = tmp_path / "d"
    assert _export(src, out) == 0
    side = json.loads((out / "sub-01" / "motion" / "sub-01_task-walk_tracksys-imuR_motion.json")
                      .read_text(encoding="utf-8"))  # fmt: skip
    assert side["SamplingFrequency"] == FS
    assert side["SamplingFrequencyEffective"] == pytest.approx(FS / 1.001, abs=1e-3)
    assert abs(side["SamplingFrequencyEffective"] - FS) > 0.05  # measured, not the nominal
