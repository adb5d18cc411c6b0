"""gaitmon export --format bids: the Motion-BIDS layout checked against the specification.

The official bids-validator (a Deno tool) is not used. Where the Python ``bids-validator``
package is installed (it brings ``bidsschematools``, the BIDS schema as data), two tests also
check every file name with it and the files against the schema's own tables; they are skipped
without it. The other tests check what the validator would: the layout and
file names (entity order of the BIDS schema, rules/entities.yaml), the TSV headers and the
JSON fields against the tables of the BIDS 1.9 motion page (channel types, components,
required sidecar fields, TrackSysParity: TrackingSystemName == the tracksys entity), and the
data themselves: every cell of _motion.tsv against the session's series (the fixture's own
arrays, or the session reader's for a real recording), n/a rows where frames were lost,
event onsets = their row / fs. The de-identification of every byte is in test_deidentify.py.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
from test_export import FS, LOST_AT, N_LOST, OPERATOR, PATIENT, write_session

from gaitmon import export as ex
from gaitmon.cli import main

# BIDS schema rules/entities.yaml: the order entities appear in a file name (the ones used here)
ENTITY_ORDER = ("sub", "ses", "task", "tracksys", "acq", "run")
# motion.md, "Restricted keyword list for channel type" / "... for channel component"
CHANNEL_TYPES = {"ACCEL", "ANGACCEL", "GYRO", "JNTANG", "LATENCY", "MAGN", "MISC", "ORNT", "POS",
                 "VEL"}  # fmt: skip
COMPONENTS = {"x", "y", "z", "quat_x", "quat_y", "quat_z", "quat_w"}  # (the schema: no n/a)
AXIAL_TYPES = {"ACCEL", "ANGACCEL", "GYRO", "MAGN", "POS", "VEL", "ORNT"}  # component MUST be set
# rules/tabular_data/motion.yaml: initial columns in this order; others must be defined ones
CHANNELS_INITIAL = ["name", "component", "type", "tracked_point", "units"]
CHANNELS_DEFINED = {"placement", "reference_frame", "description", "sampling_frequency",
                    "status", "status_description"}  # fmt: skip
STATUS = {"good", "bad", "n/a"}
# rules/sidecars/motion.yaml
SIDECAR_REQUIRED = ("SamplingFrequency", "TrackingSystemName", "TaskName")
LABEL = re.compile(r"[0-9A-Za-z]+")
DECIMALS = {"m/s^2": 5, "rad/s": 6, "deg": 4, "arbitrary": 3}  # docs/file-format.md, CSV


def _pct(v: float, decimals: int) -> str:
    """The reference text of a value: Python's ``%``, as the CSV export promises too."""
    return f"%.{decimals}f" % float(v)


def _export(src: Path, out: Path, *extra: str) -> int:
    return main(["export", str(src), "--format", "bids", "-o", str(out), "-q", *extra])


def _entities(name: str) -> tuple[list[tuple[str, str]], str]:
    stem, _, suffix = name.rpartition("_")
    return [tuple(kv.split("-", 1)) for kv in stem.split("_")], suffix  # type: ignore[misc]


def _tsv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def _header(path: Path) -> list[str]:
    return path.read_text(encoding="utf-8").splitlines()[0].split("\t")


def _motion_rows(path: Path) -> list[list[str]]:
    text = path.read_text(encoding="utf-8")
    assert text.endswith("\n") and "\r" not in text
    return [line.split("\t") for line in text.splitlines()]


@pytest.fixture
def raw(tmp_path) -> tuple[Path, dict[str, np.ndarray]]:
    src = tmp_path / "walk.h5"
    return src, write_session(src, "raw")


