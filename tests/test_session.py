"""Session files: what is written reads back exactly, recovery rebuilds it, bad files fail cleanly.

References are independent of the writer: ADC counts and sequence numbers from the simulator
(compared exactly), processed series from a Pipeline run over the whole record in one go (the
pipeline's chunking invariance is tested in test_pipeline), times and joint angles by hand.
"""

from __future__ import annotations

import itertools
import json
import shutil

import h5py
import numpy as np
import pytest

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import CHANNELS
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.finish import close_recording, open_session, recover_session
from gaitmon.io.decoder import DecoderStats
from gaitmon.io.device import LinkStats, SampleBlock
from gaitmon.io.journal import journal_path
from gaitmon.io.protocol import FrameKind, Identity
from gaitmon.io.session import (
    CHUNK_ROWS,
    FORMAT,
    FORMAT_VERSION,
    Gap,
    SessionError,
    SessionHeader,
    SessionMeta,
    SessionWriter,
    device_info,
)
from gaitmon.io.session.rows import _device_rows
from gaitmon.io.sim.sensors import simulate
from gaitmon.io.transport import LinkState, TransportStatus

pytestmark = pytest.mark.timeout(60)

FS = 100.0
N = 2500
COUNTS = simulate(N).counts
CAL = Calibration(np.array([0.01, -0.02, 0.03, 0.04]), np.array([0.001, 0.002, -0.003, 0.0]))
META = SessionMeta(patient_id="P-042", side="R", operator="dr. ö", notes="treadmill\n2 km/h")
DEVICE = device_info(Identity("GAITMON-1", "1.2.3", 123456, "R"), "simulated")


def _link(crc: int, ok: int) -> LinkStats:
    return LinkStats(
        decoder=DecoderStats(bytes_received=40 * ok, frames_ok=ok, crc_failures=crc),
        transport=TransportStatus(LinkState.CONNECTED, "ok", connections=2),
        streaming=True,
        kind=FrameKind.RAW,
        queue_overflow_frames=0,
        queued_frames=0,
    )


def _seq_with_losses(n: int) -> tuple[np.ndarray, np.ndarray, dict[int, int]]:
    """Sequence numbers and lost_before for n received rows: an ACK before row 300 (it used
    a sequence number, no sample is missing), 5 frames lost before row 700, and a unit
    restart before row 1500 (seq continues +1, the gap's duration carries the real time)."""
    step = np.ones(n, dtype=np.int64)
    step[300] = 2
    step[700] = 6
    seq = 1000 + np.cumsum(step) - 1
    lost = step - 1
    lost[300] = 0
    return seq, lost, {700: 5, 1500: 0}


def _record_raw(path, *, config_change_row=None, cal_row=None, close=True, copy_to=None):
    """Drive a SessionWriter as the engine would; returns (writer, what was written)."""
    rng = np.random.default_rng(7)
    seq, lost, gaps = _seq_with_losses(N)
    host = 50.0 + np.arange(N) / FS
    cfg0 = PipelineConfig()
    cfg1 = cfg0.replace(cutoff_hz=6.0)
    header = SessionHeader("raw", FS, META, DEVICE, cfg0, Calibration.identity())
    w = SessionWriter(path, header)
    pipe = Pipeline(cfg0)
    offset = 0
    i = 0
    while i < N:
        n = int(rng.integers(1, 6))
        for cut in (config_change_row, cal_row, *gaps):  # these happen at a block's start
            if cut is not None and i < cut < i + n:
                n = cut - i
        if i == config_change_row:
            w.log_config(cfg1)
            pipe = Pipeline(cfg1, pipe.calibration)
            offset = -i
        if i == cal_row:
            w.log_calibration(CAL)
            pipe.set_calibration(CAL)
        b = min(N, i + n)
        if i in gaps:
            if gaps[i]:
                w.add_gap(gaps[i], gaps[i] / FS, "frames lost")
            else:
                w.add_gap(0, 12.5, "link lost: unit restarted")
        if i <= 100 < b:
            w.add_marker("first")
        if i <= 900 < b:
            w.update_link(_link(crc=3, ok=900))
        if i <= 2000 < b:
            w.update_link(_link(crc=3, ok=2000))  # crc unchanged: no new crc log entry
            w.update_link(_link(crc=7, ok=2001))
        adc = COUNTS[i:b]
        block = SampleBlock(
            FrameKind.RAW, seq[i:b], host[i:b], 1.7e9, lost_before=lost[i:b], adc=adc
        )
        w.append(block, pipe.process(adc, lost[i:b]), event_offset=offset)
        i = b
    w.add_marker("back-dated", sample_idx=50)
    w.add_marker("after the end")
    if copy_to is not None:
        w.flush()
        for src, dst in ((path, copy_to), (journal_path(path), journal_path(copy_to))):
            shutil.copyfile(src, dst)
    if close:
        close_recording(w, stop_reason="duration")
    return w, seq, host, cfg0, cfg1


