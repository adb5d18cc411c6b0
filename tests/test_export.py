"""gaitmon export: CSV / MAT / C3D read back with independent readers (csv, scipy, ezc3d).

Fixture sessions are written here with h5py straight from docs/file-format.md, with known
arrays, so every exported number is compared with what was put into the session file, not
with the exporter's own output.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon import export as ex
from gaitmon.cli import main
from gaitmon.dsp.channels import CHANNELS
from gaitmon.export.writers import c3d as ex_c3d
from gaitmon.export.writers import mat as ex_mat

PATIENT = "PT-4711-XQZ"
OPERATOR = "Dr. Quillfeather"
NOTES = "Knee pain since March; lives on Elmstreet 12"
FS = 100.0
LOST_AT, N_LOST = 300, 5  # row where data resumes after 5 lost frames
STR = h5py.string_dtype()


def write_session(path: Path, mode: str = "raw", n: int = 600, seed: int = 0,
                  side: str = "R") -> dict[str, np.ndarray]:
    """A session file per docs/file-format.md; returns the per-sample arrays written."""
    rng = np.random.default_rng(seed)
    seq = 1000 + np.arange(n, dtype=np.int64)
    seq[LOST_AT:] += N_LOST
    t_s = (seq - seq[0]) / FS
    truth: dict[str, np.ndarray] = {
        "timeline/seq": seq,
        "timeline/t_s": t_s,
        "timeline/host_time_s": 5000.0 + t_s + rng.uniform(0, 0.004, n),
    }

    def f32(*shape: int, scale: float = 40.0) -> np.ndarray:
        return (rng.standard_normal((n, *shape)) * scale).astype(np.float32)

    if mode == "raw":
        truth["raw/adc"] = rng.integers(0, 4096, (n, 14)).astype(np.uint16)
        truth["processed/tilt_gyro_deg"] = f32(4)
        truth["processed/joint_gyro_deg"] = f32(3)
        truth["processed/acc_ms2"] = f32(4, 2, scale=9.0)
        truth["processed/gyro_rad_s"] = f32(4, scale=3.0)
        truth["processed/fsr_counts"] = np.abs(f32(2, scale=1500.0))
    if mode in ("raw", "tilt"):
        truth["processed/tilt_deg"] = f32(4)
        truth["processed/tilt_acc_deg"] = f32(4)
    truth["processed/joint_deg"] = f32(3)
    truth["processed/joint_acc_deg"] = f32(3)
    # the extremes of the wrapped range must survive the fixed-decimal formats too
    truth["processed/joint_deg"][5] = [180.0, -179.99998, 1e-7]
    if mode in ("raw", "joint"):
        truth["processed/heel_loaded"] = rng.integers(0, 2, n).astype(np.uint8)
        truth["processed/toe_loaded"] = rng.integers(0, 2, n).astype(np.uint8)
        truth["processed/phase"] = rng.integers(0, 4, n).astype(np.int8)

    with h5py.File(path, "w") as h:
        h.attrs.update({
            "format": "gaitmon-session", "format_version": 1,
            "created_utc": "2026-11-22T04:10:00Z", "sample_rate_hz": FS,
            "software_version": "0.1.0", "mode": mode, "complete": True, "recovered": False,
            "n_samples": n, "duration_s": float(t_s[-1] - t_s[0] + 1 / FS),
            "stop_reason": "user",
            "angle_convention": "hip flexion + = thigh - body; knee flexion + = thigh - shank; "
                                "ankle dorsiflexion + = foot - shank; wrapped to (-180, 180]",
        })
        g = h.create_group("session")
        g.attrs.update({"patient_id": PATIENT, "side": side, "operator": OPERATOR,
                        "notes": NOTES})
        d = h.create_group("device")
        d.attrs.update({"name": "gaitmon-sim", "firmware": "1.0", "serial": "SIM-1",
                        "side": side, "transport": "simulated", "channel_table_id": "ref-v1",
                        "channel_table_crc": 123})
        ch_dt = np.dtype([("index", "<i8"), ("name", STR), ("segment", STR), ("kind", STR),
                          ("unit", STR), ("adc_bits", "<i8"), ("vref_v", "<f8"),
                          ("zero_v", "<f8"), ("sensitivity_v_per_unit", "<f8")])
        d.create_dataset("channels", data=np.array(
            [(c.index, c.name, c.segment, c.kind, c.unit, c.adc_bits, c.vref_v, c.zero_v,
              c.sensitivity_v_per_unit) for c in CHANNELS], dtype=ch_dt))
        for key, arr in truth.items():
            h.create_dataset(key, data=arr)
        if mode == "raw":
            # a recording's analysed angles are the smoother's (/smoothed); the live filter's
            # differ, and an export must write the smoothed ones by default
            for key in ("processed/tilt_deg", "processed/joint_deg"):
                h.create_dataset(key.replace("processed/", "smoothed/"), data=truth[key])
                h[key][...] = truth[key] + np.float32(7.0)
        h["timeline/host_time_s"].attrs["wall_offset_s"] = 1.7e9
        h["processed"].attrs.update({"source": "pc" if mode == "raw" else "device",
                                     "reprocessed": False})
        # sorted: a short session (n < 310) must not get events out of order (a damaged file)
        h.create_dataset("events/heel_strike", data=np.unique([0, 110, 210, 310, n - 1]))
        h.create_dataset("events/toe_off", data=np.array([70, 170, 299, 300]))
        mk_dt = np.dtype([("sample_idx", "<i8"), ("t_s", "<f8"), ("label", STR)])
        h.create_dataset("markers", data=np.array([
            (50, t_s[50], "start walk"),
            (150, t_s[150], 'turn, "fast"'),
            (150, t_s[150], f"asked {PATIENT} to stop"),
        ], dtype=mk_dt))
        gp_dt = np.dtype([("sample_idx", "<i8"), ("n_lost", "<i8"), ("duration_s", "<f8"),
                          ("reason", STR)])
        h.create_dataset("gaps", data=np.array([(LOST_AT, N_LOST, N_LOST / FS, "frames lost")],
                                               dtype=gp_dt))
        lk = h.create_group("link")
        lk.attrs.update({"frames_ok": n, "frames_lost": N_LOST, "crc_failures": 1,
                         "bytes_received": n * 40, "bytes_skipped": 3, "invalid_values": 0,
                         "reconnects": 0, "queue_overflow_frames": 0})
        lk.create_dataset("crc_failures", data=np.array(
            [(120, 1)], dtype=[("sample_idx", "<i8"), ("count", "<i8")]))
        cf = h.create_group("config")
        cf.attrs.update({"fs_hz": FS, "cutoff_hz": 5.0, "filter_order": 2,
                         "event_delay_samples": 7})
        cf.create_dataset("changes", data=np.array(
            [(400, json.dumps({"cutoff_hz": 6.0}))],
            dtype=[("sample_idx", "<i8"), ("json", STR)]))
        cal = h.create_group("calibration")
        cal.attrs["tilt_offset_rad"] = np.zeros(4)
        cal.attrs["gyro_bias_rad_s"] = np.full(4, 0.01)
        cal.create_dataset("changes", data=np.array(
            [(20, json.dumps({"segments": ["body", "thigh", "shank", "foot"],
                              "tilt_offset_rad": [0.01, 0.02, 0.0, -0.01],
                              "gyro_bias_rad_s": [0.01] * 4}))],
            dtype=[("sample_idx", "<i8"), ("json", STR)]))
    return truth


@pytest.fixture(params=["raw", "tilt", "joint"])
def session(request, tmp_path) -> tuple[Path, dict[str, np.ndarray], str]:
    path = tmp_path / "walk.h5"
    return path, write_session(path, request.param), request.param


HS = np.array([0, 110, 210, 310])  # + n - 1, added per test
TO = np.array([70, 170, 299, 300])


def _hs(n: int) -> np.ndarray:
    return np.append(HS, n - 1)


# ---------------------------------------------------------------------------------------------
# CSV
# ---------------------------------------------------------------------------------------------


def _read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


CSV_COLUMNS = {  # dataset -> its CSV columns, written out by hand from the documented names
    "timeline/t_s": ["t_s"],
    "timeline/seq": ["seq"],
    "timeline/host_time_s": ["host_time_s"],
    "processed/joint_deg": ["hip_flexion_deg", "knee_flexion_deg", "ankle_dorsiflexion_deg"],
    "processed/joint_acc_deg": ["hip_flexion_acc_deg", "knee_flexion_acc_deg",
                                "ankle_dorsiflexion_acc_deg"],
    "processed/joint_gyro_deg": ["hip_flexion_gyro_deg", "knee_flexion_gyro_deg",
                                 "ankle_dorsiflexion_gyro_deg"],
    "processed/tilt_deg": ["body_tilt_deg", "thigh_tilt_deg", "shank_tilt_deg", "foot_tilt_deg"],
    "processed/tilt_acc_deg": ["body_tilt_acc_deg", "thigh_tilt_acc_deg", "shank_tilt_acc_deg",
                               "foot_tilt_acc_deg"],
    "processed/tilt_gyro_deg": ["body_tilt_gyro_deg", "thigh_tilt_gyro_deg",
                                "shank_tilt_gyro_deg", "foot_tilt_gyro_deg"],
    "processed/acc_ms2": ["body_acc_x_ms2", "body_acc_z_ms2", "thigh_acc_x_ms2",
                          "thigh_acc_z_ms2", "shank_acc_x_ms2", "shank_acc_z_ms2",
                          "foot_acc_x_ms2", "foot_acc_z_ms2"],
    "processed/gyro_rad_s": ["body_gyro_rad_s", "thigh_gyro_rad_s", "shank_gyro_rad_s",
                             "foot_gyro_rad_s"],
    "processed/fsr_counts": ["heel_fsr_lp_count", "toe_fsr_lp_count"],
    "processed/heel_loaded": ["heel_loaded"],
    "processed/toe_loaded": ["toe_loaded"],
    "processed/phase": ["phase"],
    "raw/adc": [f"{c.name}_count" for c in CHANNELS],
}
def test_csv_round_trip(session, tmp_path):
    path, truth, mode = session
    res = ex.export_session(path, "csv")
    out = tmp_path / "walk.csv"
    assert res.paths == (out, tmp_path / "walk.meta.json")
    header, rows = _read_csv(out)
    n = len(truth["timeline/t_s"])
    assert len(rows) == n
    assert header[:5] == ["t_s", "seq", "hip_flexion_deg", "knee_flexion_deg",
                          "ankle_dorsiflexion_deg"]
    assert header[-4:] == ["heel_strike", "toe_off", "gap_lost_frames", "marker"]
    assert len(header) == len(set(header))
    assert all(len(r) == len(header) for r in rows)
    expected_cols = [c for k in truth for c in CSV_COLUMNS[k]]
    assert sorted(header[:-4]) == sorted(expected_cols)
    col = {name: i for i, name in enumerate(header)}
    for key, arr in truth.items():
        flat = arr.reshape(n, -1)
        for j, name in enumerate(CSV_COLUMNS[key]):
            got = np.array([float(r[col[name]]) for r in rows])
            if arr.dtype.kind in "iu":
                np.testing.assert_array_equal(got, flat[:, j], err_msg=name)
                assert all("." not in r[col[name]] for r in rows[:20])
            else:
                # the documented decimals: half a unit in the last place
                if name.endswith("_deg"):
                    tol = 0.5e-4
                elif name.endswith("_ms2"):
                    tol = 0.5e-5
                elif name.endswith("_rad_s"):
                    tol = 0.5e-6
                elif name.endswith("lp_count"):
                    tol = 0.5e-3
                else:  # t_s, host_time_s: 6 decimals
                    tol = 0.5e-6
                # + rounding of the decimal string itself (float64 eps at these magnitudes)
                np.testing.assert_allclose(got, flat[:, j].astype(np.float64), rtol=0,
                                           atol=tol * (1 + 1e-9) + 1e-12, err_msg=name)
    hs = np.array([int(r[col["heel_strike"]]) for r in rows])
    to = np.array([int(r[col["toe_off"]]) for r in rows])
    np.testing.assert_array_equal(np.flatnonzero(hs), _hs(n))
    np.testing.assert_array_equal(np.flatnonzero(to), TO)
    lost = np.array([int(r[col["gap_lost_frames"]]) for r in rows])
    assert np.flatnonzero(lost).tolist() == [LOST_AT] and lost[LOST_AT] == N_LOST
    marker = [r[col["marker"]] for r in rows]
    assert marker[50] == "start walk"
    assert marker[150] == f'turn, "fast" | asked {PATIENT} to stop'
    assert sum(1 for m in marker if m) == 2

    meta = json.loads((tmp_path / "walk.meta.json").read_text(encoding="utf-8"))
    assert meta["format"] == "gaitmon-export-csv" and meta["mode"] == mode
    assert meta["n_samples"] == n and meta["events"]["index_base"] == 0
    assert meta["events"]["heel_strike_idx"] == _hs(n).tolist()
    assert meta["events"]["toe_off_idx"] == TO.tolist()
    assert meta["session"]["patient_id"] == PATIENT
    assert meta["gaps"] == [{"sample_idx": LOST_AT, "n_lost": N_LOST,
                             "duration_s": N_LOST / FS, "reason": "frames lost"}]
    assert [c["name"] for c in meta["columns"]] == header
    assert meta["device"]["channels"][3]["name"] == CHANNELS[3].name
    assert meta["config_changes"] == [{"sample_idx": 400, "json": '{"cutoff_hz": 6.0}'}]


def test_csv_chunking_does_not_change_the_output(tmp_path):
    """Streaming in chunks of 7 rows (events/markers/gaps across boundaries) = one chunk."""
    src = tmp_path / "s.h5"
    write_session(src, "raw", n=400)
    ex.export_session(src, "csv", tmp_path / "a.csv", chunk_rows=7)
    ex.export_session(src, "csv", tmp_path / "b.csv", chunk_rows=10_000)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


# ---------------------------------------------------------------------------------------------
# MAT
# ---------------------------------------------------------------------------------------------


def _loadmat(path: Path):
    from scipy.io import loadmat

    return loadmat(path, squeeze_me=False, struct_as_record=False)["session"][0, 0]


MAT_KEYS = {"timeline/t_s": "t_s", "timeline/seq": "seq", "timeline/host_time_s": "host_time_s",
            "raw/adc": "adc_count"}


def test_mat_round_trip(session, tmp_path):
    path, truth, mode = session
    ex.export_session(path, "mat")
    s = _loadmat(tmp_path / "walk.mat")
    n = len(truth["timeline/t_s"])
    assert s.mode[0] == mode and float(s.index_base[0, 0]) == 1.0
    for key, arr in truth.items():
        field = MAT_KEYS.get(key, key.split("/")[-1])
        got = getattr(s, field)
        want = arr.reshape(n, 1) if arr.ndim == 1 else arr
        assert got.shape == want.shape, field
        if key.startswith("timeline/"):
            assert got.dtype == np.float64  # MATLAB double
            np.testing.assert_array_equal(got, want.astype(np.float64), err_msg=field)
        else:
            assert got.dtype == arr.dtype, field  # single / uint16 / uint8 / int8 kept
            np.testing.assert_array_equal(got, want, err_msg=field)
    absent = {"raw": [], "tilt": ["adc_count", "phase"], "joint": ["adc_count", "tilt_deg"]}
    for field in absent[mode]:
        assert field not in s._fieldnames
    assert [x[0] for x in s.labels[0, 0].joint_deg.ravel()] == [
        "hip_flexion_deg", "knee_flexion_deg", "ankle_dorsiflexion_deg"]
    assert s.units[0, 0].joint_deg[0] == "deg"
    # events: 1-based MATLAB rows, and t_s at those rows
    ev = s.events[0, 0]
    np.testing.assert_array_equal(ev.heel_strike_idx.ravel(), _hs(n) + 1)
    np.testing.assert_array_equal(ev.toe_off_idx.ravel(), TO + 1)
    t = truth["timeline/t_s"]
    np.testing.assert_array_equal(ev.heel_strike_t_s.ravel(), t[_hs(n)])
    np.testing.assert_array_equal(ev.toe_off_t_s.ravel(), t[TO])
    mk = s.markers[0, 0]
    np.testing.assert_array_equal(mk.sample_idx.ravel(), [51, 151, 151])
    assert [x[0] for x in mk.label.ravel()] == ["start walk", 'turn, "fast"',
                                                f"asked {PATIENT} to stop"]
    gp = s.gaps[0, 0]
    assert gp.sample_idx.ravel().tolist() == [LOST_AT + 1] and gp.n_lost.ravel().tolist() == [5]
    meta = s.meta[0, 0]
    assert meta.session[0, 0].patient_id[0] == PATIENT
    assert float(meta.root[0, 0].sample_rate_hz[0, 0]) == FS
    assert meta.config_changes[0, 0].sample_idx.ravel().tolist() == [401]
    assert meta.device[0, 0].channels[0, 0].name.ravel()[13][0] == CHANNELS[13].name


def test_mat_refuses_a_session_over_the_v5_limit(tmp_path, monkeypatch):
    src = tmp_path / "s.h5"
    write_session(src, "raw", n=200)
    monkeypatch.setattr(ex_mat, "MAT_V5_MAX_BYTES", 10_000)
    with pytest.raises(ex.ExportError, match="2 GB MATLAB limit"):
        ex.export_session(src, "mat")
    assert not (tmp_path / "s.mat").exists()
    assert list(tmp_path.iterdir()) == [src]  # no partial file left behind


# ---------------------------------------------------------------------------------------------
# C3D
# ---------------------------------------------------------------------------------------------


def _physical(counts: np.ndarray) -> np.ndarray:
    """The doc's formula, written out: (counts * vref / 2**bits - zero_v) / sensitivity."""
    out = np.empty(counts.shape)
    for j, c in enumerate(CHANNELS):
        out[:, j] = (counts[:, j] * c.vref_v / 2**c.adc_bits - c.zero_v) / c.sensitivity_v_per_unit
    return out


