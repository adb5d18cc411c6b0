"""Gaitmon's LSL streams built from a session file, as LabRecorder records them, for the XDF
import's tests (``tests/test_xdf_import.py``) and the example file ``docs/example-walk.xdf``:

    PYTHONPATH=. python tests/xdf_sessions.py docs/example-walk.xdf

The source session is recorded the live way (SessionWriter fed block by block by the live
Pipeline, gaps logged as the recorder logs them), so an import, which replays the pipeline over
the whole record, can be checked against an independent computation of the same numbers.
"""

from __future__ import annotations

import itertools
import json
import sys
from pathlib import Path

import numpy as np
from xdf_writer import Stream, write_xdf

from gaitmon.finish import close_recording
from gaitmon.lsl.layout import (
    ANGLE_CHANNELS,
    ANGLES_TYPE,
    EVENTS_TYPE,
    RAW_CHANNELS,
    RAW_TYPE,
    EventWord,
    event_text,
    stream_name,
)

FS = 100.0
SEND_T0 = 5000.0  # the unit's host clock (LSL local_clock) at row 0
GAITMON_OFFSET_S = 12.5  # recording clock = gaitmon host clock + this (pyxdf's clock sync)
EEG_OFFSET_S = -3.25
STIM_OFFSET_S = 40.125
# frames dropped before these rows of the unit's frame count: one, a few, more than the
# filters bridge (a restart), with the reason the recorder would give
DROPS = {400: (1, "frames lost"), 900: (5, "frames lost"), 1500: (30, "frames lost"),
         2100: (150, "link lost: reconnected")}  # fmt: skip
MARKERS = {250: "walk start", 1234: "turn", 2600: "stop"}  # row -> label


def write_source(
    path: Path, n_rows: int = 2900, seed: int = 5, drops=DROPS, markers=MARKERS
) -> Path:
    """A raw session recorded the live way: the pipeline fed 50-row blocks (split at the
    gaps, as the recorder splits them), told the frames lost, gaps and markers logged."""
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import simulate

    lost_total = sum(k for k, _ in drops.values())
    counts = simulate(n_rows + lost_total, GaitModel(GaitConfig(seed=seed, standing_s=2.0))).counts
    keep = np.ones(len(counts), bool)
    lost = np.zeros(n_rows, np.int64)
    frame = 0
    for row in range(n_rows):
        if row in drops:
            k = drops[row][0]
            keep[frame : frame + k] = False
            lost[row] = k
            frame += k
        frame += 1
    adc = counts[keep]
    seq = 17 + np.flatnonzero(keep)  # the unit's counter: it was running before the recording
    header = SessionHeader("raw", FS, meta=SessionMeta(patient_id="", side="L"),
                           device={"name": "gaitmon-sim", "firmware": "1.0.0", "serial": 4242,
                                   "side": "L", "transport": "simulated"},
                           config=PipelineConfig(cutoff_hz=5.0),
                           created_utc="2026-11-20T10:00:00Z")  # fmt: skip
    pipe = Pipeline(header.config, header.calibration)
    bounds = sorted({0, n_rows, *range(0, n_rows, 50), *drops, *markers})
    with SessionWriter(path, header) as w:
        for a, b in itertools.pairwise(bounds):
            if lost[a]:
                w.add_gap(int(lost[a]), lost[a] / FS, drops[a][1])
            for row, label in markers.items():
                if a == row:
                    w.add_marker(label)
            blk = SampleBlock(FrameKind.RAW, seq[a:b], seq[a:b] / FS, 1.7e9,
                              lost_before=lost[a:b], adc=adc[a:b])  # fmt: skip
            w.append(blk, pipe.process(adc[a:b], lost[a:b]))
        close_recording(w)  # /smoothed and /strides stored, as the recorder closes
    return path


def _desc_raw(header: dict, unit: str) -> dict:
    return {
        "acquisition": {"manufacturer": "gaitmon", "model": "gaitmon-sim",
                        "serial_number": unit, "firmware": "1.0.0", "gaitmon_version": "test"},
        "channels": {"channel": [{"label": c.label, "unit": c.unit, "type": c.type}
                                 for c in RAW_CHANNELS]},
        "gaitmon": {"mode": "raw", "fs_hz": repr(FS), "side": "L", "header": json.dumps(header)},
    }  # fmt: skip


def _acq(unit: str) -> dict:
    return {"acquisition": {"manufacturer": "gaitmon", "serial_number": unit}}