def _expected_t_s() -> np.ndarray:
    # samples at 100 Hz: row i is sample i, plus the 5 lost before row 700; the ACK before
    # row 300 takes no sample time
    k = np.arange(N, dtype=np.float64)
    k[700:] += 5
    t = k / FS
    # the restart at row 1500: one step (0.01 s) by the count, the gap says 12.5 s were lost
    t[1500:] += 12.5 + 0.01 - 0.01
    return t


def _reference(cfg0, cfg1=None, change_row=None, cal_row=None):
    """The processed series computed here, by hand-placed pipelines over the whole record."""
    rows = {}
    hs, to = [], []
    bounds = sorted({0, N, *(r for r in (change_row, cal_row) if r is not None)})
    _, lost, _ = _seq_with_losses(N)  # (5 frames lost before row 700: bridged, filled in)
    pipe = Pipeline(cfg0)
    base = 0
    parts = []
    for a, b in itertools.pairwise(bounds):
        if a == change_row:
            pipe = Pipeline(cfg1, pipe.calibration)
            base = a
        if a == cal_row:
            pipe.set_calibration(CAL)
        blk = pipe.process(COUNTS[a:b], lost[a:b])
        parts.append(blk)
        hs.append(blk.heel_strike_idx + base)
        to.append(blk.toe_off_idx + base)
    rows["processed/joint_deg"] = np.concatenate([np.degrees(p.joint_kalman_rad) for p in parts])
    rows["processed/joint_gyro_deg"] = np.concatenate(
        [np.degrees(p.joint_gyro_rad) for p in parts]
    )
    rows["processed/tilt_deg"] = np.concatenate([np.degrees(p.tilt_kalman_rad) for p in parts])
    rows["processed/tilt_gyro_deg"] = np.concatenate([np.degrees(p.tilt_gyro_rad) for p in parts])
    rows["processed/acc_ms2"] = np.concatenate([p.acc_ms2 for p in parts])
    rows["processed/fsr_counts"] = np.concatenate([p.fsr_counts for p in parts])
    rows["processed/gyro_rad_s"] = np.concatenate([p.gyro_rad_s for p in parts])
    rows["processed/phase"] = np.concatenate([p.phase for p in parts])
    rows["processed/heel_loaded"] = np.concatenate([p.heel_loaded for p in parts])
    return rows, np.concatenate(hs), np.concatenate(to)


# what format 2 promises (docs/file-format.md, "Storage"): a quantised series within half its
# resolution of the pipeline's float64 value (plus float32 rounding), a joint angle (the
# difference of two quantised tilts) within one resolution, everything else exact as float32
STATED_TOLERANCE = {
    "processed/tilt_deg": 0.005,
    "processed/tilt_gyro_deg": 0.005,
    "processed/joint_deg": 0.01,
    "processed/joint_gyro_deg": 0.01,
    "processed/acc_ms2": 0.0025,
    "processed/fsr_counts": 0.125,
}