def _recording(root: Path, sub: str, ses: str | None = None,
               system: str = "imuR", task: str = "walk") -> dict[str, Path]:
    """A one-leg recording's files; the tracking system is the unit, by its leg (the
    fixture's is the right one; ``imu`` for a recording with no side)."""
    folder = root / f"sub-{sub}" / (f"ses-{ses}" if ses else "") / "motion"
    stem = f"sub-{sub}" + (f"_ses-{ses}" if ses else "") + f"_task-{task}"
    unit = {k: folder / f"{stem}_tracksys-{system}_{k}" for k in (
        "motion.tsv", "channels.tsv", "channels.json", "motion.json", "gaitmon.json")}
    return {**unit, **{k: folder / f"{stem}_{k}" for k in ("events.tsv", "events.json")}}


# ---- layout ----------------------------------------------------------------------------------


def test_the_layout_and_file_names_follow_the_bids_templates(raw, tmp_path):
    src, _ = raw
    out = tmp_path / "study"
    assert _export(src, out, "--subject", "07", "--session", "pre") == 0
    got = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())
    want = sorted(["README", "dataset_description.json", "participants.tsv", ".bidsignore",
                   *(str(p.relative_to(out)) for p in _recording(out, "07", "pre").values())])
    assert got == want
    for p in (out / "sub-07" / "ses-pre" / "motion").iterdir():
        ents, suffix = _entities(p.name)
        keys = [k for k, _ in ents]
        assert keys == sorted(keys, key=ENTITY_ORDER.index), p.name  # schema order
        assert keys[:3] == ["sub", "ses", "task"]  # required entities
        assert ("tracksys" in keys) == (suffix not in {"events.tsv", "events.json"})
        assert all(LABEL.fullmatch(v) for _, v in ents), p.name
        assert suffix in {"motion.tsv", "motion.json", "channels.tsv", "channels.json",
                          "gaitmon.json", "events.tsv", "events.json"}  # fmt: skip
        # the folders repeat the file's subject and session
        assert dict(ents)["sub"] == p.parents[2].name[4:] and dict(ents)["ses"] == "pre"


def test_no_session_level_without_a_session_label(raw, tmp_path):
    src, _ = raw
    assert _export(src, tmp_path / "d", "--subject", "3") == 0
    for p in _recording(tmp_path / "d", "3").values():
        assert p.is_file(), p


# ---- _channels.tsv and _motion.json against the spec tables -----------------------------------


def test_channels_tsv_and_motion_json_follow_the_spec(raw, tmp_path):
    src, _ = raw
    out = tmp_path / "d"
    assert _export(src, out, "--subject", "07", "--task", "gait") == 0
    files = _recording(out, "07", task="gait")
    head = _header(files["channels.tsv"])
    assert head[:5] == CHANNELS_INITIAL
    assert set(head[5:]) <= CHANNELS_DEFINED  # additional columns: only defined ones
    chans = _tsv(files["channels.tsv"])
    names = [c["name"] for c in chans]
    assert len(set(names)) == len(names)
    for c in chans:
        assert c["type"] in CHANNEL_TYPES and c["component"] in COMPONENTS, c
        assert c["placement"] and c["reference_frame"] in json.loads(
            files["channels.json"].read_text())["reference_frame"]["Levels"]
        if c["type"] in AXIAL_TYPES:
            assert c["component"] in {"x", "y", "z"}, c
        assert c["status"] in STATUS and c["tracked_point"] and c["units"]
        assert float(c["sampling_frequency"]) == FS
    by_type = {t: [c for c in chans if c["type"] == t] for t in CHANNEL_TYPES}
    assert len(by_type["ACCEL"]) == 8 and {c["units"] for c in by_type["ACCEL"]} == {"m/s^2"}
    assert len(by_type["GYRO"]) == 4 and {c["units"] for c in by_type["GYRO"]} == {"rad/s"}
    assert len(by_type["ORNT"]) == 4 and {c["units"] for c in by_type["ORNT"]} == {"deg"}
    assert [c["name"] for c in by_type["JNTANG"]] == ["hip_flexion", "knee_flexion",
                                                      "ankle_dorsiflexion"]  # fmt: skip
    assert [c["name"] for c in by_type["MISC"]] == ["heel_fsr", "toe_fsr"]
    assert {c["tracked_point"] for c in by_type["GYRO"]} == {"Body", "RightThigh", "RightShank",
                                                             "RightFoot"}  # fmt: skip
    # the motion file has one column per row of channels.tsv (MUST)
    rows = _motion_rows(files["motion.tsv"])
    assert {len(r) for r in rows} == {len(chans)}

    side = json.loads(files["motion.json"].read_text(encoding="utf-8"))
    for key in SIDECAR_REQUIRED:
        assert key in side, key
    assert side["TrackingSystemName"] == "imuR" == dict(_entities(files["motion.json"].name)[0])[
        "tracksys"]  # TrackSysParity
    assert side["TaskName"] == "gait" and side["SamplingFrequency"] == FS
    assert side["MotionChannelCount"] == len(chans)
    for t in ("ACCEL", "GYRO", "ORNT", "JNTANG"):
        assert side[f"{t}ChannelCount"] == len(by_type[t]), t
    assert side["MiscChannelCount"] == len(by_type["MISC"]) and "MISCChannelCount" not in side
    assert side["Manufacturer"] == "gaitmon"
    assert side["RecordingDuration"] == pytest.approx(len(rows) / FS)
    assert side["MissingValues"] == "n/a"
    own = json.loads(files["gaitmon.json"].read_text(encoding="utf-8"))  # gaitmon's own keys
    assert own["angles"]["source"] == "smoothed" and own["angles"]["method"]
    assert "DeviceSerialNumber" not in side  # de-identified by default
    assert "5 lost frames" in side["SubjectArtefactDescription"]


