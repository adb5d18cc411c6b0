"""The LSL outlets end to end: a real pylsl inlet receives what the engine streams.

The simulated unit runs over a real pty (the decoder, pyserial, the engine thread) at twice
real time while the engine records a session and feeds the outlets; the test's inlets
resolve the streams first (so they miss nothing), then compare what they received with the
session file the same engine wrote: every sample, the angles on the same rows, the heel
strikes on the same rows (+-1), and timestamps that follow the unit's sample clock.
"""

from __future__ import annotations

import sys
import time
import uuid

import numpy as np
import pytest

pylsl = pytest.importorskip("pylsl")

from gaitmon.engine import Engine  # noqa: E402
from gaitmon.finish import open_session  # noqa: E402
from gaitmon.io.device import Device  # noqa: E402
from gaitmon.io.session import SessionMeta  # noqa: E402
from gaitmon.io.session.codec import tolerance  # noqa: E402
from gaitmon.io.sim import GaitConfig, SimulatedUnit  # noqa: E402
from gaitmon.io.sim.pty import PtySimulator  # noqa: E402
from gaitmon.io.transport import SerialTransport  # noqa: E402
from gaitmon.lsl import layout  # noqa: E402
from gaitmon.lsl.layout import EventWord, parse_event  # noqa: E402
from gaitmon.lsl.outlets import LslOutlets  # noqa: E402

STREAMS = ("angles", "events", "raw")
# the sample clock fit learns the rate over its first 10 s of samples (trust_s, docs/lsl.md):
# those are left out of the jitter (on a loaded machine its slews then reach ~1 ms)
SETTLE_K = 1000


def _desc_channels(info) -> list[tuple[str, str, str]]:
    ch = info.desc().child("channels").child("channel")
    out = []
    while not ch.empty():
        out.append((ch.child_value("label"), ch.child_value("unit"), ch.child_value("type")))
        ch = ch.next_sibling()
    return out


@pytest.fixture(scope="module")
def streamed(tmp_path_factory):
    """(received per stream, infos, session path, outlets) of ~8 s of simulated walking."""
    unit_id = f"test{uuid.uuid4().hex[:8]}"  # other LSL streams on this machine: not ours
    out = tmp_path_factory.mktemp("lsl") / "walk.h5"
    unit = SimulatedUnit(GaitConfig(seed=5, standing_s=1.5), speed=2.0)
    inlets: dict[str, pylsl.StreamInlet] = {}
    got: dict[str, list] = {s: [] for s in STREAMS}
    with PtySimulator(unit) as sim:
        eng = Engine(Device(SerialTransport(str(sim.link_path))), "raw", transport_label="pty")
        holder: dict[str, LslOutlets] = {}

        def before_stream() -> None:
            eng.start_recording(out, SessionMeta(patient_id="P-SECRET", side="R"))
            holder["o"] = LslOutlets.attach(
                eng, SessionMeta(patient_id="P-SECRET", side="R"), unit=unit_id
            )
            for s in STREAMS:
                found = pylsl.resolve_byprop("source_id", layout.source_id(unit_id, s), 1, 10.0)
                assert found, f"the {s} stream was not found"
                inlets[s] = pylsl.StreamInlet(found[0], max_buflen=60, recover=False)
                inlets[s].open_stream(timeout=10.0)

        def pull() -> None:
            for s, inlet in inlets.items():
                data, ts = inlet.pull_chunk(timeout=0.0)
                if ts:
                    got[s].append((data, ts))

        eng.start(before_stream=before_stream)
        outlets = holder["o"]
        deadline = time.monotonic() + 60
        while eng.samples_total < 800 and time.monotonic() < deadline:
            pull()
            time.sleep(0.02)
        eng.add_marker("turn")
        eng.apply_config(eng.config.replace(cutoff_hz=5.0))  # goes out as a config event
        while eng.samples_total < 2200 and time.monotonic() < deadline:
            pull()
            time.sleep(0.02)
        eng.stop()  # the recording stops, then the engine (the last event goes out)
        infos = {s: inlets[s].info() for s in STREAMS}
        pushed = outlets.samples_pushed
        t_end = time.monotonic() + 30
        while time.monotonic() < t_end:
            pull()
            n = min(sum(len(ts) for _d, ts in got[s]) for s in ("angles", "raw"))
            words = [parse_event(d[0])[0] for c in got["events"] for d in c[0]]
            if n >= pushed and EventWord.RECORDING_STOP in words:
                break
            time.sleep(0.02)
        outlets.detach()
    received = {}
    for s in STREAMS:
        ts = np.concatenate([np.asarray(t) for _d, t in got[s]]) if got[s] else np.zeros(0)
        if s == "events":
            data = [d[0] for c in got[s] for d in c[0]]
        else:
            data = np.concatenate([np.asarray(d) for d, _t in got[s]])
        received[s] = (data, ts)
    return received, infos, out, outlets, eng.samples_total