def _check_processed(s, cfg0, cfg1=None, change_row=None, cal_row=None):
    ref, hs, to = _reference(cfg0, cfg1, change_row, cal_row)
    s.use_angles("live")  # the stored causal series (readers default to the smoothed ones)
    assert s.format_version == 2
    for name, expected in ref.items():
        got = s.read(name)
        kind = name.rsplit("/")[-1].rsplit("_")[-1]
        want = {"phase": np.int8, "loaded": np.uint8}.get(kind, np.float32)
        assert got.dtype == want, name
        tol = STATED_TOLERANCE.get(name)
        if tol is None:  # stored exactly, or derived exactly (the gyro from the counts)
            assert np.array_equal(got, expected.astype(got.dtype)), name
            continue
        err = got.astype(np.float64) - expected
        if name.endswith("_deg"):
            err = (err + 180.0) % 360.0 - 180.0
        # float32 carries ~1e-5 deg near 180 deg on top of the quantisation
        slack = 4 * np.spacing(np.float32(np.abs(expected).max()))
        assert np.abs(err).max() <= tol + slack, (name, np.abs(err).max())
        assert np.abs(err).max() > tol / 10, name  # really quantised (the test sees format 2)
    assert np.array_equal(s.heel_strike_idx, np.sort(hs))
    assert np.array_equal(s.toe_off_idx, np.sort(to))
    assert len(s.heel_strike_idx) > 10


def test_raw_session_round_trip(tmp_path):
    path = tmp_path / "s.h5"
    w, seq, host, cfg0, cfg1 = _record_raw(path, config_change_row=1200, cal_row=1800)
    assert w.rows == N
    assert not journal_path(path).exists()
    with open_session(path) as s:
        assert s.problems == []
        assert s.n_samples == N
        assert np.array_equal(s.read("raw/adc"), COUNTS)
        assert np.array_equal(s.read("timeline/seq"), seq)
        assert np.array_equal(s.read("timeline/host_time_s"), host)
        t = s.read("timeline/t_s")
        assert np.allclose(t, _expected_t_s(), rtol=0, atol=1e-9)
        assert s.duration_s == pytest.approx(t[-1] + 0.01)
        assert s.complete and not s.recovered and not s.reprocessed
        assert s.stop_reason == "duration"
        assert s.processed_source == "pc"
        assert s.wall_offset_s == 1.7e9
        _check_processed(s, cfg0, cfg1, 1200, 1800)

        assert s.meta == META
        assert s.device == DEVICE
        assert s.channels == [c.as_dict() for c in CHANNELS]
        assert s.config == cfg0
        assert s.event_delay_samples == cfg0.event_delay_samples
        assert s.config_changes == [(1200, cfg1)]
        assert np.array_equal(s.calibration.tilt_offset_rad, np.zeros(4))
        [(row, cal)] = s.calibration_changes
        assert row == 1800
        assert np.array_equal(cal.tilt_offset_rad, CAL.tilt_offset_rad)
        assert np.array_equal(cal.gyro_bias_rad_s, CAL.gyro_bias_rad_s)
        assert s.gaps == [
            Gap(700, 5, 0.05, "frames lost"),
            Gap(1500, 0, 12.5, "link lost: unit restarted"),
        ]
        labels = [m.label for m in s.markers]
        assert labels == ["first", "back-dated", "after the end"]
        first_row = s.markers[0].sample_idx
        assert 95 < first_row <= 100  # the next row when the block holding row 100 came
        assert s.markers[0].t_s == t[first_row]
        assert s.markers[1] == (50, t[50], "back-dated")
        assert s.markers[2].sample_idx == N
        assert s.markers[2].t_s == pytest.approx(t[-1] + 0.01)
        assert s.link["crc_failures"] == 7
        assert s.link["frames_ok"] == 2001
        assert s.link["reconnects"] == 1
        assert [c for _, c in s.crc_failures] == [3, 7]
        assert s.header.config == cfg0
        part = s.read_range(2490, 3000, ["raw/adc"])
        assert np.array_equal(part["raw/adc"], COUNTS[2490:])