def _events(c) -> list[tuple[str, str, float]]:
    ev = c["parameters"]["EVENT"]
    times = ev["TIMES"]["value"]
    return [(ev["CONTEXTS"]["value"][i], ev["LABELS"]["value"][i],
             float(times[0, i] * 60 + times[1, i])) for i in range(int(ev["USED"]["value"][0]))]


def test_c3d_round_trip(session, tmp_path):
    ezc3d = pytest.importorskip("ezc3d")
    path, truth, mode = session
    res = ex.export_session(path, "c3d")
    assert res.paths == (tmp_path / "walk.c3d",)
    c = ezc3d.c3d(str(tmp_path / "walk.c3d"))
    n = len(truth["timeline/t_s"])
    n_frames = n + N_LOST  # the lost frames are frames too, on the uniform 100 Hz grid
    frame = (truth["timeline/seq"] - truth["timeline/seq"][0])
    gap = np.arange(LOST_AT, LOST_AT + N_LOST)
    P = c["parameters"]
    assert float(P["POINT"]["RATE"]["value"][0]) == FS
    labels = P["POINT"]["LABELS"]["value"]
    pts = c["data"]["points"]
    assert pts.shape[2] == n_frames
    assert labels[:3] == ["RHipAngles", "RKneeAngles", "RAnkleAngles"]
    assert P["POINT"]["ANGLES"]["value"] == labels and P["POINT"]["ANGLE_UNITS"]["value"] == [
        "deg"]
    # X = the angle (float32 in both the session and C3D: exact); Y, Z = 0; gap frames invalid
    np.testing.assert_array_equal(pts[0, :3, frame], truth["processed/joint_deg"])
    np.testing.assert_array_equal(pts[1:3, :3][:, :, frame], 0.0)
    assert np.isnan(pts[:3, :, gap]).all()
    if mode != "joint":
        assert labels[3:] == ["BodyTilt", "RThighTilt", "RShankTilt", "RFootTilt"]
        np.testing.assert_array_equal(pts[0, 3:, frame], truth["processed/tilt_deg"])
    else:
        assert len(labels) == 3
    an = c["data"]["analogs"]
    if mode == "raw":
        assert float(P["ANALOG"]["RATE"]["value"][0]) == FS
        assert P["ANALOG"]["LABELS"]["value"][:14] == [ch.name for ch in CHANNELS]
        assert P["ANALOG"]["UNITS"]["value"][:14] == [ch.unit for ch in CHANNELS]
        want = _physical(truth["raw/adc"].astype(np.float64))
        # C3D stores float32: relative 2**-24
        np.testing.assert_allclose(an[0, :14, frame], want, rtol=2**-23, atol=1e-6)
        np.testing.assert_array_equal(an[0, 14:16, frame], truth["processed/fsr_counts"])
        assert np.isnan(an[0][:, gap]).all()
    else:
        assert an.shape[1] == 0
    ev = _events(c)
    strikes = [(cx, t) for cx, lab, t in ev if lab == "Foot Strike"]
    offs = [(cx, t) for cx, lab, t in ev if lab == "Foot Off"]
    assert {cx for cx, _ in strikes + offs} == {"Right"}
    # EVENT:TIMES: seconds from frame 1 (time 0); frame of row k = seq[k] - seq[0]
    np.testing.assert_allclose([t for _, t in strikes], frame[_hs(n)] / FS, atol=1e-5)
    np.testing.assert_allclose([t for _, t in offs], frame[TO] / FS, atol=1e-5)
    general = [(lab, t) for cx, lab, t in ev if cx == "General"]
    assert [lab for lab, _ in general] == ["start walk", 'turn, "fast"',
                                           f"asked {PATIENT} to stop"]
    assert P["SUBJECTS"]["NAMES"]["value"] == [PATIENT]
    assert P["GAITMON"]["MODE"]["value"] == [mode]