def test_inlet_receives_every_sample(streamed):
    received, _infos, _path, outlets, total = streamed
    angles, ts = received["angles"]
    assert total >= 2200
    assert outlets.samples_pushed == total
    assert len(ts) >= 0.99 * total
    assert angles.shape[1] == len(layout.ANGLE_CHANNELS) == 7
    raw, raw_ts = received["raw"]
    assert len(raw_ts) >= 0.99 * total
    assert raw.shape[1] == 15


def test_timestamps_follow_the_sample_clock_within_a_millisecond(streamed):
    """Residual of each timestamp against a straight line through (frame counter, time):
    the link's jitter (reads of several frames at once, a loaded machine) does not reach it."""
    received, _infos, _path, _outlets, _total = streamed
    raw, ts = received["raw"]
    seq = raw[:, 0].astype(np.float64)
    assert np.all(np.diff(ts) > 0)  # from the first sample: never back (XDF readers need it)
    late = seq >= seq[0] + SETTLE_K
    assert late.sum() >= 1000
    coef = np.polyfit(seq[late], ts[late], 1)
    resid = ts[late] - np.polyval(coef, seq[late])
    assert np.abs(resid).max() <= 1e-3, np.abs(resid).max()
    # the slope is the unit's sample period on the host's clock: 1 / (100 Hz x speed 2)
    assert coef[0] == pytest.approx(0.005, rel=1e-3)
    # and the stamps are LSL's clock: near now, not the monotonic clock's origin
    assert abs(ts[-1] - pylsl.local_clock()) < 30


def test_angles_equal_the_recorded_live_angles_on_the_same_rows(streamed):
    received, _infos, path, _outlets, _total = streamed
    angles, _ts = received["angles"]
    raw, _rts = received["raw"]
    with open_session(path) as s:
        s.use_angles("live")
        seq = s.read("timeline/seq")
        rows = np.searchsorted(seq, raw[:, 0])
        ok = (rows < len(seq)) & (seq[np.minimum(rows, len(seq) - 1)] == raw[:, 0])
        # every recorded row was streamed (the outlets opened before the first block), and
        # what was streamed beyond them came after the recording stopped (the engine streams
        # on for a block or more while it stops, longer on a busy machine)
        assert ok.sum() == len(seq) and ok[: ok.sum()].all()
        assert (raw[~ok, 0] > seq[-1]).all()
        rows = rows[ok]
        joints = s.read("processed/joint_deg")[rows]
        tilts = s.read("processed/tilt_deg")[rows]
        adc = s.read("raw/adc")[rows]
    got = angles[ok]
    assert np.array_equal(raw[ok, 1:], adc.astype(np.int32))  # the raw counts, exactly
    tol_j = tolerance("processed/joint_deg") + 1e-4  # the file stores centidegrees
    tol_t = tolerance("processed/tilt_deg") + 1e-4
    assert np.isfinite(got).all()
    assert np.abs(got[:, :3] - joints).max() <= tol_j
    assert np.abs(got[:, 3:] - tilts).max() <= tol_t


def test_heel_strikes_are_stamped_at_the_files_rows(streamed):
    received, _infos, path, _outlets, _total = streamed
    events, ev_ts = received["events"]
    raw, ts = received["raw"]
    words = [parse_event(e) for e in events]
    hs_ts = np.array([t for (w, _r), t in zip(words, ev_ts, strict=True)
                      if w is EventWord.HEEL_STRIKE])  # fmt: skip
    assert len(hs_ts) >= 5
    # the sample each event is stamped at, through the raw stream's own (timestamp, counter)
    # pairs: an event carries exactly the stamp its sample was pushed with, although it is
    # confirmed up to a stride later, when the clock fit has moved on (by milliseconds while
    # it settles: the first heel strike was 2.7 ms off its sample once)
    near = np.abs(ts[None, :] - hs_ts[:, None]).argmin(axis=1)
    assert np.abs(ts[near] - hs_ts).max() < 1e-6
    with open_session(path) as s:
        seq = s.read("timeline/seq")
        file_hs = np.asarray(s.heel_strike_idx)
    rows = np.searchsorted(seq, raw[near, 0])
    # the stream goes on a moment after the file stops: a heel strike on the file's last
    # rows may be confirmed only after the recording stopped (with the force-sensor check
    # on, a stride's events are decided up to a stride and 0.75 s later)
    settled = rows[rows < len(seq) - 250]
    assert len(file_hs) >= len(settled) >= 5
    for r in settled:
        assert np.abs(file_hs - r).min() <= 1
    for r in file_hs:  # and none of the file's is missing from the stream
        assert np.abs(rows - r).min() <= 1
    kinds = {w for w, _r in words}
    assert {EventWord.TOE_OFF, EventWord.MARKER, EventWord.RECORDING_START,
            EventWord.RECORDING_STOP} <= kinds  # fmt: skip
    assert "turn" in {r for w, r in words if w is EventWord.MARKER}