def gaitmon_streams(src: Path, unit: str = "4242", *, offset_s: float = GAITMON_OFFSET_S,
                    events: list[tuple[float, str]] = (), raw: bool = True,
                    angles: bool = True, mode: str = "raw") -> list[Stream]:  # fmt: skip
    """The three streams the outlets publish for the source session, as LabRecorder records
    them: timestamps on the gaitmon host's clock (its sample clock: row time + start) and
    clock offsets mapping it onto the recording computer's. ``events``: (row time offset in s
    from row 0 on the gaitmon clock, text) added to the event stream."""
    from gaitmon.finish import open_session

    with open_session(src) as s:
        adc = s.read("raw/adc").astype(np.int32) if raw else None
        seq = s.read("timeline/seq").astype(np.int32)
        t_s = s.read("timeline/t_s")
        angles_deg = np.hstack([s.read("processed/joint_deg"), s.read("processed/tilt_deg")])
        header = s.header.as_dict()
        gaps = list(s.gaps)
        marks = list(s.markers)
        hs = s.heel_strike_idx
    ts = SEND_T0 + t_s
    offsets = [(SEND_T0 + k, offset_s) for k in range(-5, int(t_s[-1]) + 10, 5)]
    ev: list[tuple[float, str]] = [(ts[0] - 0.5, event_text(EventWord.RECORDING_START, "x.h5"))]
    ev += [(ts[i], EventWord.HEEL_STRIKE.value) for i in hs]
    for g in gaps:
        first_lost = ts[g.sample_idx - 1] + 1 / FS
        ev.append((first_lost, event_text(EventWord.GAP_START, g.reason)))
        ev.append((ts[g.sample_idx], EventWord.GAP_END.value))
    # markers a little off their row's time, as a click between two frames is
    ev += [(ts[m.sample_idx] + 0.003, event_text(EventWord.MARKER, m.label)) for m in marks]
    ev += [(SEND_T0 + dt, text) for dt, text in events]
    ev.sort()
    out = []
    if raw:
        out.append(Stream(stream_name(unit, "raw"), RAW_TYPE, "int32", FS, ts,
                          np.column_stack([seq, adc]), len(RAW_CHANNELS),
                          desc=_desc_raw(header, unit), source_id=f"gaitmon-{unit}-raw",
                          clock_offsets=offsets))  # fmt: skip
    if angles:
        ang = angles_deg.astype(np.float32)
        if mode == "joint":
            ang[:, 3:] = np.nan
        desc = _acq(unit) | {"channels": {"channel": [{"label": c.label} for c in ANGLE_CHANNELS]}}
        if not raw:
            desc["gaitmon"] = {"mode": mode, "fs_hz": repr(FS), "side": header["session"]["side"]}
        out.append(Stream(stream_name(unit, "angles"), ANGLES_TYPE, "float32", FS, ts, ang,
                          len(ANGLE_CHANNELS), desc=desc, source_id=f"gaitmon-{unit}-angles",
                          clock_offsets=offsets))  # fmt: skip
    out.append(Stream(stream_name(unit, "events"), EVENTS_TYPE, "string", 0.0,
                      np.array([t for t, _ in ev]), [[x] for _, x in ev], 1, desc=_acq(unit),
                      source_id=f"gaitmon-{unit}-events", clock_offsets=offsets))  # fmt: skip
    return out


def eeg_stream(t0: float, t1: float, fs_hz: float = 250.0, channels: int = 8) -> Stream:
    """A foreign EEG stream on its own clock, spanning the recording and more."""
    ts = np.arange(t0 - 2.0, t1 + 2.0, 1 / fs_hz)
    data = np.random.default_rng(1).normal(size=(len(ts), channels)).astype(np.float32)
    desc = {"acquisition": {"manufacturer": "BrainAmp"}}
    return Stream(
        "EEG",
        "EEG",
        "float32",
        fs_hz,
        ts,
        data,
        channels,
        desc=desc,
        source_id="eeg-1",
        clock_offsets=[(t, EEG_OFFSET_S) for t in np.arange(t0 - 2, t1 + 2, 5.0)],
    )


def labrecorder_file(
    source: Path, path: Path, stim_rows: tuple[int, ...] = (500, 1700), eeg_channels: int = 8
) -> Path:
    """The LabRecorder file of ``source``: gaitmon's three streams, an EEG stream, and a
    stimulator's markers (named "Stimulator", on a clock 40 s off) placed at the
    recording-clock times of ``stim_rows``."""
    from gaitmon.finish import open_session

    streams = gaitmon_streams(source)
    with open_session(source) as s:
        t_s = s.read("timeline/t_s")
    stim_send = [SEND_T0 + t_s[r] + GAITMON_OFFSET_S - STIM_OFFSET_S for r in stim_rows]
    labels = [["pulse on"] if k % 2 == 0 else ["pulse off"] for k in range(len(stim_rows))]
    stim = Stream(
        "Stimulator",
        "Markers",
        "string",
        0.0,
        np.array(stim_send),
        labels,
        1,
        source_id="stim",
        clock_offsets=[(stim_send[0] - 10 + 5 * k, STIM_OFFSET_S) for k in range(12)],
    )
    eeg = eeg_stream(SEND_T0 + EEG_OFFSET_S, SEND_T0 + t_s[-1], 250.0, eeg_channels)
    return write_xdf(path, [eeg, *streams[:2], stim, streams[2]])


if __name__ == "__main__":  # the example recording of the README
    import tempfile

    out = Path(sys.argv[1] if len(sys.argv) > 1 else "example-walk.xdf")
    with tempfile.TemporaryDirectory() as tmp:
        src = write_source(
            Path(tmp) / "example.h5",
            n_rows=1500,
            seed=3,
            drops={500: (1, "frames lost"), 1000: (4, "frames lost")},
            markers={250: "walk start", 1400: "stop"},
        )
        labrecorder_file(src, out, stim_rows=(600, 1200), eeg_channels=2)
    print(f"wrote {out} ({out.stat().st_size} bytes)")