# ---- the BIDS tools' own rules (when installed: bids-validator, which brings bidsschematools) ---


def _study_with_every_kind_of_file(src: Path, out: Path) -> list[str]:
    """A dataset with a session level, a subject without one and a dated scan (not
    de-identified): every kind of file the export writes; their dataset paths ("/sub-...")."""
    assert _export(src, out, "--subject", "07", "--session", "pre") == 0
    assert _export(src, out, "--subject", "08") == 0
    assert _export(src, out, "--subject", "09", "--session", "post", "--no-deidentify") == 0
    return sorted("/" + p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())


def test_every_file_name_passes_the_python_bids_validator(raw, tmp_path):
    """bids_validator.BIDSValidator checks a path against the BIDS schema's file rules
    (bidsschematools): entities, their order, the datatype folder, suffix and extension."""
    bids_validator = pytest.importorskip("bids_validator")
    src, _ = raw
    paths = _study_with_every_kind_of_file(src, tmp_path / "study")
    assert "/sub-09/ses-post/sub-09_ses-post_scans.tsv" in paths and len(paths) == 26
    validator = bids_validator.BIDSValidator()
    # gaitmon's own metadata files (and .bidsignore itself) are what .bidsignore hides
    hidden = [p for p in paths if p.endswith("_gaitmon.json") or p == "/.bidsignore"]
    assert len(hidden) == 4
    assert [p for p in paths if not validator.is_bids(p) and p not in hidden] == []
    # and it does refuse what BIDS forbids, so passing says something
    for bad in ("/sub-07/motion/sub-07_tracksys-imuR_task-walk_motion.tsv",  # entity order
                "/sub-07/motion/sub-08_task-walk_tracksys-imuR_motion.tsv",  # folder != file
                "/sub-07/motion/sub-07_task-walk_tracksys-imuR_motion.csv",
                "/sub-P-1/motion/sub-P-1_task-walk_tracksys-imuR_motion.tsv"):  # fmt: skip
        assert not validator.is_bids(bad), bad


def _schema_name(key: str) -> str:
    """A column's name from its schema key (``type__channels`` -> ``type``)."""
    return key.split("__")[0]