def test_a_settings_change_goes_out_at_the_files_row(streamed):
    """``config <json>`` on the events stream, stamped at the row the file logs it at."""
    import json

    received, _infos, path, _outlets, _total = streamed
    events, ev_ts = received["events"]
    raw, ts = received["raw"]
    words = [parse_event(e) for e in events]
    changes = [
        (json.loads(rest), t)
        for (w, rest), t in zip(words, ev_ts, strict=True)
        if w is EventWord.CONFIG
    ]
    # the settings in force when the inlet subscribed (it may have missed earlier changes),
    # then the change
    assert [c["cutoff_hz"] for c, _t in changes] == [4.0, 5.0]
    t = changes[1][1]
    with open_session(path) as s:
        seq = s.read("timeline/seq")
        (row, logged), = s.config_changes
    assert logged.cutoff_hz == 5.0
    at = int(np.abs(ts - t).argmin())
    assert abs(ts[at] - t) < 0.5 / 200  # stamped on a sample: the one of the file's row
    assert int(np.searchsorted(seq, raw[at, 0])) == row


def test_descriptions_say_channels_units_and_hide_the_patient(streamed):
    _received, infos, _path, outlets, _total = streamed
    want = {
        "angles": [(c.label, c.unit, c.type) for c in layout.ANGLE_CHANNELS],
        "raw": [(c.label, c.unit, c.type) for c in layout.RAW_CHANNELS],
    }
    for s, channels in want.items():
        assert _desc_channels(infos[s]) == channels
    a = infos["angles"]
    assert a.type() == layout.ANGLES_TYPE and a.nominal_srate() == 100.0
    assert a.channel_format() == pylsl.cf_float32
    assert infos["raw"].channel_format() == pylsl.cf_int32
    assert infos["events"].nominal_srate() == pylsl.IRREGULAR_RATE
    acq = a.desc().child("acquisition")
    assert acq.child_value("manufacturer") == layout.MANUFACTURER
    assert acq.child_value("model") == "gaitmon-sim"
    # the XDF MoCap convention: Euler-angle channel types, each channel's object, and the lag
    # taken out of the timestamps (the events': the low-pass delay their dates are moved back)
    ch = a.desc().child("channels").child("channel")
    objects = []
    while not ch.empty():
        objects.append(ch.child_value("object"))
        ch = ch.next_sibling()
    assert objects == ["hip", "knee", "ankle", "body", "thigh", "shank", "foot"]
    assert {c.type for c in layout.ANGLE_CHANNELS} == {"OrientationP"}
    lag = {s: float(infos[s].desc().child("acquisition").child_value("compensated_lag"))
           for s in STREAMS}  # fmt: skip
    from gaitmon.dsp.pipeline import PipelineConfig

    delay = PipelineConfig().event_delay_samples  # the settings the outlets opened with
    assert delay > 0 and lag == {"angles": 0.0, "raw": 0.0, "events": delay / 100.0}
    assert {s: infos[s].desc().child("gaitmon").child_value("stream") for s in STREAMS} == {
        s: s for s in STREAMS}
    g = infos["raw"].desc().child("gaitmon")
    assert g.child_value("mode") == "raw" and g.child_value("side") == "R"
    assert g.child("subject_id").empty()
    import json

    header = json.loads(g.child_value("header"))
    assert header["session"]["patient_id"] == ""
    assert header["sample_rate_hz"] == 100.0 and header["mode"] == "raw"
    for s in STREAMS:
        assert "P-SECRET" not in infos[s].as_xml()
    assert outlets.names[0].endswith(" angles")