def test_plain_h5py_reads_the_documented_layout(tmp_path):
    path = tmp_path / "s.h5"
    _record_raw(path, config_change_row=1200)
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == FORMAT
        assert f.attrs["format_version"] == 2
        assert bool(f.attrs["complete"]) is True
        assert f.attrs["n_samples"] == N
        assert f.attrs["mode"] == "raw"
        assert f["raw/adc"].dtype == np.uint16
        assert f["raw/adc"].shape == (N, 14)
        assert f["processed/acc_ms2"].shape == (N, 4, 2)
        assert f["processed/heel_loaded"].dtype == np.uint8
        assert f["session"].attrs["patient_id"] == "P-042"
        assert f["device"].attrs["serial"] == 123456
        assert f["device/channels"].shape == (14,)
        assert f["device/channels"]["name"][0].decode() == CHANNELS[0].name
        assert f["config"].attrs["cutoff_hz"] == 4.0
        change = f["config/changes"][0]
        assert change["sample_idx"] == 1200
        assert json.loads(change["json"])["cutoff_hz"] == 6.0
        assert f["markers"]["label"][0].decode() == "first"
        assert f["link/crc_failures"].shape == (2,)
        assert f["processed"].attrs["source"] == "pc"
        assert "hip" in f.attrs["angle_convention"].lower()
        assert f["timeline/seq"].chunks[0] > 1  # chunked and resizable
        assert f["timeline/seq"].maxshape == (None,)


def test_tilt_mode_stores_device_tilts_and_derives_joints(tmp_path):
    rng = np.random.default_rng(11)
    n = 300
    kal = rng.uniform(-179, 179, size=(n, 4)).round(2)
    acc = rng.uniform(-179, 179, size=(n, 4)).round(2)
    path = tmp_path / "t.h5"
    with SessionWriter(path, SessionHeader("tilt")) as w:
        for a in range(0, n, 4):
            blk = SampleBlock(
                FrameKind.TILT,
                np.arange(a, a + 4),
                np.arange(a, a + 4) / FS,
                0.0,
                acc_tilt_deg=acc[a : a + 4],
                kalman_tilt_deg=kal[a : a + 4],
            )
            w.append(blk)
    with open_session(path) as s:
        assert s.processed_source == "device"
        assert "raw/adc" not in s.dataset_names
        assert "processed/heel_loaded" not in s.dataset_names
        assert np.array_equal(s.read("processed/tilt_deg"), kal.astype(np.float32))
        assert np.array_equal(s.read("processed/tilt_acc_deg"), acc.astype(np.float32))

        def wrap180(x):
            return (x + 180.0) % 360.0 - 180.0

        b, th, sh, ft = kal.T
        hand = np.stack([wrap180(th - b), wrap180(th - sh), wrap180(ft - sh)], axis=1)
        assert np.allclose(s.read("processed/joint_deg"), hand, atol=1e-4)
        assert len(s.heel_strike_idx) == 0


def _joint_block(a, b, heel, toe):
    n = b - a
    return SampleBlock(
        FrameKind.JOINT,
        np.arange(a, b),
        np.arange(a, b) / FS,
        0.0,
        acc_joint_deg=np.full((n, 3), 1.25),
        kalman_joint_deg=np.tile([10.5, -3.25, 7.0], (n, 1)) + np.arange(a, b)[:, None],
        heel_loaded=heel[a:b],
        toe_loaded=toe[a:b],
        phase=(heel[a:b] + 3 * toe[a:b] - 2 * (heel[a:b] & toe[a:b])).astype(np.uint8),
    )