def test_c3d_long_session_is_split_into_parts(tmp_path, monkeypatch):
    ezc3d = pytest.importorskip("ezc3d")
    src = tmp_path / "long.h5"
    truth = write_session(src, "raw", n=600, side="L")
    monkeypatch.setattr(ex_c3d, "C3D_MAX_PART_S", 2.5)  # 250-frame parts: 605 frames -> 3 parts
    res = ex.export_session(src, "c3d")
    assert [p.name for p in res.paths] == [f"long_part00{k}.c3d" for k in (1, 2, 3)]
    parts = [ezc3d.c3d(str(p)) for p in res.paths]
    assert [p["data"]["points"].shape[2] for p in parts] == [250, 250, 105]
    knee = np.concatenate([p["data"]["points"][0, 1] for p in parts])
    frame = truth["timeline/seq"] - truth["timeline/seq"][0]
    np.testing.assert_array_equal(knee[frame], truth["processed/joint_deg"][:, 1])
    strikes = []
    for k, p in enumerate(parts):
        assert float(p["parameters"]["GAITMON"]["PART_START_S"]["value"][0]) == 2.5 * k
        strikes += [2.5 * k + t for cx, lab, t in _events(p) if lab == "Foot Strike"]
        assert all(cx == "Left" for cx, lab, _ in _events(p) if lab.startswith("Foot"))
    np.testing.assert_allclose(strikes, frame[_hs(600)] / FS, atol=1e-5)


