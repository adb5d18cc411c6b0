"""``gaitmon import FILE.xdf``: a LabRecorder file of gaitmon's streams becomes a session.

The XDF files are written here by ``tests/xdf_writer.py`` (from the XDF specification) and
read by pyxdf: the streams are built from a source session recorded the live way
(SessionWriter fed block by block by the live Pipeline, gaps logged as the recorder logs them),
so the import, which replays the pipeline over the whole record, is checked against an
independent computation of the same numbers.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyxdf")

from xdf_sessions import (
    DROPS,
    MARKERS,
    eeg_stream,
    gaitmon_streams,
    labrecorder_file,
    write_source,
)
from xdf_writer import write_xdf

from gaitmon.lsl.layout import (
    EventWord,
    event_text,
)


@pytest.fixture(scope="module")
def source(tmp_path_factory) -> Path:
    return write_source(tmp_path_factory.mktemp("xdf") / "source.h5")


@pytest.fixture(scope="module")
def recording(source, tmp_path_factory) -> Path:
    """The LabRecorder file: gaitmon's three streams, an EEG stream, a stimulator's markers
    (on a clock 40 s off, placed at the recording-clock times of rows 500 and 1700)."""
    return labrecorder_file(source, tmp_path_factory.mktemp("xdf") / "walk.xdf")


@pytest.fixture(scope="module")
def imported(recording) -> Path:
    from gaitmon.cli import main

    out = recording.with_name("walk_imported.h5")
    assert main(["import", str(recording), "-o", str(out), "--markers-from", "Stimulator",
                 "-q"]) == 0  # fmt: skip
    return out


def test_counts_timeline_and_gaps_as_recorded(source, imported):
    from gaitmon.finish import open_session

    with open_session(source) as a, open_session(imported) as b:
        assert b.mode == "raw" and b.complete and not b.recovered
        assert np.array_equal(a.read("raw/adc"), b.read("raw/adc"))  # bit-exact
        assert b.read("raw/adc").dtype == a.read("raw/adc").dtype
        assert np.array_equal(a.read("timeline/seq"), b.read("timeline/seq"))
        assert np.array_equal(a.read("timeline/t_s"), b.read("timeline/t_s"))
        got = [(g.sample_idx, g.n_lost, g.reason) for g in b.gaps]
        assert got == [(row, k, why) for row, (k, why) in DROPS.items()]
        assert [(g.sample_idx, g.n_lost, g.duration_s, g.reason) for g in a.gaps] == [
            (g.sample_idx, g.n_lost, g.duration_s, g.reason) for g in b.gaps
        ]
        assert b.header.meta.side == "L" and b.device["serial"] == 4242
        assert b.config == a.config and b.config.cutoff_hz == 5.0
        assert "walk.xdf" in b.stop_reason


def test_processed_series_equal_the_live_recording(source, imported):
    """The import replays the pipeline over the whole record; the source was processed block
    by block as it arrived, restarts after the long gap included: the same numbers."""
    import h5py

    from gaitmon.finish import open_session

    with h5py.File(source, "r") as fa, h5py.File(imported, "r") as fb:
        names: list[str] = []
        for group in ("processed", "smoothed", "events", "overview"):
            fa[group].visititems(lambda name, obj, g=group: names.append(f"{g}/{name}")
                                 if isinstance(obj, h5py.Dataset) else None)  # fmt: skip
        assert {"processed/tilt_deg", "smoothed/tilt_deg", "events/heel_strike"} <= set(names)
        for path in names:  # as stored: the quantised codes, bit for bit
            x, y = fa[path][()], fb[path][()]
            assert x.dtype == y.dtype, path
            assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), path
    with open_session(source) as a, open_session(imported) as b:
        for source_of_angles in ("smoothed", "live"):
            for path in ("processed/tilt_deg", "processed/joint_deg"):
                assert np.array_equal(a.with_angles(source_of_angles).read(path),
                                      b.with_angles(source_of_angles).read(path))  # fmt: skip
        assert np.array_equal(a.heel_strike_idx, b.heel_strike_idx)
        assert len(b.heel_strike_idx) > 10
        assert np.array_equal(a.toe_off_idx, b.toe_off_idx)
        assert "overview" in b.h5


def test_markers_on_their_rows(source, imported):
    """gaitmon's markers on their rows; the stimulator's (its clock 40 s off the recording
    computer's, 27.6 s off gaitmon's) on the rows it was placed at: the clocks synchronised."""
    from gaitmon.finish import open_session

    with open_session(imported) as b:
        got = sorted((m.sample_idx, m.label) for m in b.markers)
    want = sorted([*MARKERS.items(), (500, "pulse on"), (1700, "pulse off")])
    assert [label for _, label in got] == [label for _, label in want]
    for (row, _), (want_row, _) in zip(got, want, strict=True):
        assert abs(row - want_row) <= 1
    assert [r for r, _ in got if _ in MARKERS.values()] == sorted(MARKERS)


def _strides_line(capsys, path: Path) -> str:
    from gaitmon.cli import main

    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    return next(line for line in out.splitlines() if line.strip().startswith("strides"))


def test_info_agrees_with_the_source(source, imported, capsys):
    a, b = _strides_line(capsys, source), _strides_line(capsys, imported)
    assert re.search(r"\d+ included", a)
    assert a == b


def test_review_report_and_export_read_it(source, imported, tmp_path):
    """The imported file opens in review (the model the window shows), gives the source's
    report (strides, losses, cycles) and exports."""
    from gaitmon.cli import main
    from gaitmon.finish import open_session
    from gaitmon.report import gather_report
    from gaitmon.review.model import open_document

    a_doc, b_doc = open_document(source), open_document(imported)
    try:
        assert b_doc.n_rows == a_doc.n_rows == 2900
        assert np.array_equal(b_doc.gaps[0], a_doc.gaps[0])
        assert np.array_equal(b_doc.gaps[1], a_doc.gaps[1])
        assert np.array_equal(b_doc.t_s, a_doc.t_s)
    finally:
        a_doc.close()
        b_doc.close()
    with open_session(source) as a, open_session(imported) as b:
        ra, rb = gather_report(a), gather_report(b)
    assert len(rb.rows) == len(ra.rows) > 10
    assert rb.summary == ra.summary
    assert np.array_equal(rb.mean_deg, ra.mean_deg, equal_nan=True)
    assert (rb.losses.frames_lost, rb.losses.n_gaps) == (ra.losses.frames_lost, 4)
    out = tmp_path / "w.csv"
    assert main(["export", str(imported), "--format", "csv", "-o", str(out), "--quiet"]) == 0
    assert out.stat().st_size > 10_000


def test_settings_change_applies_from_its_row(source, tmp_path):
    """A ``config`` event mid-recording: the rows before it keep the recorded settings, the
    rows after it change, and the file lists the change at its row; an event repeating the
    settings in force changes nothing."""
    from gaitmon.cli import main
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.finish import open_session

    with open_session(source) as s:
        t_s = s.read("timeline/t_s")
        same = s.config.as_dict()
    new = PipelineConfig(cutoff_hz=2.0).as_dict()
    row = 1800
    events = [(t_s[300], event_text(EventWord.CONFIG, json.dumps(same))),
              (t_s[row] + 0.002, event_text(EventWord.CONFIG, json.dumps(new)))]  # fmt: skip
    xdf = write_xdf(tmp_path / "change.xdf", gaitmon_streams(source, events=events))
    out = tmp_path / "change.h5"
    assert main(["import", str(xdf), "-o", str(out), "-q"]) == 0
    with open_session(source) as a, open_session(out) as b:
        assert [(i, c.cutoff_hz) for i, c in b.config_changes] == [(row, 2.0)]
        ta = a.with_angles("live").read("processed/tilt_deg")
        tb = b.with_angles("live").read("processed/tilt_deg")
        assert np.array_equal(ta[:row], tb[:row])
        assert not np.allclose(ta[row + 50 :], tb[row + 50 :], atol=0.05)


def test_calibration_change_applies_from_its_row(source, tmp_path):
    """A ``calibration`` event (the standing pose zeroed mid-recording): from its row on the
    tilts are relative to the new offsets, in the live and the smoothed angles alike."""
    from gaitmon.cli import main
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.finish import open_session

    with open_session(source) as s:
        t_s = s.read("timeline/t_s")
    offsets_rad = np.radians([1.0, -2.0, 3.0, 4.0])
    cal = Calibration(offsets_rad, np.zeros(4))
    row = 2400
    events = [(t_s[row] - 0.003, event_text(EventWord.CALIBRATION, json.dumps(cal.as_dict())))]
    xdf = write_xdf(tmp_path / "cal.xdf", gaitmon_streams(source, events=events))
    out = tmp_path / "cal.h5"
    assert main(["import", str(xdf), "-o", str(out), "-q"]) == 0
    with open_session(source) as a, open_session(out) as b:
        assert [(i, list(c.tilt_offset_rad)) for i, c in b.calibration_changes] == [
            (row, list(offsets_rad))
        ]
        for angles in ("live", "smoothed"):
            ta = a.with_angles(angles).read("processed/tilt_deg").astype(np.float64)
            tb = b.with_angles(angles).read("processed/tilt_deg").astype(np.float64)
            assert np.array_equal(ta[:row], tb[:row]), angles
            # the live filter carries its state across the change: the offset shows once it
            # has settled; the smoother sees the whole record
            diff = np.median(ta[row + 200 :] - tb[row + 200 :], axis=0)
            assert np.allclose(diff, [1.0, -2.0, 3.0, 4.0], atol=0.05), (angles, diff)


def _run(argv, capsys) -> tuple[int, str]:
    from gaitmon.cli import main

    rc = main(argv)
    err = capsys.readouterr().err.strip()
    return rc, err


def test_not_an_xdf_file(tmp_path, capsys):
    bad = tmp_path / "notes.xdf"
    bad.write_text("hello")
    rc, err = _run(["import", str(bad)], capsys)
    assert rc == 2 and "not an XDF file" in err and len(err.splitlines()) == 1
    rc, err = _run(["import", str(tmp_path / "missing.xdf")], capsys)
    assert rc == 2 and "does not exist" in err


def test_the_recording_is_never_overwritten(recording, capsys):
    before = recording.read_bytes()
    rc, err = _run(["import", str(recording), "-o", str(recording), "--force"], capsys)
    assert rc == 2 and "itself" in err
    assert recording.read_bytes() == before


def test_no_gaitmon_stream(tmp_path, capsys):
    xdf = write_xdf(tmp_path / "eeg.xdf", [eeg_stream(100.0, 110.0)])
    rc, err = _run(["import", str(xdf)], capsys)
    assert rc == 2 and "no gaitmon stream" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "eeg.h5").exists()


def test_two_units_need_unit(source, tmp_path, capsys):
    streams = gaitmon_streams(source, "4242") + gaitmon_streams(source, "77")
    xdf = write_xdf(tmp_path / "two.xdf", streams)
    rc, err = _run(["import", str(xdf)], capsys)
    assert rc == 2 and len(err.splitlines()) == 1
    assert "4242" in err and "77" in err and "--unit" in err
    rc, err = _run(["import", str(xdf), "--unit", "77", "-q"], capsys)
    assert rc == 0, err
    assert (tmp_path / "two.h5").exists()
    rc, err = _run(["import", str(xdf), "--unit", "5", "--force"], capsys)
    assert rc == 2 and "no gaitmon unit 5" in err


def test_truncated_file(recording, tmp_path, capsys):
    data = recording.read_bytes()
    cut = tmp_path / "cut.xdf"
    cut.write_bytes(data[: len(data) * 2 // 3])
    rc, err = _run(["import", str(cut)], capsys)
    assert rc == 2 and "cut short" in err and "--partial" in err and len(err.splitlines()) == 1
    assert "Traceback" not in err
    assert not (tmp_path / "cut.h5").exists()
    rc, err = _run(["import", str(cut), "--partial"], capsys)
    assert rc == 0, err
    assert "cut short" in err
    from gaitmon.finish import open_session

    with open_session(tmp_path / "cut.h5") as s:
        assert 500 < s.n_samples < 2900


def test_cut_inside_the_header_is_one_line(recording, tmp_path, capsys):
    cut = tmp_path / "head.xdf"
    cut.write_bytes(recording.read_bytes()[:300])
    rc, err = _run(["import", str(cut)], capsys)
    assert rc == 2 and len(err.splitlines()) == 1 and "Traceback" not in err


def test_joint_angles_without_raw_stream_said_in_one_line(source, tmp_path, capsys):
    xdf = write_xdf(tmp_path / "angles.xdf", gaitmon_streams(source, raw=False, mode="joint"))
    rc, err = _run(["import", str(xdf)], capsys)
    assert rc == 2 and len(err.splitlines()) == 1
    assert "own joint angles" in err and "raw mode" in err
    assert not (tmp_path / "angles.h5").exists()


def test_tilt_mode_imports_the_units_tilts(record_simulated, tmp_path, capsys):
    """A unit in tilt mode streams only its angles: the import is a tilt-mode session with the
    unit's tilts (to the file's 0.01 degree), the source's gaps and no accelerometer tilts."""
    from gaitmon.finish import open_session

    src = record_simulated(tmp_path / "tilt.h5", "--mode", "tilt", "--loss-pct", "2",
                           "--side", "R", duration_s=20)  # fmt: skip
    xdf = write_xdf(tmp_path / "tilt.xdf", gaitmon_streams(src, raw=False, mode="tilt"))
    out = tmp_path / "tilt_imported.h5"
    rc, err = _run(["import", str(xdf), "-o", str(out)], capsys)
    assert rc == 0, err
    assert "tilt-mode session" in err
    with open_session(src) as a, open_session(out) as b:
        assert b.mode == "tilt" and b.complete and b.meta.side == "R"
        assert b.n_samples == a.n_samples
        assert [(g.sample_idx, g.n_lost) for g in b.gaps] == [
            (g.sample_idx, g.n_lost) for g in a.gaps
        ]
        assert len(a.gaps) > 3
        assert np.array_equal(b.read("timeline/t_s"), a.read("timeline/t_s"))
        assert np.array_equal(b.read("processed/tilt_deg"), a.read("processed/tilt_deg"))
        assert np.array_equal(b.read("processed/joint_deg"), a.read("processed/joint_deg"))
        assert np.isnan(b.read("processed/tilt_acc_deg")).all()