def test_joint_mode_rows_and_contact_edge_events(tmp_path):
    n = 400
    t = np.arange(n)
    heel = (t % 100) < 40  # heel strikes at 100, 200, 300 (row 0 has no past)
    toe = ((t % 100) >= 20) & ((t % 100) < 60)  # toe offs at 60, 160, 260, 360
    path = tmp_path / "j.h5"
    with SessionWriter(path, SessionHeader("joint")) as w:
        for a in range(0, n, 3):
            w.append(_joint_block(a, min(n, a + 3), heel, toe))
    with open_session(path) as s:
        assert np.array_equal(s.read("processed/heel_loaded"), heel.astype(np.uint8))
        assert np.array_equal(s.read("processed/toe_loaded"), toe.astype(np.uint8))
        assert np.array_equal(s.read("processed/phase")[:45], [1] * 20 + [2] * 20 + [3] * 5)
        assert s.read("processed/joint_deg")[5].tolist() == [15.5, 1.75, 12.0]
        assert s.heel_strike_idx.tolist() == [100, 200, 300]
        assert s.toe_off_idx.tolist() == [60, 160, 260, 360]


def test_device_rows_reject_raw_blocks():
    with pytest.raises(ValueError, match="TILT or JOINT"):
        _device_rows(FrameKind.RAW, {"adc": COUNTS[:2]})


def test_recovery_rebuilds_the_live_file(tmp_path):
    live = tmp_path / "live.h5"
    crashed = tmp_path / "crashed.h5"
    # the crashed copy is taken before close (file + journal as a kill -9 would leave them)
    _, seq, host, cfg0, cfg1 = _record_raw(
        live, config_change_row=1200, cal_row=1800, copy_to=crashed
    )
    fractions = []
    with open_session(crashed, progress=fractions.append) as s:
        assert not journal_path(crashed).exists()
        assert s.recovered and not s.complete and s.reprocessed
        assert s.stop_reason == "recovered"
        assert s.problems == []
        assert fractions[-1] == 1.0
        assert np.array_equal(s.read("raw/adc"), COUNTS)
        assert np.array_equal(s.read("timeline/seq"), seq)
        assert np.array_equal(s.read("timeline/host_time_s"), host)
        _check_processed(s, cfg0, cfg1, 1200, 1800)
        s.use_angles("smoothed")  # stored by the recovery as by the live writer's close
        with open_session(live) as ref:
            assert s.smoothed_stored and ref.smoothed_stored
            assert np.array_equal(s.read("timeline/t_s"), ref.read("timeline/t_s"))
            for name in ref.dataset_names:
                assert np.array_equal(s.read(name), ref.read(name)), name
            assert s.markers == ref.markers
            assert s.gaps == ref.gaps
            assert s.crc_failures == ref.crc_failures
            assert s.link == ref.link
            assert s.config_changes == ref.config_changes
            assert s.meta == ref.meta and s.device == ref.device
            assert s.duration_s == ref.duration_s
    with h5py.File(crashed, "r") as f:  # plain h5py after recovery
        assert f["raw/adc"].shape == (N, 14)
        assert bool(f.attrs["recovered"]) is True
        assert bool(f["processed"].attrs["reprocessed"]) is True


def test_recovery_takes_the_smoothers_first_pass_from_its_replay_and_matches_the_close(
    tmp_path, monkeypatch
):
    """With no change of settings the replayed pipeline's filter is the smoother's first pass:
    recovery keeps it instead of running the filter again, and its /smoothed equals the one the
    live recorder's close computed from the raw counts (a new calibration at row 1800, gaps)."""
    import gaitmon.dsp.smoother as smoother

    live = tmp_path / "live.h5"
    crashed = tmp_path / "crashed.h5"
    _record_raw(live, cal_row=1800, copy_to=crashed)
    ran: list[tuple[int, int]] = []
    real = smoother.CausalFirstPass.rows

    def counting(self, a, b, counts):
        ran.append((a, b))
        return real(self, a, b, counts)

    monkeypatch.setattr(smoother.CausalFirstPass, "rows", counting)
    with open_session(crashed) as s, open_session(live) as ref:
        assert s.recovered and s.smoothed_stored and ref.smoothed_stored
        assert ran == []  # taken from the replay
        s.use_angles("smoothed")
        ref.use_angles("smoothed")
        assert np.array_equal(s.read("processed/tilt_deg"), ref.read("processed/tilt_deg"))