def test_c3d_parts_hold_at_most_255_events(tmp_path):
    """EVENT arrays have one-byte dimensions: a part is cut before its 256th event."""
    ezc3d = pytest.importorskip("ezc3d")
    src = tmp_path / "busy.h5"
    truth = write_session(src, "joint", n=1200)
    hs = np.arange(0, 1200, 2)  # 600 heel strikes: > 2 x 255
    with h5py.File(src, "a") as h:
        del h["events/heel_strike"]
        h.create_dataset("events/heel_strike", data=hs)
    res = ex.export_session(src, "c3d")
    frame = truth["timeline/seq"] - truth["timeline/seq"][0]
    got, n_frames = [], 0
    for p in res.paths:
        c = ezc3d.c3d(str(p))  # readable: the 255 limit held
        start = float(c["parameters"]["GAITMON"]["PART_START_S"]["value"][0])
        ev = _events(c)
        assert len(ev) <= 255
        got += [start + t for _, lab, t in ev if lab == "Foot Strike"]
        n_frames += c["data"]["points"].shape[2]
    assert len(res.paths) == 3 and n_frames == 1200 + N_LOST
    np.testing.assert_allclose(got, frame[hs] / FS, atol=1e-5)


# ---------------------------------------------------------------------------------------------
# De-identification
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["csv", "mat", "c3d"])
def test_deidentify_removes_the_identifiers_and_keeps_the_data(tmp_path, fmt):
    if fmt == "c3d":
        pytest.importorskip("ezc3d")
    src = tmp_path / "s.h5"
    write_session(src, "raw")
    plain = ex.export_session(src, fmt, tmp_path / f"plain.{fmt}")
    anon = ex.export_session(src, fmt, tmp_path / f"anon.{fmt}", deidentify=True)
    secrets = [PATIENT, OPERATOR, NOTES, "Elmstreet", "Quillfeather"]

    def blob(paths) -> bytes:
        return b"".join(p.read_bytes() for p in paths)

    if fmt == "c3d":
        import ezc3d

        c = ezc3d.c3d(str(anon.paths[0]))
        assert c["parameters"]["SUBJECTS"]["NAMES"]["value"] == [ex.ANONYMOUS]
    # the test can fail: the identifiers are in the ordinary export (MAT: char arrays are
    # UTF-16 in v5 files, so look for both encodings)
    def found(data: bytes, s: str) -> bool:
        return s.encode("utf-8") in data or s.encode("utf-16-le") in data

    assert found(blob(plain.paths), PATIENT)
    for s in secrets:
        assert not found(blob(anon.paths), s), s
    if fmt == "csv":
        # same data rows; only the marker that named the patient changed, and the host clock
        # starts at 0 (issue 12: it dated the recording, with the wall-clock offset)
        head, a = _read_csv(plain.paths[0])
        _, b = _read_csv(anon.paths[0])
        host = head.index("host_time_s")
        keep = [k for k in range(len(head) - 1) if k != host]
        assert [[r[k] for k in keep] for r in a] == [[r[k] for k in keep] for r in b]
        host_a = np.array([float(r[host]) for r in a])
        host_b = np.array([float(r[host]) for r in b])
        np.testing.assert_allclose(host_b, host_a - host_a[0], atol=2e-6)
        assert b[150][-1] == f'turn, "fast" | asked {ex.REDACTED} to stop'
        meta = json.loads(anon.paths[1].read_text(encoding="utf-8"))
        assert meta["deidentified"] is True and "source_file" not in meta
        assert meta["session"] == {"patient_id": "", "side": "R", "operator": "", "notes": ""}
    elif fmt == "mat":
        a, b = _loadmat(plain.paths[0]), _loadmat(anon.paths[0])
        np.testing.assert_array_equal(a.joint_deg, b.joint_deg)
        np.testing.assert_array_equal(a.adc_count, b.adc_count)
    else:
        import ezc3d

        a, b = ezc3d.c3d(str(plain.paths[0])), ezc3d.c3d(str(anon.paths[0]))
        np.testing.assert_array_equal(a["data"]["points"], b["data"]["points"])
        np.testing.assert_array_equal(a["data"]["analogs"], b["data"]["analogs"])