def test_the_motion_files_meet_the_bids_schema_tables(raw, tmp_path):
    """The machine-readable BIDS schema (bidsschematools; the validator's own rules) as the
    reference instead of this file's tables: required sidecar fields and their types, the
    channels.tsv columns (initial ones in order, every other one defined) and their allowed
    values, events.tsv's initial columns and sorted onsets."""
    schema = pytest.importorskip("bidsschematools.schema").load_schema()
    src, _ = raw
    out = tmp_path / "study"
    _study_with_every_kind_of_file(src, out)
    rules, objects = schema.rules, schema.objects
    chan_rule = rules.tabular_data.motion.motionChannels
    events_rule = rules.tabular_data.events.Events
    required_fields = {f for group in rules.sidecars.motion.values()
                       for f, level in group["fields"].items()
                       if (level if isinstance(level, str) else level["level"]) == "required"}
    assert {"SamplingFrequency", "TaskName"} <= required_fields  # (the schema read as meant)
    types = {"number": (int, float), "integer": (int,), "string": (str,)}
    for motion_json in out.rglob("*_motion.json"):
        side = json.loads(motion_json.read_text(encoding="utf-8"))
        assert required_fields <= set(side), motion_json.name
        for key, value in side.items():
            if key in objects.metadata and objects.metadata[key].get("type") in types:
                assert isinstance(value, types[objects.metadata[key]["type"]]), key
                assert value >= objects.metadata[key].get("minimum", value), key
    for channels_tsv in out.rglob("*_channels.tsv"):
        head = _header(channels_tsv)
        initial = [_schema_name(k) for k in chan_rule.initial_columns]
        assert head[: len(initial)] == initial
        required = [_schema_name(k) for k, lv in chan_rule.columns.items() if lv == "required"]
        assert set(required) <= set(head)
        assert set(head) <= {_schema_name(k) for k in chan_rule.columns}  # allowed_if_defined
        keys = {_schema_name(k): k for k in chan_rule.columns}
        rows = _tsv(channels_tsv)
        for column in head:
            definition = objects.columns[keys[column]]
            for row in rows:
                value = row[column]
                # n/a is every TSV column's missing value (and the spec's component table
                # lists it: "channels that have no corresponding spatial axis")
                if value != "n/a" and "enum" in definition:
                    assert value in definition["enum"], (column, value)
                if value != "n/a" and definition.get("type") == "number":
                    float(value)
        n_columns = {len(r) for r in _motion_rows(
            channels_tsv.with_name(channels_tsv.name.replace("_channels.tsv", "_motion.tsv")))}
        assert n_columns == {len(rows)}  # no header row: every row is data of every channel
    for events_tsv in out.rglob("*_events.tsv"):
        head = _header(events_tsv)
        assert head[:2] == list(events_rule.initial_columns) == ["onset", "duration"]
        onsets = [float(e["onset"]) for e in _tsv(events_tsv)]
        assert onsets == sorted(onsets) and min(onsets, default=0) >= -60


# ---- the values ------------------------------------------------------------------------------


def _grid(truth: dict[str, np.ndarray]) -> np.ndarray:
    """The fixture's true frame of each row: its sequence numbers count the lost frames."""
    seq = truth["timeline/seq"]
    return seq - seq[0]


def _expected(truth: dict[str, np.ndarray], angles: str) -> list[tuple[np.ndarray, int]]:
    """Columns of _motion.tsv in the documented order, from the arrays put in the file."""
    off = np.float32(7.0) if angles == "live" else np.float32(0.0)  # see write_session
    cols = []
    for i in range(4):
        cols += [(truth["processed/acc_ms2"][:, i, 0], 5), (truth["processed/acc_ms2"][:, i, 1], 5),
                 (truth["processed/gyro_rad_s"][:, i], 6)]  # fmt: skip
    cols += [(truth["processed/fsr_counts"][:, j], 3) for j in range(2)]
    cols += [(truth["processed/tilt_deg"][:, i] + off, 4) for i in range(4)]
    cols += [(truth["processed/joint_deg"][:, j] + off, 4) for j in range(3)]
    return cols