def test_recovery_with_a_damaged_journal_tail_keeps_what_came_before(tmp_path):
    path = tmp_path / "s.h5"
    w, *_ = _record_raw(path, close=False)
    w.flush()
    jp = journal_path(path)
    w._release()  # as if killed: nothing more reaches either file
    size = jp.stat().st_size
    with open(jp, "r+b") as f:  # cut into the last record, then append garbage
        f.truncate(size - 3)
        f.seek(0, 2)
        f.write(np.random.default_rng(0).bytes(500))
    with open_session(path) as s:
        # the last record was the "after the end" marker: every row survives
        assert s.n_samples == N
        assert np.array_equal(s.read("raw/adc"), COUNTS)
        assert [m.label for m in s.markers] == ["first", "back-dated"]


def test_a_stale_journal_beside_a_complete_file_is_just_removed(tmp_path):
    path = tmp_path / "s.h5"
    _record_raw(path)
    journal_path(path).write_bytes(b"GMJRNL01 leftover")
    with open_session(path) as s:
        assert s.complete and not s.recovered
    assert not journal_path(path).exists()


def test_recovery_can_be_cancelled_and_resumed(tmp_path):
    live, crashed = tmp_path / "a.h5", tmp_path / "b.h5"
    _record_raw(live, copy_to=crashed)
    with pytest.raises(SessionError, match="cancelled"):
        recover_session(crashed, progress=lambda f: False)
    assert journal_path(crashed).exists()
    assert recover_session(crashed) == crashed
    with open_session(crashed) as s:
        assert s.recovered and s.n_samples == N


def test_journal_without_any_file_is_recovered(tmp_path):
    live, crashed = tmp_path / "a.h5", tmp_path / "b.h5"
    _record_raw(live, copy_to=crashed)
    crashed.unlink()  # e.g. killed before the HDF5 file was flushed for the first time
    with open_session(crashed) as s:
        assert s.n_samples == N


def test_empty_session(tmp_path):
    path = tmp_path / "e.h5"
    SessionWriter(path, SessionHeader("raw")).close()
    with open_session(path) as s:
        assert s.n_samples == 0 and s.duration_s == 0.0 and s.complete
        assert s.read("raw/adc").shape == (0, 14)


def test_writer_refuses_to_overwrite(tmp_path):
    path = tmp_path / "s.h5"
    SessionWriter(path, SessionHeader("raw")).close()
    with pytest.raises(SessionError, match="already exists"):
        SessionWriter(path, SessionHeader("raw"))
    path.unlink()
    journal_path(path).write_bytes(b"x")
    with pytest.raises(SessionError, match="recovered"):
        SessionWriter(path, SessionHeader("raw"))
    w = SessionWriter(path, SessionHeader("raw"), overwrite=True)
    w.close()
    assert not journal_path(path).exists()


def test_writer_rejects_misuse(tmp_path):
    w = SessionWriter(tmp_path / "s.h5", SessionHeader("raw"))
    tilt = SampleBlock(
        FrameKind.TILT,
        np.arange(1),
        np.zeros(1),
        0.0,
        acc_tilt_deg=np.zeros((1, 4)),
        kalman_tilt_deg=np.zeros((1, 4)),
    )
    with pytest.raises(ValueError, match="raw session"):
        w.append(tilt)
    raw = SampleBlock(FrameKind.RAW, np.arange(2), np.zeros(2), 0.0, adc=COUNTS[:2])
    with pytest.raises(ValueError, match="pipeline block"):
        w.append(raw)
    w.append(raw, Pipeline().process(COUNTS[:2]))
    with pytest.raises(ValueError, match="increase"):
        w.append(raw, Pipeline().process(COUNTS[:2]))
    w.close()
    with pytest.raises(SessionError, match="already stopped"):
        w.add_marker("late")
    with pytest.raises(SessionError, match="cannot create"):
        SessionWriter(tmp_path / "no such dir" / "s.h5", SessionHeader("raw"))