# ---------------------------------------------------------------------------------------------
# The command: errors are one line and exit != 0; no silent overwrite
# ---------------------------------------------------------------------------------------------


def _one_line_error(capsys, argv: list[str]) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code != 0
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def test_cli_exports_and_refuses_to_overwrite(tmp_path, capsys):
    src = tmp_path / "s.h5"
    write_session(src, "joint")
    assert main(["export", str(src), "--format", "csv", "-q"]) == 0
    out = tmp_path / "s.csv"
    before = out.read_bytes()
    out.write_bytes(b"keep me")
    msg = _one_line_error(capsys, ["export", str(src), "--format", "csv"])
    assert "already exists" in msg and "--force" in msg
    assert out.read_bytes() == b"keep me"
    assert main(["export", str(src), "--format", "csv", "--force", "-q"]) == 0
    assert out.read_bytes() == before
    # the side file counts too
    out.unlink()
    msg = _one_line_error(capsys, ["export", str(src), "--format", "csv"])
    assert "s.meta.json" in msg and not out.exists()


def test_cli_bad_inputs_give_one_line_errors(tmp_path, capsys):
    # (the wording of bad-file messages belongs to gaitmon.io.session; check the gist)
    msg = _one_line_error(capsys, ["export", str(tmp_path / "nope.h5"), "--format", "mat"])
    assert "nope.h5" in msg and "exist" in msg
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"this is not hdf5" * 10)
    msg = _one_line_error(capsys, ["export", str(junk), "--format", "csv"])
    assert "junk.h5" in msg and "HDF5" in msg
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as h:
        h.attrs["format"] = "something-else"
    msg = _one_line_error(capsys, ["export", str(other), "--format", "c3d"])
    assert "not a gaitmon session" in msg
    damaged = tmp_path / "damaged.h5"
    write_session(damaged, "raw")
    with h5py.File(damaged, "a") as h:
        del h["timeline/t_s"]
    msg = _one_line_error(capsys, ["export", str(damaged), "--format", "csv"])
    assert "damaged.h5" in msg and "t_s" in msg
    assert not (tmp_path / "damaged.csv").exists()
    src = tmp_path / "s.h5"
    write_session(src, "raw")
    msg = _one_line_error(capsys, ["export", str(src), "--format", "csv", "-o",
                                   str(tmp_path / "no" / "dir" / "x.csv")])
    assert "output folder does not exist" in msg
    msg = _one_line_error(capsys, ["export", str(src), "--format", "csv", "-o", str(src)])
    assert "session file itself" in msg
    with pytest.raises(SystemExit) as e:
        main(["export", str(src), "--format", "xls"])
    assert e.value.code != 0
    assert list(tmp_path.glob("*.partial")) == [] and list(tmp_path.glob(".*partial*")) == []