def test_patient_id_goes_out_only_when_allowed():
    from types import SimpleNamespace

    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.engine import Mode
    from gaitmon.io.protocol import Identity

    engine = SimpleNamespace(
        identity=Identity("gaitmon-sim", "1.0.0", 1, "R"), mode=Mode.TILT, fs_hz=100.0,
        transport_label="x", config=PipelineConfig(), calibration=Calibration.identity(),
    )  # fmt: skip
    o = LslOutlets(engine, SessionMeta(patient_id="P-OK"), allow_patient_id=True,  # type: ignore[arg-type]
                   unit=f"test{uuid.uuid4().hex[:8]}")  # fmt: skip
    try:
        assert o.raw is None  # tilt mode: no raw stream
        assert o._info("angles").desc().child("gaitmon").child_value("subject_id") == "P-OK"
        assert o.header_dict()["session"]["patient_id"] == "P-OK"
    finally:
        o.close()


def test_record_without_lsl_never_imports_pylsl(tmp_path, monkeypatch, capsys):
    """--lsl off: pylsl is not imported, so no LSL socket can exist; with it on and pylsl
    missing, one line says what to install."""
    from gaitmon.cli import main

    monkeypatch.setitem(sys.modules, "pylsl", None)  # importing it now raises ImportError
    out = tmp_path / "s.h5"
    args = ["record", "--simulate", "--duration", "0.5", "--speed", "5", "-o", str(out), "-q"]
    assert main(args) == 0
    assert out.exists()
    assert main([*args[:-1], "--force", "--lsl"]) == 2
    assert "install gaitmon[lsl]" in capsys.readouterr().err


def test_gaitmon_record_lsl_streams_while_it_records(tmp_path):
    """The README's command, as written but shorter: LSL tools see the streams while it runs,
    with the patient id only because --lsl-patient-id allows it."""
    import os
    import subprocess

    out = tmp_path / "walk.h5"
    since = pylsl.local_clock()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "record", "--simulate", "--lsl", "--duration", "8",
         "--speed", "2", "--patient", "P9", "--lsl-patient-id", "-o", str(out)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, text=True,
    )  # fmt: skip
    try:
        ours = []
        deadline = time.monotonic() + 120  # a loaded machine starts it slowly
        while not ours and time.monotonic() < deadline and proc.poll() is None:
            found = pylsl.resolve_byprop("source_id", "gaitmon-sim-angles", 0, 1.0)
            ours = [i for i in found if i.created_at() >= since]  # not another run's
        assert ours, "gaitmon record --lsl published no angles stream"
        inlet = pylsl.StreamInlet(ours[0], recover=False)
        info = inlet.info(timeout=5.0)
        got = 0
        t_end = time.monotonic() + 20
        while got < 200 and time.monotonic() < t_end:
            _d, ts = inlet.pull_chunk(timeout=0.2)
            got += len(ts)
        assert got >= 200
        assert info.desc().child("gaitmon").child_value("subject_id") == "P9"
        assert _desc_channels(info)[0] == ("hip_flexion", "degrees", "OrientationP")
    finally:
        _out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "streaming to LSL as 'gaitmon sim angles'" in err
    with open_session(out) as s:
        assert s.n_samples >= 790


def test_gaitmon_record_without_lsl_publishes_no_stream(tmp_path):
    """Watched from outside, as LabRecorder would: while `gaitmon record` runs without --lsl,
    no gaitmon stream appears on the network. The watcher is this run's own LSL session
    (conftest), so another run's streams on this machine are not seen; one continuous
    resolver, polled while the process runs (liblsl's one-shot resolves overran their
    timeout by seconds on a loaded machine)."""
    import os
    import subprocess

    since = pylsl.local_clock()
    resolver = pylsl.ContinuousResolver(pred="starts-with(name,'gaitmon sim')", forget_after=60.0)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen(
        [sys.executable, "-m", "gaitmon", "record", "--simulate", "--duration", "6",
         "--speed", "2", "-q", "-o", str(tmp_path / "s.h5")],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, text=True,
    )  # fmt: skip
    try:
        seen: list[str] = []
        deadline = time.monotonic() + 240
        while proc.poll() is None and time.monotonic() < deadline:  # as long as it runs
            seen += [i.name() for i in resolver.results() if i.created_at() >= since]
            time.sleep(0.05)
        seen += [i.name() for i in resolver.results() if i.created_at() >= since]
    finally:
        _out, err = proc.communicate(timeout=240)
        del resolver
    assert proc.returncode == 0, err
    assert seen == []


