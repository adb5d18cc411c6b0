"""``gaitmon batch``: a study folder reprocessed locally and on Dask gives the same bytes;
reruns resume; a damaged file is a row, not the end; de-identified tables name no patient."""

from __future__ import annotations

import csv
import io
import logging
import math
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.analysis import STRIDE_COLUMNS, analyse_session, stride_cells, stride_start_times
from gaitmon.batch import OK, SUMMARY_MEASURES, run_batch
from gaitmon.cli import main
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.finish import close_recording, open_session
from gaitmon.finish.reprocess import rewrite_processed
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import realistic_sensors, simulate
from gaitmon.reprocessing import Reprocessing

FS = 100.0
N = 1500  # 15 s each: ~10 strides
# 7 patients, 3 of them with two sessions, in two sub-folders: every case the tests check (a
# label shared by a patient's sessions, mirrored folders, a pool of 2 beside Dask); 20 sessions
# checked nothing more and cost the suite ~70 s (the study, local, de-identified and Dask runs)
N_SESSIONS = 10
SETTINGS = Reprocessing.of({"cutoff_hz": 5.0})  # the default is 4 Hz


def patient(k: int) -> str:
    return f"PAT-{7000 + k % 7}X"  # 7 patients, some with several sessions


def write_session(path: Path, seed: int, pid: str, *, operator: str = "", notes: str = "",
                  markers: tuple[str, ...] = (), device: dict[str, object] | None = None) -> None:
    counts = simulate(N, GaitModel(GaitConfig(seed=seed)), realistic_sensors(seed)).counts
    header = SessionHeader("raw", FS, meta=SessionMeta(patient_id=pid, side="R",
                                                       operator=operator, notes=notes),
                           device=device or {},
                           config=PipelineConfig(), calibration=Calibration.identity(),
                           created_utc=f"2026-03-{1 + seed % 28:02d}T10:00:00Z")  # fmt: skip
    w = SessionWriter(path, header)
    for k, label in enumerate(markers):
        w.add_marker(label, 100 * (k + 1))
    seq = np.arange(N, dtype=np.int64)
    blk = SampleBlock(FrameKind.RAW, seq, 10.0 + seq / FS, 1.7e9,
                      lost_before=np.zeros(N, np.int64), adc=counts)  # fmt: skip
    w.append(blk, Pipeline(PipelineConfig()).process(counts))
    close_recording(w)


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    """N_SESSIONS sessions in two sub-folders (file names carry the patient id, as clinics do)."""
    root = tmp_path_factory.mktemp("study")
    for k in range(N_SESSIONS):
        sub = root / ("site-a" if k % 2 else "site-b")
        sub.mkdir(exist_ok=True)
        write_session(sub / f"{patient(k)}_{k:02d}.h5", seed=100 + k, pid=patient(k))
    (root / "site-a" / "notes.txt").write_text("not a session")
    return root


def read_csv(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text(encoding="utf-8"))))


def contents(path: Path) -> dict[str, object]:
    """Every dataset's bytes (numbers) or values (tables with text) and every attribute."""
    out: dict[str, object] = {}

    def visit(name: str, obj: h5py.HLObject) -> None:
        out[f"{name}@attrs"] = {k: repr(v) for k, v in obj.attrs.items()}
        if isinstance(obj, h5py.Dataset):
            data = obj[()]
            has_objects = data.dtype.hasobject if isinstance(data, np.ndarray) else True
            out[name] = data.tolist() if has_objects else data.tobytes()

    with h5py.File(path, "r") as f:
        out["@attrs"] = {k: repr(v) for k, v in f.attrs.items()}
        f.visititems(visit)
    return out


@pytest.fixture(scope="module")
def local_run(study, tmp_path_factory):
    out = tmp_path_factory.mktemp("local")
    return run_batch(study, out, SETTINGS, jobs=2), out