@pytest.mark.parametrize("angles", ["smoothed", "live"])
def test_every_cell_is_the_sessions_value_and_lost_frames_are_na_rows(raw, tmp_path, angles):
    src, truth = raw
    out = tmp_path / "d"
    assert _export(src, out, "--angles", angles) == 0
    rec = _recording(out, "01")
    rows = _motion_rows(rec["motion.tsv"])
    grid = _grid(truth)
    assert len(rows) == grid[-1] + 1 == len(grid) + N_LOST  # row k at k / fs
    lost = sorted(set(range(len(rows))) - set(grid.tolist()))
    assert lost == list(range(LOST_AT, LOST_AT + N_LOST))
    for k in lost:
        assert set(rows[k]) == {"n/a"}
    cols = _expected(truth, angles)
    units = [c["units"] for c in _tsv(rec["channels.tsv"])]
    for j, (values, decimals) in enumerate(cols):
        assert DECIMALS[units[j]] == decimals
        got = [rows[k][j] for k in grid.tolist()]
        want = [_pct(v, decimals) for v in values]
        assert got == want, j  # bit for bit to the printed decimals
    own = json.loads(rec["gaitmon.json"].read_text())
    assert own["angles"]["source"] == angles


def test_chunked_writing_gives_the_same_bytes(raw, tmp_path):
    src, _ = raw
    a = ex.export_session(src, "bids", tmp_path / "a", chunk_rows=7)
    b = ex.export_session(src, "bids", tmp_path / "b")
    assert [p.relative_to(tmp_path / "a") for p in a.paths] == [
        p.relative_to(tmp_path / "b") for p in b.paths]
    for p, q in zip(a.paths, b.paths, strict=True):
        if p.suffix == ".tsv":
            assert p.read_bytes() == q.read_bytes(), p.name


@pytest.mark.parametrize("mode", ["tilt", "joint"])
def test_unit_modes_export_the_angles_they_have(tmp_path, mode):
    src = tmp_path / "s.h5"
    truth = write_session(src, mode)
    assert _export(src, tmp_path / "d") == 0
    rec = _recording(tmp_path / "d", "01")
    types = [c["type"] for c in _tsv(rec["channels.tsv"])]
    assert types == (["ORNT"] * 4 if mode == "tilt" else []) + ["JNTANG"] * 3
    rows = _motion_rows(rec["motion.tsv"])
    grid = _grid(truth)
    joint = truth["processed/joint_deg"]
    for j in range(3):
        assert [rows[k][len(types) - 3 + j] for k in grid.tolist()] == [
            _pct(v, 4) for v in joint[:, j]]


def test_a_real_recording_with_lost_frames_matches_the_session_reader(tmp_path,
                                                                      record_simulated):
    from gaitmon.finish import open_session

    src = record_simulated(tmp_path / "lossy.h5", "--loss-pct", "3", duration_s=8)
    assert _export(src, tmp_path / "d") == 0
    rec = _recording(tmp_path / "d", "01", system="imu")  # no side entered
    rows = _motion_rows(rec["motion.tsv"])
    names = [c["name"] for c in _tsv(rec["channels.tsv"])]
    with open_session(src) as s:
        assert s.gaps, "the simulated link lost no frames"
        t = s.read("timeline/t_s")
        frame = np.rint((t - t[0]) * s.sample_rate_hz).astype(int)
        acc, gyro = s.read("processed/acc_ms2"), s.read("processed/gyro_rad_s")
        knee = s.read("processed/joint_deg")[:, 1]  # the smoothed angles (the default)
        n_lost = sum(g.n_lost for g in s.gaps if 0 < g.sample_idx < s.n_samples)
        hs = s.heel_strike_idx
    assert len(rows) == frame[-1] + 1 == len(frame) + n_lost
    assert sum(1 for r in rows if set(r) == {"n/a"}) == n_lost
    col = {n: i for i, n in enumerate(names)}
    assert [rows[k][col["shank_acc_z"]] for k in frame] == [_pct(v, 5) for v in acc[:, 2, 1]]
    assert [rows[k][col["foot_gyro_y"]] for k in frame] == [_pct(v, 6) for v in gyro[:, 3]]
    assert [rows[k][col["knee_flexion"]] for k in frame] == [_pct(v, 4) for v in knee]
    evs = _tsv(rec["events.tsv"])
    got_hs = [int(e["sample"]) for e in evs if e["trial_type"] == "heel_strike"]
    assert got_hs == frame[hs].tolist() and len(got_hs) >= 5
    for e in evs:
        if e["sample"] != "n/a":
            assert float(e["onset"]) == pytest.approx(int(e["sample"]) / FS, abs=1e-9)