def test_progress_goes_to_stderr_for_long_sessions(tmp_path, capsys, monkeypatch):
    from gaitmon.commands import export as cmd

    src = tmp_path / "s.h5"
    write_session(src, "raw", n=300)
    monkeypatch.setattr(cmd, "PROGRESS_MIN_SAMPLES", 100)
    assert main(["export", str(src), "--format", "mat"]) == 0
    cap = capsys.readouterr()
    assert "exporting mat: 100%" in cap.err
    assert "exported 300 samples (raw mode)" in cap.out


def test_nan_survives_csv_and_mat(tmp_path):
    src = tmp_path / "s.h5"
    write_session(src, "tilt")
    with h5py.File(src, "a") as h:
        h["processed/joint_deg"][7, 1] = np.nan
    ex.export_session(src, "csv")
    ex.export_session(src, "mat")
    header, rows = _read_csv(tmp_path / "s.csv")
    assert math.isnan(float(rows[7][header.index("knee_flexion_deg")]))
    assert math.isnan(_loadmat(tmp_path / "s.mat").joint_deg[7, 1])


# ---------------------------------------------------------------------------------------------
# Sessions recorded by gaitmon itself (SessionWriter + the pipeline + the simulated sensors)
# ---------------------------------------------------------------------------------------------

RECORD_SCRIPT = r"""
import os, sys
import numpy as np
from gaitmon.dsp.pipeline import Pipeline
from gaitmon.finish import close_recording
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

path, n, crash = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "crash"
counts = simulate(n, GaitModel(GaitConfig(seed=3)), SensorConfig(seed=3)).counts
np.save(path + ".counts.npy", counts)
pipe = Pipeline()
hdr = SessionHeader(mode="raw", meta=SessionMeta(patient_id="PT-REC-77", side="R",
                    operator="op", notes="n"))
w = SessionWriter(path, hdr)
for a in range(0, n, 50):
    b = min(n, a + 50)
    seq = np.arange(a, b, dtype=np.int64)
    blk = SampleBlock(FrameKind.RAW, seq, 100.0 + seq / 100.0, 1.7e9,
                      lost_before=np.zeros(b - a, np.int64), adc=counts[a:b])
    w.append(blk, pipe.process(counts[a:b]))
    if a == 500:
        w.add_marker("half way")
if crash:
    w.flush()
    os._exit(0)  # like kill -9: no close, the journal stays
close_recording(w)
"""