def test_readme_example_file_imports(tmp_path, capsys):
    """The README's command on docs/example-walk.xdf (made by tests/xdf_sessions.py)."""
    import shutil

    from gaitmon.cli import main
    from gaitmon.finish import open_session

    example = Path(__file__).resolve().parents[1] / "docs" / "example-walk.xdf"
    xdf = Path(shutil.copy(example, tmp_path / "example-walk.xdf"))
    assert main(["import", str(xdf), "--markers-from", "Stimulator"]) == 0
    err = capsys.readouterr().err
    assert "1500 frames" in err and "2 gaps (5 frames lost)" in err and "4 markers" in err
    with open_session(tmp_path / "example-walk.h5") as s:
        assert [m.label for m in s.markers] == ["walk start", "pulse on", "pulse off", "stop"]
        assert [m.sample_idx for m in s.markers] == [250, 600, 1200, 1400]
    assert "9 included" in _strides_line(capsys, tmp_path / "example-walk.h5")


def test_control_frames_and_a_counter_restart_are_no_gaps(source, tmp_path, capsys):
    """The unit's control frames share the frame counter (a jump with no time lost), and a
    unit that restarts starts it again: neither is a gap, the timestamps say no data frame was
    missed; the rows, gaps and processed series stay the recording's."""
    from gaitmon.finish import open_session

    streams = gaitmon_streams(source)
    counter = streams[0].time_series[:, 0]
    counter[700:] += 1  # one control frame before row 700
    counter[2300:] -= counter[2300]  # the counter restarts at 0 at row 2300
    xdf = write_xdf(tmp_path / "counter.xdf", streams)
    rc, err = _run(["import", str(xdf), "-o", str(tmp_path / "counter.h5")], capsys)
    assert rc == 0, err
    with open_session(source) as a, open_session(tmp_path / "counter.h5") as b:
        assert [(g.sample_idx, g.n_lost) for g in b.gaps] == [(r, k) for r, (k, _) in DROPS.items()]
        seq_a, seq_b = a.read("timeline/seq"), b.read("timeline/seq")
        assert np.array_equal(seq_b[:700], seq_a[:700])
        assert np.array_equal(seq_b[700:2300], seq_a[700:2300] + 1)
        assert np.all(np.diff(seq_b) > 0)
        assert np.array_equal(b.read("timeline/t_s"), a.read("timeline/t_s"))
        assert np.array_equal(
            a.with_angles("live").read("processed/tilt_deg"),
            b.with_angles("live").read("processed/tilt_deg"),
        )