# ---- events ----------------------------------------------------------------------------------


def test_events_are_dated_on_the_rows_of_the_motion_file(raw, tmp_path):
    src, truth = raw
    assert _export(src, tmp_path / "d") == 0
    rec = _recording(tmp_path / "d", "01")
    head = _header(rec["events.tsv"])
    assert head[:2] == ["onset", "duration"]  # REQUIRED, first
    sidecar = json.loads(rec["events.json"].read_text())
    assert set(head) <= set(sidecar)  # every column is described
    evs = _tsv(rec["events.tsv"])
    assert {e["trial_type"] for e in evs} <= set(sidecar["trial_type"]["Levels"])
    onsets = [float(e["onset"]) for e in evs]
    assert onsets == sorted(onsets)
    grid = _grid(truth)
    n = len(grid)
    kinds = {k: [int(e["sample"]) for e in evs if e["trial_type"] == k]
             for k in ("heel_strike", "toe_off", "marker", "gap")}  # fmt: skip
    assert kinds["heel_strike"] == grid[[0, 110, 210, 310, n - 1]].tolist()
    assert kinds["toe_off"] == grid[[70, 170, 299, 300]].tolist()
    assert kinds["marker"] == grid[[50, 150, 150]].tolist()
    assert kinds["gap"] == [LOST_AT]  # the first n/a row
    for e in evs:
        assert float(e["onset"]) == pytest.approx(int(e["sample"]) / FS, abs=1e-9)
    gap = next(e for e in evs if e["trial_type"] == "gap")
    assert float(gap["duration"]) == pytest.approx(N_LOST / FS) and gap["label"] == "frames lost"
    rows = _motion_rows(rec["motion.tsv"])
    k0, k1 = int(gap["sample"]), int(gap["sample"]) + round(float(gap["duration"]) * FS)
    assert all(set(r) == {"n/a"} for r in rows[k0:k1])
    assert set(rows[k0 - 1]) != {"n/a"} and set(rows[k1]) != {"n/a"}
    labels = [e["label"] for e in evs if e["trial_type"] == "marker"]
    assert labels == ["start walk", 'turn, "fast"', "asked [removed] to stop"]


# ---- dataset files, several recordings --------------------------------------------------------


def test_dataset_files_and_a_second_recording_in_the_same_folder(raw, tmp_path):
    src, _ = raw
    out = tmp_path / "study"
    out.mkdir()
    # a study's participants.tsv with its own column: kept, the new row gets n/a there
    (out / "participants.tsv").write_text("participant_id\tage\nsub-03\t54\n")
    assert _export(src, out, "--subject", "07") == 0
    assert _tsv(out / "participants.tsv") == [{"participant_id": "sub-03", "age": "54"},
                                              {"participant_id": "sub-07", "age": "n/a"}]
    (out / "participants.tsv").unlink()
    assert _export(src, out, "--subject", "07", "--force") == 0
    desc = json.loads((out / "dataset_description.json").read_text())
    assert desc["Name"] and desc["BIDSVersion"] == "1.9.0" and desc["DatasetType"] == "raw"
    assert "n/a" in (out / "README").read_text()
    (out / "README").write_text("our study\n")  # the dataset's own text is kept
    assert _export(src, out, "--subject", "08", "--session", "post") == 0
    assert (out / "README").read_text() == "our study\n"
    assert _header(out / "participants.tsv") == ["participant_id"]
    assert [r["participant_id"] for r in _tsv(out / "participants.tsv")] == ["sub-07", "sub-08"]
    assert _recording(out, "08", "post")["motion.tsv"].is_file()
    # the same recording again is refused, and allowed with --force
    assert _export(src, out, "--subject", "07") == 2
    assert _export(src, out, "--subject", "07", "--force") == 0
    assert len(_tsv(out / "participants.tsv")) == 2