@pytest.mark.parametrize("crash", [False, True], ids=["clean", "killed"])
def test_export_of_a_recorded_session(tmp_path, crash):
    import subprocess
    import sys

    from gaitmon.dsp.angles import joint_angles
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import DEFAULT_TABLE
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.dsp.smoother import smooth_record_tilts

    src = tmp_path / "rec.h5"
    n = 1500
    subprocess.run([sys.executable, "-c", RECORD_SCRIPT, str(src), str(n),
                    "crash" if crash else "clean"], check=True, timeout=120)
    assert (tmp_path / "rec.h5.journal").exists() == crash
    counts = np.load(str(src) + ".counts.npy")
    res = ex.export_session(src, "csv", deidentify=True)  # recovers a killed recording first
    assert not (tmp_path / "rec.h5.journal").exists()
    header, rows = _read_csv(res.paths[0])
    assert len(rows) == n
    col = {c: i for i, c in enumerate(header)}
    got_counts = np.array([[int(r[col[f"{c.name}_count"]]) for c in CHANNELS] for r in rows])
    np.testing.assert_array_equal(got_counts, counts)
    # the pipeline run once over the whole record (chunked = whole, by the pipeline's contract)
    ref = Pipeline().process(counts)
    knee = np.array([float(r[col["knee_flexion_deg"]]) for r in rows])
    # the exported angles are the zero-lag smoother's over the whole record
    tilt = smooth_record_tilts(counts, DEFAULT_TABLE, [(0, Calibration.identity())], FS)
    want = np.degrees(joint_angles(tilt)[:, 1]).astype(np.float32)
    # the session stores the tilts at 0.01 deg, the knee is their difference (format 2),
    # and the CSV prints 4 decimals
    np.testing.assert_allclose(knee, want, rtol=0, atol=0.01 + 0.5e-4 + 1e-5)
    assert np.ptp(knee) > 20  # it really walked
    hs = np.flatnonzero([int(r[col["heel_strike"]]) for r in rows])
    assert len(hs) >= 5
    np.testing.assert_array_equal(hs, ref.heel_strike_idx)
    meta = json.loads(res.paths[1].read_text(encoding="utf-8"))
    assert meta["events"]["heel_strike_idx"] == hs.tolist()
    assert meta["root"]["recovered"] is crash
    assert [m["label"] for m in meta["markers"]] == ["half way"]
    assert b"PT-REC-77" not in res.paths[0].read_bytes() + res.paths[1].read_bytes()


# ---------------------------------------------------------------------------------------------
# The format registry, cancel
# ---------------------------------------------------------------------------------------------


def _registered_session(tmp_path: Path, fmt: str, mode: str, n: int) -> Path:
    """A fixture session for a registered format (skipped if its optional package is absent)."""
    try:
        ex.FORMATS[fmt].check_available()
    except ex.ExportError as exc:
        pytest.skip(str(exc))
    src = tmp_path / "s.h5"
    write_session(src, mode, n=n)
    return src