def test_every_session_is_reprocessed_with_the_settings_and_summarised(study, local_run):
    result, out = local_run
    assert [o.status for o in result.outcomes] == [OK] * N_SESSIONS
    rels = sorted(p.relative_to(study).as_posix() for p in study.rglob("*.h5"))
    assert [o.rel for o in result.outcomes] == rels  # sorted by relative path
    for rel in rels:  # mirrored layout, new settings, the original untouched
        with open_session(out / rel) as new, open_session(study / rel) as old:
            assert new.config.cutoff_hz == 5.0 and new.reprocessed
            assert old.config.cutoff_hz == 4.0 and not old.reprocessed
    rows = read_csv(out / "summary.csv")
    assert [r["session"] for r in rows] == rels
    # one row against an independent path: gaitmon process + analyse_session on its output
    rel = rels[3]
    ref = out.parent / "ref.h5"
    rewrite_processed(study / rel, ref, PipelineConfig().replace(cutoff_hz=5.0), overwrite=True)
    with open_session(ref) as s:
        t_s = s.read("timeline/t_s")
        an = analyse_session(s, t_s=t_s)
        summ = an.summary()
        starts = stride_start_times(an.rows, t_s)
        ref_strides = [stride_cells(r, k + 1, t)
                       for k, (r, t) in enumerate(zip(an.rows, starts, strict=True))]
        method = s.angle_method
        spatial = an.spatial()
    r = rows[3]
    assert r["patient"] == patient(int(Path(rel).stem[-2:]))
    assert r["date_utc"].startswith("2026-03-")
    assert float(r["duration_s"]) == pytest.approx(N / FS, abs=0.02)
    assert int(r["strides"]) == len(an.rows) >= 6
    assert int(r["strides_included"]) == an.n_included == len(an.rows) - 2  # first and last out
    assert int(r["strides_excluded"]) == 2
    for k in SUMMARY_MEASURES:
        want = getattr(summ, k, None) if hasattr(summ, k) else getattr(spatial, k, None)
        if k == "strides_with_length":
            want = spatial.n_strides
        if want is None or math.isnan(want):
            assert r[k] == "", k
        else:
            assert float(r[k]) == pytest.approx(want, abs=1e-2), k
    # one rounding (4 decimals); 1e-12: the parsed text's own float error
    assert float(r["stride_time_mean_s"]) == pytest.approx(summ.stride_time_mean_s,
                                                           abs=5e-5 + 1e-12)  # fmt: skip
    assert r["angles_method"] == method and r["status"] == "ok" and r["reason"] == ""
    strides = [x for x in read_csv(out / "strides.csv") if x["session"] == rel]
    assert len(strides) == len(ref_strides)
    assert strides[0]["status"] == "excluded: first stride"
    assert strides[-1]["status"] == "excluded: last stride"
    assert strides[1]["status"] == "included"
    keys = [c.key for c in STRIDE_COLUMNS]  # the review table's cells, as text
    assert [[got[k] for k in keys] for got in strides] == ref_strides
    # the stride times are the gait's: ~1.1 s strides at 60 % stance
    assert 0.8 < float(strides[1]["stride_s"]) < 1.6
    assert 50 < float(strides[1]["stance_pct"]) < 70
    assert int(strides[1]["stride"]) == 2


def test_the_dask_run_equals_the_local_run_bit_for_bit(study, local_run, tmp_path):
    distributed = pytest.importorskip("distributed")
    _, local_out = local_run
    out = tmp_path / "dask"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0",
                                  silence_logs=logging.CRITICAL) as cluster:  # fmt: skip
        result = run_batch(study, out, SETTINGS, dask=cluster.scheduler_address)
    assert result.count(OK) == N_SESSIONS and result.n_resumed == 0
    for name in ("summary.csv", "strides.csv"):
        assert (out / name).read_bytes() == (local_out / name).read_bytes(), name
    for o in result.outcomes:
        a, b = contents(local_out / o.rel), contents(out / o.rel)
        assert a.keys() == b.keys() and "processed/tilt_deg" in a and "events/heel_strike" in a
        for k in a:
            assert a[k] == b[k], (o.rel, k)