def test_review_window_opens_the_import(qtbot, review_win, source, imported, tmp_path):
    """The real review window on the imported file: the source's strides in its table, the
    markers of both streams labelled on the timeline, no error."""
    from gaitmon.analysis import analyse_session
    from gaitmon.finish import open_session

    with qtbot.waitSignal(review_win.analysis_done, timeout=60_000):
        review_win.open_file(imported)
    qtbot.waitUntil(lambda: review_win.timeline.applied_requests > 0, timeout=60_000)
    with open_session(source) as a:
        n_strides = len(analyse_session(a).rows)
    assert review_win.table.model().rowCount() == n_strides > 10
    labels = sorted(item.toPlainText() for item in review_win.timeline._marker_labels)
    assert labels == sorted([*MARKERS.values(), "pulse on", "pulse off"])
    review_win.grab().save(str(tmp_path / "review_import.png"))


def test_only_the_streams_needed_are_read(recording, tmp_path, capsys, monkeypatch):
    """The EEG beside gaitmon's streams is not read (a lab's 64-channel EEG would cost most of
    the time); a --markers-from name that is not in the file lists the file's streams."""
    import pyxdf

    asked = []
    load = pyxdf.load_xdf

    def spy(*args, **kwargs):
        asked.append(kwargs.get("select_streams"))
        return load(*args, **kwargs)

    monkeypatch.setattr(pyxdf, "load_xdf", spy)
    rc, err = _run(["import", str(recording), "-o", str(tmp_path / "a.h5"), "-q"], capsys)
    assert rc == 0, err
    ids = {int(i["stream_id"]): i["name"] for i in pyxdf.resolve_streams(str(recording))}
    assert sorted(ids[k] for k in asked[0]) == sorted(
        ["gaitmon 4242 raw", "gaitmon 4242 angles", "gaitmon 4242 events", "Stimulator"]
    )
    rc, err = _run(["import", str(recording), "-o", str(tmp_path / "b.h5"),
                    "--markers-from", "Trigger"], capsys)  # fmt: skip
    assert rc == 2 and "no stream named 'Trigger'" in err and "'EEG'" in err
    assert not (tmp_path / "b.h5").exists()