@pytest.mark.parametrize("fmt", list(ex.FORMATS))
def test_every_registered_format_writes_its_own_suffix(tmp_path, fmt):
    src = _registered_session(tmp_path, fmt, "joint", 200)
    res = ex.export_session(src, fmt, deidentify=False)
    if ex.FORMATS[fmt].folder:  # a dataset folder beside the file, named after it
        assert res.paths[0].is_relative_to(src.with_name(f"{src.stem}-{fmt}"))
    else:
        assert res.paths[0] == src.with_suffix(ex.FORMATS[fmt].suffix)
    assert res.paths[0].stat().st_size > 0


@pytest.mark.parametrize("fmt", list(ex.FORMATS))
def test_cancel_stops_at_the_first_progress_point_and_leaves_no_file(tmp_path, fmt):
    src = _registered_session(tmp_path, fmt, "raw", 600)
    seen: list[float] = []
    with pytest.raises(ex.ExportCancelled, match="cancelled"):
        ex.export_session(src, fmt, tmp_path / "out", progress=seen.append,
                          cancel=lambda: True, chunk_rows=100)
    assert seen == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.h5"]
    assert issubclass(ex.ExportCancelled, ex.ExportError)  # the CLI reports it in one line


def test_cancel_that_never_fires_changes_nothing(tmp_path):
    src = tmp_path / "s.h5"
    write_session(src, "raw", n=400)
    asked: list[int] = []
    ex.export_session(src, "csv", tmp_path / "a.csv", chunk_rows=100,
                      cancel=lambda: bool(asked.append(1)))
    ex.export_session(src, "csv", tmp_path / "b.csv", chunk_rows=100)
    assert len(asked) == 4  # once per chunk
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_listing_the_formats_loads_no_format_module():
    """The command-line parser reads FORMATS; that must not import numpy or a writer."""
    code = ("import sys, gaitmon.export as e;"
            "assert set(e.FORMATS) >= {'csv', 'mat', 'c3d', 'strides', 'bids'};"
            "print(sorted(m for m in sys.modules if m in ('numpy', 'scipy', 'ezc3d')"
            " or m.startswith('h5py') or m.startswith('gaitmon.analysis')"
            " or m.startswith('gaitmon.export.writers.') and m.rsplit('.', 1)[1] in e.FORMATS))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=60)
    assert out.stdout.strip() == "[]"


def test_csv_text_equals_python_percent_formatting():
    """The vectorised CSV writer gives byte for byte what ``"%.Nf" % x`` / ``"%d" % x`` give,
    including rounding ties of the exact binary value, -0, NaN, inf and out-of-range values."""
    from gaitmon.export.writers.csv_text import CsvColumn, format_block

    rng = np.random.default_rng(7)
    m = 5000
    specials = np.array([np.nan, -np.nan, np.inf, -np.inf, -0.0, 0.0, 1e12, 1e20, -1e17, 0.5,
                         1.5, 2.5, 0.125, -0.375, 1.00005, 2.00015, -1e-9, 999.99995])
    cols = [
        (rng.standard_normal(m).astype(np.float32) * 100, 4),
        (rng.standard_normal(m) * 1e4 + 1e5, 6),
        ((rng.integers(-10**7, 10**7, m) + 0.5) / 10**4, 4),  # exact ties at the 4th decimal
        ((rng.integers(-10**6, 10**6, m) + 0.5) / 10**5, 4),  # near ties (binary inexact)
        (np.resize(specials, m), 3),
        (np.resize(specials, m), 0),
        (rng.integers(0, 4096, m).astype(np.uint16), None),
        (rng.integers(-3, 4, m).astype(np.int8), None),
        (np.resize([1.7, -2.5, 1e20, -0.0, 3.0], m), None),
        (np.arange(m, dtype=np.int64) * 10**9, None),
    ]
    tails = {3: '"a, b"', 10: ""}
    got = format_block([CsvColumn(np.asarray(v), d) for v, d in cols], tails).decode()
    fmt = ",".join("%d" if d is None else f"%.{d}f" for _, d in cols) + ","
    want = "".join(fmt % tuple(float(np.asarray(v)[r]) for v, _ in cols) + tails.get(r, "")
                   + "\n" for r in range(m))
    assert got == want


def test_a_marker_without_a_label_is_a_visible_placeholder_in_csv(tmp_path: Path) -> None:
    src = tmp_path / "s.h5"
    write_session(src, "raw", n=600)
    with h5py.File(src, "r+") as h:  # a marker set with no label (the Marker button, empty box)
        mk = h["markers"]
        rows = mk[()]
        new = np.concatenate([rows, np.array([(400, 4.0, "")], dtype=rows.dtype)])
        del h["markers"]
        h.create_dataset("markers", data=new)
    res = ex.export_session(src, "csv", tmp_path / "out.csv")
    header, rows = _read_csv(res.paths[0])
    col = header.index("marker")
    assert rows[400][col] == "marker"
    assert rows[50][col] == "start walk"  # labelled markers as they were
    assert all(r[col] == "" for i, r in enumerate(rows) if i not in (50, 150, 400))
