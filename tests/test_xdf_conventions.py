"""gaitmon's LSL streams in an XDF file: the XDF MoCap meta-data convention the outlets now
follow and the older one both import alike; a recorder that renamed the streams' types (or
their types and names) is handled; every refusal says what the file holds and what to do
(raw-mode angles without the raw stream, a regular-rate stream as markers, a foreign file).

The files are written here (``tests/xdf_writer.py``) from a source session recorded the live
way (``tests/xdf_sessions.py``) and read by pyxdf.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyxdf")

from xdf_sessions import eeg_stream, gaitmon_streams, labrecorder_file, write_source
from xdf_writer import Stream, write_xdf

from gaitmon.cli import main
from gaitmon.lsl import layout


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_source(tmp_path_factory.mktemp("xdfc") / "source.h5")


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    rc = main(argv)
    return rc, capsys.readouterr().err.strip()


def _kind(stream) -> str:
    return stream.name.rsplit(" ", 1)[1]


def _new_convention(streams: list) -> list:
    """As the outlets write them now: gaitmon/stream, MoCap channel types and objects,
    acquisition/compensated_lag."""
    out = []
    for s in copy.deepcopy(streams):
        kind = _kind(s)
        s.desc.setdefault("gaitmon", {})["stream"] = kind
        s.desc["acquisition"]["compensated_lag"] = "0.06" if kind == "events" else "0.0"
        if kind == "angles":
            s.desc["channels"] = {"channel": [
                {"label": c.label, "unit": c.unit, "type": c.type, "object": c.object}
                for c in layout.ANGLE_CHANNELS]}  # fmt: skip
        out.append(s)
    return out


def _old_convention(streams: list) -> list:
    """As gaitmon wrote them before: JointAngle / SegmentTilt channel types, no gaitmon/stream."""
    out = []
    for s in copy.deepcopy(streams):
        if _kind(s) == "angles":
            types = ["JointAngle"] * 3 + ["SegmentTilt"] * 4
            s.desc["channels"] = {"channel": [
                {"label": c.label, "unit": "degrees", "type": t}
                for c, t in zip(layout.ANGLE_CHANNELS, types, strict=True)]}  # fmt: skip
        out.append(s)
    return out


def _series(path: Path) -> dict[str, np.ndarray]:
    from gaitmon.finish import open_session

    with open_session(path) as s:
        return {k: s.read(k) for k in ("raw/adc", "timeline/seq", "processed/joint_deg")}


def test_the_new_and_the_old_convention_import_alike(source, tmp_path, capsys):
    assert {c.type for c in layout.ANGLE_CHANNELS} == {"OrientationP"}
    assert not set(layout.LEGACY_ANGLE_TYPES) & {c.type for c in layout.ANGLE_CHANNELS}
    got = {}
    for label, streams in (("new", _new_convention(gaitmon_streams(source))),
                           ("old", _old_convention(gaitmon_streams(source)))):  # fmt: skip
        xdf = write_xdf(tmp_path / f"{label}.xdf", streams)
        rc, err = _run(["import", str(xdf), "-q"], capsys)
        assert rc == 0, err
        got[label] = _series(tmp_path / f"{label}.h5")
    want = _series(source)
    for key, value in want.items():
        np.testing.assert_array_equal(got["new"][key], value, err_msg=key)
        np.testing.assert_array_equal(got["old"][key], value, err_msg=key)


def test_gaitmon_streams_with_renamed_types_are_still_found(source, tmp_path, capsys):
    """A recorder set up to call every stream "Data": gaitmon's manufacturer, names and
    source ids still say which is which (the old code said "none whose
    acquisition/manufacturer is 'gaitmon'", which was untrue)."""
    streams = _old_convention(gaitmon_streams(source))
    for s in streams:
        s.type = "Data"
    xdf = write_xdf(tmp_path / "renamed.xdf", streams)
    rc, err = _run(["import", str(xdf), "-q"], capsys)
    assert rc == 0, err
    np.testing.assert_array_equal(_series(tmp_path / "renamed.h5")["raw/adc"],
                                  _series(source)["raw/adc"])  # fmt: skip
    # streams of the new convention say their kind themselves: names changed too, still found
    streams = _new_convention(gaitmon_streams(source))
    for k, s in enumerate(streams):
        s.type, s.name, s.source_id = "Data", f"stream {k}", f"id{k}"
    xdf = write_xdf(tmp_path / "anonymous.xdf", streams)
    rc, err = _run(["import", str(xdf), "-q"], capsys)
    assert rc == 0, err


def test_gaitmon_streams_that_say_nothing_of_their_kind_are_named(source, tmp_path, capsys):
    """Old-convention streams whose types and names were both changed: the message says
    what was found (made by gaitmon) and what is missing (which stream is which)."""
    streams = _old_convention(gaitmon_streams(source))
    for k, s in enumerate(streams):
        s.type, s.name, s.source_id = "Data", f"stream {k}", f"id{k}"
    xdf = write_xdf(tmp_path / "lost.xdf", streams)
    rc, err = _run(["import", str(xdf)], capsys)
    assert rc == 2 and len(err.splitlines()) == 1
    assert "none whose acquisition/manufacturer" not in err
    assert "made by gaitmon" in err and "'stream 0' (Data, 15 channels, 100 Hz)" in err
    assert "'stream 1' (Data, 7 channels, 100 Hz)" in err and "apart" in err
    assert not (tmp_path / "lost.h5").exists()


def test_raw_mode_angles_without_the_raw_stream_ask_for_it(source, tmp_path, capsys):
    streams = gaitmon_streams(source, raw=False, mode="raw")
    xdf = write_xdf(tmp_path / "noraw.xdf", streams)
    rc, err = _run(["import", str(xdf)], capsys)
    assert rc == 2 and len(err.splitlines()) == 1
    assert "joint-mode" not in err and "own raw angles" not in err
    assert "not its raw stream ('gaitmon 4242 raw')" in err and "LabRecorder" in err
    assert not (tmp_path / "noraw.h5").exists()


def test_a_regular_rate_stream_is_refused_as_markers(source, tmp_path, capsys):
    """As live --lsl-markers refuses it: a 250 Hz EEG's samples are data, not events (the
    old code wrote one marker per EEG sample, labelled with its first channel)."""
    xdf = labrecorder_file(source, tmp_path / "walk.xdf")
    rc, err = _run(["import", str(xdf), "--markers-from", "EEG"], capsys)
    assert rc == 2 and len(err.splitlines()) == 1
    assert "'EEG' (--markers-from) is a regular 250 Hz stream" in err
    assert "'Stimulator' (Markers, 1 channel, irregular rate)" in err
    assert not (tmp_path / "walk.h5").exists()
    rc, err = _run(["import", str(xdf), "--markers-from", "Stimulator", "-q"], capsys)
    assert rc == 0, err


def test_a_foreign_file_names_the_streams_it_holds(tmp_path, capsys):
    stim = Stream(
        "Stimulator", "Markers", "string", 0.0, np.array([101.0, 102.0]), [["a"], ["b"]], 1,
        source_id="stim")  # fmt: skip
    xdf = write_xdf(tmp_path / "eeg.xdf", [eeg_stream(100.0, 110.0), stim])
    rc, err = _run(["import", str(xdf)], capsys)
    assert rc == 2 and len(err.splitlines()) == 1
    assert "holds no gaitmon stream" in err
    assert "'EEG' (EEG, 8 channels, 250 Hz)" in err
    assert "'Stimulator' (Markers, 1 channel, irregular rate)" in err
    assert not (tmp_path / "eeg.h5").exists()