def test_header_validation():
    with pytest.raises(ValueError, match="mode"):
        SessionHeader("video")
    with pytest.raises(ValueError, match="side"):
        SessionMeta(side="left")
    h = SessionHeader("raw", meta=META, device=DEVICE, calibration=CAL)
    back = SessionHeader.from_dict(json.loads(json.dumps(h.as_dict())))
    assert back.meta == META and back.device == DEVICE and back.config == h.config
    assert np.array_equal(back.calibration.tilt_offset_rad, CAL.tilt_offset_rad)
    assert back.channels == CHANNELS


# --------------------------------------------------------------------------------------------
# Bad files: one-line SessionError (or partial data), never a traceback, never a hang
# --------------------------------------------------------------------------------------------


def _one_line(e: SessionError) -> str:
    msg = str(e)
    assert "\n" not in msg and 10 < len(msg) < 400
    return msg


@pytest.mark.timeout(20)
def test_missing_file(tmp_path):
    with pytest.raises(SessionError) as e:
        open_session(tmp_path / "nope.h5")
    assert "does not exist" in _one_line(e.value)


@pytest.mark.timeout(20)
def test_not_hdf5(tmp_path):
    p = tmp_path / "notes.h5"
    p.write_text("patient walked well\n")
    with pytest.raises(SessionError) as e:
        open_session(p)
    assert "not an HDF5 file" in _one_line(e.value)