def test_a_labrecorder_file_of_the_streams_imports_as_the_recorded_session(streamed, tmp_path):
    """The streams as the inlets received them, written as LabRecorder writes them (each
    stream's own info XML as its header; tests/xdf_writer.py), then `gaitmon import`: the
    session it rebuilds holds the recorded file's raw counts on the same frame counters, and
    the marker and the settings change on their rows."""
    from xdf_writer import Stream, write_xdf

    from gaitmon.lsl.xdf_import import import_xdf

    received, infos, path, _outlets, _total = streamed

    class AsReceived(Stream):
        xml: bytes = b""

        def header_xml(self) -> bytes:
            return self.xml  # what LabRecorder stores: the stream's info as LSL sent it

    streams = []
    for s, fmt in (("raw", "int32"), ("angles", "float32"), ("events", "string")):
        data, ts = received[s]
        series = [[e] for e in data] if s == "events" else data
        info = infos[s]
        st = AsReceived(info.name(), info.type(), fmt, info.nominal_srate(), np.asarray(ts),
                        series, info.channel_count(), source_id=info.source_id())  # fmt: skip
        st.xml = info.as_xml().encode("utf-8")
        streams.append(st)
    xdf = write_xdf(tmp_path / "lab.xdf", streams)
    imported = tmp_path / "imported.h5"
    import_xdf(xdf, imported)
    with open_session(path) as rec, open_session(imported) as imp:
        seq_rec, seq_imp = rec.read("timeline/seq"), imp.read("timeline/seq")
        common, i_rec, i_imp = np.intersect1d(seq_rec, seq_imp, return_indices=True)
        assert len(common) >= 0.95 * len(seq_rec)
        assert np.array_equal(rec.read("raw/adc")[i_rec], imp.read("raw/adc")[i_imp])
        assert imp.header.meta.patient_id == ""  # not let out: not in the lab's file either
        turn = [m for m in imp.markers if m.label == "turn"]
        rec_turn = [m for m in rec.markers if m.label == "turn"]
        assert len(turn) == 1 and len(rec_turn) == 1
        row_rec = rec_turn[0].sample_idx
        assert seq_imp[turn[0].sample_idx] == seq_rec[row_rec]
        (row_c, _cfg), = [c for c in imp.config_changes if c[1].cutoff_hz == 5.0]
        assert seq_imp[row_c] == seq_rec[rec.config_changes[0][0]]


def test_a_late_subscriber_gets_the_calibration_in_force():
    """LabRecorder subscribing after a Zero: the zero's ``calibration`` event went out before
    it listened, and the stream descriptions still hold the calibration the outlets opened with,
    so the one in force goes out again when the events stream gains a consumer."""
    import json

    unit_id = f"test{uuid.uuid4().hex[:8]}"
    unit = SimulatedUnit(GaitConfig(seed=6, standing_s=4.0), speed=2.0)
    got: list[tuple[str, float]] = []
    with PtySimulator(unit) as sim:
        eng = Engine(Device(SerialTransport(str(sim.link_path))), "raw", transport_label="pty")
        holder: dict[str, LslOutlets] = {}
        eng.start(before_stream=lambda: holder.setdefault(
            "o", LslOutlets.attach(eng, SessionMeta(side="R"), unit=unit_id)))  # fmt: skip
        try:
            deadline = time.monotonic() + 30
            while eng.samples_total < 200 and time.monotonic() < deadline:
                time.sleep(0.02)
            zeroed = eng.zero()  # standing still: the calibration changes, nobody listens yet
            while eng.calibration != zeroed and time.monotonic() < deadline:
                time.sleep(0.02)
            found = pylsl.resolve_byprop("source_id", layout.source_id(unit_id, "events"), 1, 10)
            assert found
            inlet = pylsl.StreamInlet(found[0], max_buflen=60, recover=False)
            inlet.open_stream(timeout=10.0)
            end = time.monotonic() + 30
            while time.monotonic() < end and not any(
                parse_event(e)[0] is EventWord.CALIBRATION for e, _t in got
            ):
                data, ts = inlet.pull_chunk(timeout=0.1)
                got += [(d[0], t) for d, t in zip(data, ts, strict=True)]
        finally:
            eng.stop()
            holder["o"].detach()
    cals = [json.loads(parse_event(e)[1]) for e, _t in got
            if parse_event(e)[0] is EventWord.CALIBRATION]  # fmt: skip
    assert cals, [parse_event(e)[0] for e, _t in got]
    assert cals[0] == zeroed.as_dict()
    assert any(abs(v) > 1e-6 for v in zeroed.tilt_offset_rad)  # (a real change, not zeros)