def test_a_rerun_skips_what_is_done_and_redoes_a_deleted_output(study, tmp_path):
    sub = tmp_path / "sub"  # 4 sessions: a full run here is enough
    for rel in sorted(p.relative_to(study) for p in study.rglob("*.h5"))[:4]:
        (sub / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(study / rel, sub / rel)
    out = tmp_path / "out"
    first = run_batch(sub, out, SETTINGS, jobs=1)
    summary, strides = (out / "summary.csv").read_bytes(), (out / "strides.csv").read_bytes()
    assert first.n_resumed == 0 and first.count(OK) == 4
    assert len(strides.splitlines()) > 4 * 6
    stamps = {o.rel: (out / o.rel).stat().st_mtime_ns for o in first.outcomes}
    again = run_batch(sub, out, SETTINGS, jobs=1)
    assert again.n_resumed == 4
    assert {o.rel: (out / o.rel).stat().st_mtime_ns for o in again.outcomes} == stamps
    assert (out / "summary.csv").read_bytes() == summary
    gone = first.outcomes[2].rel
    (out / gone).unlink()
    third = run_batch(sub, out, SETTINGS, jobs=1)
    assert third.n_resumed == 3 and (out / gone).exists()
    assert (out / "summary.csv").read_bytes() == summary  # redone to the same values
    assert (out / "strides.csv").read_bytes() == strides
    # other settings are another batch: nothing is reused
    other = run_batch(sub, out, Reprocessing.of({"cutoff_hz": 6.0}), jobs=1)
    assert other.n_resumed == 0
    with open_session(out / gone) as s:
        assert s.config.cutoff_hz == 6.0
    # a kill mid-run leaves a .partial output and no record: the session is done again
    (out / gone).rename(out / (gone + ".partial"))
    last = run_batch(sub, out, Reprocessing.of({"cutoff_hz": 6.0}), jobs=1)
    assert last.n_resumed == 3 and (out / gone).exists()


def test_a_damaged_file_is_a_row_and_the_batch_goes_on(study, tmp_path, capsys):
    sub = tmp_path / "sub"
    sub.mkdir()
    rels = sorted(p.relative_to(study) for p in study.rglob("*.h5"))[:3]
    for rel in rels:
        shutil.copyfile(study / rel, sub / rel.name)
    bad = sub / rels[1].name
    data = bad.read_bytes()
    bad.write_bytes(data[: len(data) // 3])  # truncated, as a copy stopped mid-way leaves it
    out = tmp_path / "out"
    assert main(["batch", str(sub), "-o", str(out), "--cutoff-hz", "4", "--jobs", "1"]) == 0
    err = capsys.readouterr().err
    assert f"damaged: {bad.name}" in err
    assert "3 sessions (2 ok, 1 damaged, 0 skipped" in err
    rows = read_csv(out / "summary.csv")
    by_name = {r["session"]: r for r in rows}
    assert by_name[bad.name]["status"] == "damaged" and by_name[bad.name]["reason"]
    assert by_name[bad.name]["strides"] == ""
    assert not (out / bad.name).exists()
    others = [r for r in rows if r["session"] != bad.name]
    assert [r["status"] for r in others] == ["ok", "ok"]
    assert all(int(r["strides"]) > 5 for r in others)
    assert {x["session"] for x in read_csv(out / "strides.csv")} == {r["session"] for r in others}


@pytest.fixture(scope="module")
def deid_run(study, tmp_path_factory):
    out = tmp_path_factory.mktemp("deid") / "shared"
    return run_batch(study, out, SETTINGS, jobs=2, deidentify=True), out


def test_deidentified_tables_carry_no_patient_id_date_or_file_name(study, local_run, deid_run):
    result, local_out = local_run
    deid, out = deid_run
    assert [o.status for o in deid.outcomes] == [OK] * N_SESSIONS
    summary = (out / "summary.csv").read_text(encoding="utf-8")
    strides = (out / "strides.csv").read_text(encoding="utf-8")
    data = (summary + strides).encode()
    for o in result.outcomes:
        assert o.patient_id.encode() not in data
        assert Path(o.rel).stem.encode() not in data
        assert o.created_utc[:10].encode() not in data
    assert b"PAT-" not in data and b"2026" not in data
    rows = list(csv.DictReader(io.StringIO(summary)))
    assert [r["session"] for r in rows] == [f"S{k:04d}" for k in range(1, N_SESSIONS + 1)]
    # one label per patient: sessions of the same patient share it, others differ
    label_of: dict[str, str] = {}
    for o, r in zip(result.outcomes, rows, strict=True):
        assert label_of.setdefault(o.patient_id, r["patient"]) == r["patient"]
    assert len(set(label_of.values())) == len(label_of) == 7
    # the measures and strides are the identified tables', under the labels
    plain = read_csv(local_out / "summary.csv")
    for a, b in zip(rows, plain, strict=True):
        assert [a[k] for k in SUMMARY_MEASURES] == [b[k] for k in SUMMARY_MEASURES]
    to_label = {b["session"]: a["session"] for a, b in zip(rows, plain, strict=True)}
    plain_strides = (local_out / "strides.csv").read_text(encoding="utf-8").splitlines()
    relabelled = [plain_strides[0]] + [
        to_label[line.split(",", 1)[0]] + "," + line.split(",", 1)[1] for line in plain_strides[1:]
    ]
    assert strides.splitlines() == relabelled


# what a de-identified session file may differ in from the identified one (key -> why)
CLEANED = {
    "@attrs": "created_utc left out",
    "session@attrs": "patient_id, operator, notes blanked",
    "device@attrs": "serial, transport blanked",
    "timeline/host_time_s": "the host clock from 0",
    "timeline/host_time_s@attrs": "wall_offset_s left out",
}


def test_deidentified_batch_leaves_nothing_in_out_that_names_a_patient(study, local_run,
                                                                       deid_run):
    """Every byte of every file under OUT (the sessions too, not only the CSVs), searched for
    the patient ids, the file names and the recording dates; the sessions hold the identified
    run's data otherwise, value for value."""
    result, local_out = local_run
    deid, out = deid_run
    files = sorted(p for p in out.rglob("*") if p.is_file())
    names = sorted(p.relative_to(out).as_posix() for p in files)
    assert names == sorted(["summary.csv", "strides.csv",
                            *(f"S{k:04d}.h5" for k in range(1, N_SESSIONS + 1))])  # fmt: skip
    secrets = {o.patient_id for o in result.outcomes} | {Path(o.rel).stem for o in result.outcomes}
    secrets |= {o.created_utc[:10] for o in result.outcomes} | {"site-a", "site-b"}
    for p in files:
        blob = p.read_bytes()
        found = [x for x in secrets if x.encode() in blob]
        assert found == [], (p.name, found)
    for k, o in enumerate(result.outcomes):
        label = f"S{k + 1:04d}"
        mine, theirs = contents(out / f"{label}.h5"), contents(local_out / o.rel)
        assert set(mine) == set(theirs)
        assert {key for key in mine if mine[key] != theirs[key]} <= set(CLEANED), label
        with h5py.File(out / f"{label}.h5", "r") as f:
            assert "created_utc" not in f.attrs
            assert {k: f["session"].attrs[k] for k in ("patient_id", "operator", "notes")} == (
                dict.fromkeys(("patient_id", "operator", "notes"), ""))
            host = f["timeline/host_time_s"][...]
            assert host[0] == 0.0 and "wall_offset_s" not in f["timeline/host_time_s"].attrs
        with h5py.File(local_out / o.rel, "r") as f:
            np.testing.assert_allclose(host, f["timeline/host_time_s"][...] - 10.0, atol=1e-9)
        with open_session(out / f"{label}.h5") as s:  # still a session gaitmon reads
            assert s.config.cutoff_hz == 5.0 and s.meta.patient_id == "" and s.n_samples == N
    # the key: beside OUT, never in it; it links each label to its source and patient
    assert deid.key == out.with_name("shared.gaitmon-key") and deid.key.is_dir()
    key = read_csv(deid.key / "key.csv")
    summary = read_csv(out / "summary.csv")
    assert [(r["session"], r["file"], r["source"], r["patient_id"]) for r in key] == [
        (f"S{k + 1:04d}", f"S{k + 1:04d}.h5", o.rel, o.patient_id)
        for k, o in enumerate(result.outcomes)]
    assert [r["patient"] for r in key] == [r["patient"] for r in summary]


def test_a_deidentified_rerun_resumes_and_the_kinds_of_out_are_never_mixed(study, local_run,
                                                                            deid_run, tmp_path):
    from gaitmon.errors import UserError

    _, out = deid_run
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    again = run_batch(study, out, SETTINGS, deidentify=True)
    assert again.n_resumed == N_SESSIONS
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    _, local_out = local_run
    with pytest.raises(UserError, match="not de-identified"):
        run_batch(study, local_out, SETTINGS, deidentify=True)
    with pytest.raises(UserError, match="add --deidentify"):
        run_batch(study, out, SETTINGS)


def test_deidentified_sessions_lose_operator_notes_serial_and_the_patient_in_markers(tmp_path,
                                                                                      capsys):
    """Typed texts: the patient id and operator inside marker labels, notes, the unit's serial
    and its Bluetooth address; none of their bytes is left anywhere in the file (HDF5 keeps
    a rewritten attribute's old bytes in free space: the file is copied afresh)."""
    src = tmp_path / "in"
    src.mkdir()
    pid, operator, notes = "PAT-9911Q", "Dr Zed Quorum", "lives at 12 Elm Road"
    address = "00:1A:7D:DA:71:13"
    write_session(src / "zed.h5", 7, pid, operator=operator, notes=notes,
                  markers=(f"{pid} sits", f"{operator} says stop", "turn"),
                  device={"name": "gaitmon-unit", "firmware": "1.2", "serial": 48213,
                          "transport": address, "side": "R"})  # fmt: skip
    with h5py.File(src / "zed.h5", "r") as f:  # (the identified file does hold them)
        assert f["device"].attrs["serial"] == 48213
    raw = (src / "zed.h5").read_bytes()
    assert all(x.encode() in raw for x in (pid, operator, notes, address))
    out = tmp_path / "out"
    result = run_batch(src, out, SETTINGS, deidentify=True)
    assert [o.status for o in result.outcomes] == [OK]
    blob = (out / "S0001.h5").read_bytes()
    for secret in (pid, operator, notes, address, "Elm Road", "Quorum", "2026-03"):
        assert secret.encode() not in blob, secret
    with open_session(out / "S0001.h5") as s:
        assert [m.label for m in s.markers] == ["[removed] sits", "[removed] says stop", "turn"]
        assert [m.sample_idx for m in s.markers] == [100, 200, 300]
    with h5py.File(out / "S0001.h5", "r") as f:
        dev = dict(f["device"].attrs)
        assert dev["serial"] == "" and dev["transport"] == "" and dev["firmware"] == "1.2"
    assert list(out.iterdir()) and not any(p.suffix == ".partial" for p in out.rglob("*"))
    assert not any((result.key / "work").iterdir())  # no work file left in the key either
    # info says what was removed instead of printing blanks
    from gaitmon.cli import main

    assert main(["info", str(out / "S0001.h5")]) == 0
    text = capsys.readouterr().out
    assert "recorded     date removed," in text and "serial - via -" in text


def test_the_command_writes_deidentified_csvs_and_reads_settings_json(study, tmp_path, capsys):
    sub = tmp_path / "sub"
    sub.mkdir()
    src = sorted(study.rglob("*.h5"))[0]
    shutil.copyfile(src, sub / src.name)
    (sub / "tilt.h5").write_bytes(b"")  # not even HDF5: damaged, named only by its label
    settings = tmp_path / "s.json"
    settings.write_text('{"cutoff-hz": 3.5, "method": "paper"}')
    out = tmp_path / "out"
    # --jobs 1: the pool is the local run's (2 sessions here need no 2 spawned workers)
    rc = main(["batch", str(sub), "-o", str(out), "--settings", str(settings), "--r", "0.2",
               "--deidentify", "--jobs", "1", "-q"])  # fmt: skip
    assert rc == 0
    with open_session(out / "S0001.h5") as s:  # (named by its label, not its file name)
        assert (s.config.cutoff_hz, s.config.tilt_method, s.config.r) == (3.5, "paper", 0.2)
    assert not (out / src.name).exists()
    for name in ("summary.csv", "strides.csv"):
        data = (out / name).read_bytes()
        assert src.stem.encode() not in data and b"PAT-" not in data and b"tilt" not in data
    rows = read_csv(out / "summary.csv")
    assert [(r["session"], r["status"]) for r in rows] == [("S0001", "ok"), ("S0002", "damaged")]
    assert "S0002" in rows[1]["reason"]
    err = capsys.readouterr().err  # a run's log names sessions by their labels too
    assert "gaitmon batch: damaged: S0002: " in err
    assert "tilt" not in err and src.stem not in err and "PAT-" not in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--settings", '{"cutof_hz": 4}'], "unknown setting 'cutof_hz'"),
        (["--settings", "[4]"], "must be a JSON object"),
        (["--cutoff-hz", "-1"], "--cutoff-hz must be above 0"),
        (["--jobs", "0"], "--jobs must be 1 or more"),
    ],
)
def test_bad_settings_are_one_line(study, tmp_path, capsys, argv, message):
    assert main(["batch", str(study), "-o", str(tmp_path / "o"), *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_paper_settings_without_the_paper_filter_skip_the_session_with_the_reason(
    study, tmp_path
):
    sub = tmp_path / "sub"
    sub.mkdir()
    src = sorted(study.rglob("*.h5"))[0]
    shutil.copyfile(src, sub / src.name)
    result = run_batch(sub, tmp_path / "out", Reprocessing.of({"r": 0.2}))
    (o,) = result.outcomes
    assert o.status == "skipped" and "add --method paper" in o.reason
    assert math.isnan(o.duration_s)


def test_a_run_interrupted_mid_way_resumes_to_the_same_tables(study, tmp_path):
    sub = tmp_path / "sub"
    sub.mkdir()
    for src in sorted(study.rglob("*.h5"))[:4]:
        shutil.copyfile(src, sub / src.name)
    clean = run_batch(sub, tmp_path / "clean", SETTINGS)
    assert clean.count(OK) == 4

    def interrupt_after_two(fraction: float, detail: str) -> None:
        if fraction >= 0.5:
            raise KeyboardInterrupt  # Ctrl-C after the second session

    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        run_batch(sub, out, SETTINGS, progress=interrupt_after_two)
    assert not (out / "summary.csv").exists()  # the tables come last
    resumed = run_batch(sub, out, SETTINGS)
    assert resumed.n_resumed == 2 and resumed.count(OK) == 4
    for name in ("summary.csv", "strides.csv"):
        assert (out / name).read_bytes() == (tmp_path / "clean" / name).read_bytes()


def test_a_both_legs_session_is_skipped_with_the_reason_not_called_damaged(study, tmp_path):
    """A good file of both legs was reported "damaged" (``open_session`` refuses both legs)."""
    sub = tmp_path / "sub"
    sub.mkdir()
    src = sorted(study.rglob("*.h5"))[0]
    shutil.copyfile(src, sub / src.name)
    assert main(["record", "--simulate-bilateral", "--duration", "8", "--speed", "8", "-o",
                 str(sub / "both.h5"), "-q"]) == 0  # fmt: skip
    result = run_batch(sub, tmp_path / "out")
    by_rel = {o.rel: o for o in result.outcomes}
    assert by_rel["both.h5"].status == "skipped"
    assert "both legs" in by_rel["both.h5"].reason and "gaitmon process" in by_rel["both.h5"].reason
    assert by_rel[src.name].status == OK


def _workers(pid: int) -> set[int]:
    """The batch's pool workers now (a child gone between the listing and the read is not)."""
    out = set()
    for c in _children(pid):
        try:
            if b"spawn_main" in Path(f"/proc/{c}/cmdline").read_bytes():
                out.add(c)
        except OSError:  # it ended a moment ago (CI: FileNotFoundError for /proc/PID/cmdline)
            continue
    return out


def _children(pid: int) -> set[int]:
    out = set()
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                status = (d / "status").read_text()
            except OSError:
                continue
            if f"\nPPid:\t{pid}\n" in status:
                out.add(int(d.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "\nState:\tZ" not in state  # a zombie has ended


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads /proc (Linux)")
def test_a_killed_batch_takes_its_workers_with_it(study, tmp_path):
    """Issue 26, item 12: after ``kill -9`` of ``gaitmon batch`` its pool workers reprocessed
    on (and wrote their outputs) for nobody. Now they die with it: no output appears after
    the kill, and every worker is gone."""
    import os
    import signal
    import subprocess
    import sys
    import time

    sub = tmp_path / "sub"
    sub.mkdir()
    for src in sorted(study.rglob("*.h5"))[:6]:
        shutil.copyfile(src, sub / src.name)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-m", "gaitmon", "batch", str(sub), "-o", str(out),
                             "--jobs", "2", "-q"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    try:
        workers: set[int] = set()
        deadline = time.monotonic() + 120
        # wait until two workers run and one is writing (a .partial output exists)
        while time.monotonic() < deadline and proc.poll() is None:
            workers = _workers(proc.pid)
            if len(workers) >= 2 and list(out.rglob("*.partial")):
                break
            time.sleep(0.01)
        assert proc.poll() is None and len(workers) >= 2, "the batch ended before the kill"
        done_at_kill = {p.name for p in out.rglob("*.h5")}
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 120  # a generous wait for the old code's workers to end
        while time.monotonic() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.05)
        assert not any(_alive(w) for w in workers)
        assert {p.name for p in out.rglob("*.h5")} == done_at_kill  # nothing written after
    finally:
        if proc.poll() is None:
            proc.kill()
