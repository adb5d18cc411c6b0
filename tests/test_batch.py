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
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter, open_session
from gaitmon.io.session.reprocess import rewrite_processed
from gaitmon.io.sim import GaitConfig, GaitModel
from gaitmon.io.sim.sensors import realistic_sensors, simulate
from gaitmon.reprocessing import Reprocessing

FS = 100.0
N = 1500  # 15 s each: ~10 strides
N_SESSIONS = 20
SETTINGS = Reprocessing.of({"cutoff_hz": 5.0})  # the default is 4 Hz


def patient(k: int) -> str:
    return f"PAT-{7000 + k % 7}X"  # 7 patients, some with several sessions


def write_session(path: Path, seed: int, pid: str) -> None:
    counts = simulate(N, GaitModel(GaitConfig(seed=seed)), realistic_sensors(seed)).counts
    header = SessionHeader("raw", FS, meta=SessionMeta(patient_id=pid, side="R"),
                           config=PipelineConfig(), calibration=Calibration.identity(),
                           created_utc=f"2026-03-{1 + seed % 28:02d}T10:00:00Z")  # fmt: skip
    w = SessionWriter(path, header)
    seq = np.arange(N, dtype=np.int64)
    blk = SampleBlock(FrameKind.RAW, seq, 10.0 + seq / FS, 1.7e9,
                      lost_before=np.zeros(N, np.int64), adc=counts)  # fmt: skip
    w.append(blk, Pipeline(PipelineConfig()).process(counts))
    w.close()


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    """20 sessions in two sub-folders (file names carry the patient id, as clinics do)."""
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
    assert float(r["stride_time_mean_s"]) == pytest.approx(summ.stride_time_mean_s, abs=5e-5)
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


def test_deidentified_tables_carry_no_patient_id_date_or_file_name(study, local_run, tmp_path):
    result, local_out = local_run
    out = tmp_path / "copy"
    shutil.copytree(local_out, out)  # the same outputs and records: a rerun resumes them all
    deid = run_batch(study, out, SETTINGS, deidentify=True)
    assert deid.n_resumed == N_SESSIONS
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


def test_the_command_writes_deidentified_csvs_and_reads_settings_json(study, tmp_path):
    sub = tmp_path / "sub"
    sub.mkdir()
    src = sorted(study.rglob("*.h5"))[0]
    shutil.copyfile(src, sub / src.name)
    (sub / "tilt.h5").write_bytes(b"")  # not even HDF5: damaged, named only by its label
    settings = tmp_path / "s.json"
    settings.write_text('{"cutoff-hz": 3.5, "method": "paper"}')
    out = tmp_path / "out"
    rc = main(["batch", str(sub), "-o", str(out), "--settings", str(settings), "--r", "0.2",
               "--deidentify", "-q"])  # fmt: skip
    assert rc == 0
    with open_session(out / src.name) as s:
        assert (s.config.cutoff_hz, s.config.tilt_method, s.config.r) == (3.5, "paper", 0.2)
    for name in ("summary.csv", "strides.csv"):
        data = (out / name).read_bytes()
        assert src.stem.encode() not in data and b"PAT-" not in data and b"tilt" not in data
    rows = read_csv(out / "summary.csv")
    assert [(r["session"], r["status"]) for r in rows] == [("S0001", "ok"), ("S0002", "damaged")]
    assert "S0002" in rows[1]["reason"]


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