@pytest.mark.timeout(20)
def test_hdf5_but_not_a_session(tmp_path):
    p = tmp_path / "other.h5"
    with h5py.File(p, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(SessionError) as e:
        open_session(p)
    assert "not a gaitmon session (no 'format' attribute)" in _one_line(e.value)
    with h5py.File(p, "a") as f:
        f.attrs["format"] = "something-else"
    with pytest.raises(SessionError, match="not a gaitmon session"):
        open_session(p)


@pytest.mark.timeout(20)
def test_newer_format_version(tmp_path):
    p = tmp_path / "s.h5"
    SessionWriter(p, SessionHeader("raw")).close()
    with h5py.File(p, "a") as f:
        f.attrs["format_version"] = FORMAT_VERSION + 1
    with pytest.raises(SessionError, match="newer gaitmon"):
        open_session(p)


@pytest.mark.timeout(30)
def test_truncated_session(tmp_path):
    p = tmp_path / "s.h5"
    _record_raw(p)
    data = p.read_bytes()
    for frac in (0.1, 0.5, 0.9):
        q = tmp_path / f"cut{frac}.h5"
        q.write_bytes(data[: int(len(data) * frac)])
        with pytest.raises(SessionError) as e, open_session(q) as s:
            for name in s.dataset_names:
                s.read(name)
        _one_line(e.value)


@pytest.mark.timeout(60)
def test_random_bytes_in_the_middle(tmp_path):
    p = tmp_path / "s.h5"
    _record_raw(p)
    data = p.read_bytes()
    rng = np.random.default_rng(5)
    outcomes = {"error": 0, "opened": 0}
    for i in range(12):
        damaged = bytearray(data)
        at = int(rng.integers(0, len(data) - 4096)) if i else 0  # i == 0: the superblock
        damaged[at : at + 512] = rng.bytes(512)
        q = tmp_path / f"d{i}.h5"
        q.write_bytes(bytes(damaged))
        try:
            with open_session(q) as s:
                for name in s.dataset_names:
                    assert len(s.read(name)) <= N
                outcomes["opened"] += 1
        except SessionError as e:
            _one_line(e)
            outcomes["error"] += 1
    assert outcomes["error"] >= 1  # at least the damaged superblock is refused


@pytest.mark.timeout(20)
def test_garbage_journal_beside_a_good_file_opens_the_file(tmp_path):
    live, crashed = tmp_path / "a.h5", tmp_path / "b.h5"
    _record_raw(live, copy_to=crashed)
    journal_path(crashed).write_bytes(np.random.default_rng(1).bytes(3000))
    with open_session(crashed) as s:
        assert any("not recovered" in p for p in s.problems)
        # format 2 writes whole compressed chunks: the rows of the chunk being filled were in
        # the (here unusable) journal only
        assert s.n_samples == N // CHUNK_ROWS * CHUNK_ROWS
        assert np.array_equal(s.read("raw/adc"), COUNTS[: s.n_samples])


@pytest.mark.timeout(30)
def test_the_file_holds_whole_chunks_and_the_journal_the_rest(tmp_path):
    """While recording, the HDF5 file receives each compressed chunk once, whole; the rows of
    the chunk being filled are in the journal (synced every 100 ms), which recovery reads."""
    n = 2 * CHUNK_ROWS + 1000
    counts = np.tile(COUNTS, (-(-n // N), 1))[:n]
    path, crashed = tmp_path / "a.h5", tmp_path / "b.h5"
    w = SessionWriter(path, SessionHeader("raw", FS))
    pipe = Pipeline()
    for a in range(0, n, 700):
        b = min(n, a + 700)
        blk = SampleBlock(FrameKind.RAW, np.arange(a, b, dtype=np.int64), a / FS + np.zeros(b - a),
                          1.7e9, lost_before=np.zeros(b - a, np.int64), adc=counts[a:b])
        w.append(blk, pipe.process(counts[a:b]))
    w.flush()
    for src, dst in ((path, crashed), (journal_path(path), journal_path(crashed))):
        shutil.copyfile(src, dst)
    close_recording(w)
    with h5py.File(crashed, "r") as f:  # the file as the crash left it
        assert f["raw/adc"].shape[0] == 2 * CHUNK_ROWS
        assert np.array_equal(f["raw/adc"][()], counts[: 2 * CHUNK_ROWS])
    with open_session(crashed) as s:  # recovered from the journal: every row, exactly
        assert s.recovered and s.n_samples == n
        assert np.array_equal(s.read("raw/adc"), counts)
        with open_session(path) as live:
            live.use_angles("live")
            s.use_angles("live")
            for name in ("processed/tilt_deg", "processed/joint_deg", "processed/gyro_rad_s"):
                assert np.array_equal(s.read(name), live.read(name)), name


@pytest.mark.timeout(20)
def test_garbage_journal_without_a_file(tmp_path):
    p = tmp_path / "s.h5"
    journal_path(p).write_bytes(b"GMJRNL01" + b"\x00" * 100)
    with pytest.raises(SessionError) as e:
        open_session(p)
    assert "journal" in _one_line(e.value)


def test_a_live_recording_is_not_recovered_under_the_writer(tmp_path):
    # e.g. `gaitmon info` run on the file the application is recording: the journal is locked
    path = tmp_path / "live.h5"
    w = SessionWriter(path, SessionHeader("raw"))
    w.append(
        SampleBlock(FrameKind.RAW, np.arange(3), np.zeros(3), 0.0, adc=COUNTS[:3]),
        Pipeline().process(COUNTS[:3]),
    )
    w.flush()
    with pytest.raises(SessionError, match="being recorded right now"):
        open_session(path)
    with pytest.raises(SessionError, match="being recorded right now"):
        recover_session(path)
    assert journal_path(path).exists()
    close_recording(w)
    with open_session(path) as s:
        assert s.complete and s.n_samples == 3