def test_without_deidentification_the_scan_is_dated_and_the_serial_kept(raw, tmp_path):
    src, _ = raw
    out = tmp_path / "d"
    assert _export(src, out, "--no-deidentify") == 0
    scans = _tsv(out / "sub-01" / "sub-01_scans.tsv")
    assert scans == [{"filename": "motion/sub-01_task-walk_tracksys-imuR_motion.tsv",
                      "acq_time": "2026-11-22T04:10:00Z"}]  # fmt: skip
    side = json.loads(_recording(out, "01")["motion.json"].read_text())
    assert side["DeviceSerialNumber"] == "SIM-1"
    # de-identified (the default, from Python too): no scans file, no date, no serial anywhere
    res = ex.export_session(src, "bids", tmp_path / "a")
    files = [p for p in (tmp_path / "a").rglob("*") if p.is_file()]
    assert sorted(files) == sorted(res.paths)
    assert not [p for p in files if p.name.endswith("_scans.tsv")]
    blob = b"".join(p.read_bytes() for p in files)
    for secret in ("2026-11-22", "SIM-1", PATIENT, OPERATOR):
        assert secret.encode() not in blob, secret


# ---- subject labels --------------------------------------------------------------------------


def test_the_subject_label_comes_from_the_users_map(raw, tmp_path, capsys):
    src, _ = raw
    mapping = tmp_path / "subjects.tsv"
    mapping.write_text(f"patient_id\tlabel\nSOMEONE-ELSE\t02\n{PATIENT}\tsub-12\n")
    assert _export(src, tmp_path / "d", "--subject-map", str(mapping)) == 0
    assert _recording(tmp_path / "d", "12")["motion.tsv"].is_file()
    mapping.write_text("SOMEONE-ELSE,02\n")
    capsys.readouterr()
    assert _export(src, tmp_path / "e", "--subject-map", str(mapping)) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "no row" in err and PATIENT not in err
    assert not (tmp_path / "e").exists()  # nothing is left behind
    assert _export(src, tmp_path / "f", "--subject-from-patient-id") == 0
    assert _recording(tmp_path / "f", "PT4711XQZ")["motion.tsv"].is_file()


@pytest.mark.parametrize("args", [
    ("--subject", "P-01"), ("--session", "a b"), ("--task", "walk_fast"),
    ("--subject", "01", "--subject-from-patient-id"),
])  # fmt: skip
def test_bad_labels_and_options_are_one_line_errors(raw, tmp_path, capsys, args):
    src, _ = raw
    try:
        rc = _export(src, tmp_path / "d", *args)
    except SystemExit as exc:  # argparse: the options exclude each other
        rc = int(exc.code or 0)
    assert rc == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "error:" in err
    assert not (tmp_path / "d").exists()


def test_bids_options_with_another_format_are_refused(raw, capsys):
    src, _ = raw
    assert main(["export", str(src), "--format", "csv", "--subject", "01", "-q"]) == 2
    assert "only for --format bids" in capsys.readouterr().err
    with pytest.raises(ex.ExportError, match="takes no options"):
        ex.export_session(src, "csv", options={"subject": "01"})


def test_a_force_sensor_the_cross_check_flagged_is_a_bad_channel(tmp_path, record_simulated):
    src = record_simulated(tmp_path / "dead.h5", "--heel-dead-at", "4", "--side", "R",
                           duration_s=14)
    assert _export(src, tmp_path / "d") == 0
    status = {c["name"]: c for c in _tsv(_recording(tmp_path / "d", "01")["channels.tsv"])}
    assert status["heel_fsr"]["status"] == "bad"
    assert "never loads" in status["heel_fsr"]["status_description"]
    assert status["toe_fsr"]["status"] == "good"  # checked by the same cross-check, not flagged
    assert status["knee_flexion"]["status"] == "n/a"  # not assessed
