"""The review document's change events, without Qt: an exclusion change emits exactly one
event with the ranges in force and where they were kept, the ranges are kept where
``gaitmon report`` reads them, and the angle source and settings of the series shown emit
their own events."""

from __future__ import annotations

import json
from dataclasses import fields

import pytest

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.finish import open_session
from gaitmon.io.session import exclusions
from gaitmon.report import gather_report
from gaitmon.review.events import (
    AnglesChanged,
    Emitter,
    ExclusionsChanged,
    SettingsChanged,
)
from gaitmon.review.model import Replay, changed_settings, open_document
from gaitmon.review.settings import PIPELINE_SETTINGS, ReviewKey

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def walk(tmp_path_factory, record_simulated):
    return record_simulated(tmp_path_factory.mktemp("events") / "walk.h5", duration_s=20)


@pytest.fixture
def doc(walk):
    d = open_document(walk)
    d.clear_exclusions()  # (a side file left by another test)
    yield d
    d.clear_exclusions()
    d.close()


def _record(emitter: Emitter) -> list:
    got: list = []
    emitter.connect(got.append)
    return got


def test_an_exclusion_emits_one_event_with_the_ranges_and_keeps_them(doc, walk):
    got = _record(doc.events.exclusions)
    others = _record(doc.events.angles) + _record(doc.events.settings)
    hs = doc.recorded.heel_strike_idx
    a, b = int(hs[4]) + 3, int(hs[5]) + 3
    event = doc.exclude(a, b, "turn")
    assert got == [event]
    assert event == ExclusionsChanged((exclusions.Exclusion(a, b, "turn"),),
                                      exclusions.side_path(walk))  # fmt: skip
    assert others == []
    # kept beside the recording, in the file every reader reads
    stored = json.loads(exclusions.side_path(walk).read_text(encoding="utf-8"))
    assert [(r["start_idx"], r["stop_idx"], r["label"]) for r in stored["excluded_ranges"]] == [
        (a, b, "turn")
    ]
    # a range touching it is joined: still one event a change
    doc.exclude(b, b + 10, "turn")
    assert len(got) == 2
    assert got[-1].exclusions == (exclusions.Exclusion(a, b + 10, "turn"),)
    doc.include(a, a + 2)
    assert got[-1].exclusions == (exclusions.Exclusion(a + 2, b + 10, "turn"),)
    doc.clear_exclusions()
    assert len(got) == 4 and got[-1].exclusions == ()
    assert not exclusions.side_path(walk).exists()


def test_the_exclusions_cannot_be_changed_behind_the_documents_back(doc):
    got = _record(doc.events.exclusions)
    doc.exclude(10, 20)
    doc.exclusions.append(exclusions.Exclusion(30, 40))  # a copy
    assert doc.exclusions == [exclusions.Exclusion(10, 20)]
    assert len(got) == 1


def test_report_and_document_see_the_same_exclusions(doc, walk):
    hs = doc.recorded.heel_strike_idx
    doc.exclude(int(hs[6]) + 2, int(hs[7]) + 2, "stumble")
    doc.exclude(int(hs[10]) + 2, int(hs[11]) + 2, "turn")
    with open_session(walk) as s:
        # gaitmon report reads the stored exclusions (excluded_ranges=None)
        data = gather_report(s)
        assert exclusions.read(s) == (doc.exclusions, "")
    spans = [(x.reason, x.n_strides) for x in data.excluded_spans]
    assert [label for label, _ in spans] == ["stumble", "turn"]
    assert all(n >= 1 for _, n in spans)
    # the same document reopened reads the same ranges again
    again = open_document(walk)
    try:
        assert again.exclusions == doc.exclusions
    finally:
        again.close()


def test_an_exclusion_that_cannot_be_kept_still_applies_and_says_why(doc, monkeypatch):
    def refuse(*_a, **_k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(exclusions, "save", refuse)
    got = _record(doc.events.exclusions)
    doc.exclude(5, 50)
    assert got[-1].kept_in is None and got[-1].problem == "Permission denied"
    assert doc.exclusions == [exclusions.Exclusion(5, 50)]


def test_angles_and_settings_emit_their_events(doc):
    angles = _record(doc.events.angles)
    settings = _record(doc.events.settings)
    assert doc.angle_sources == ("smoothed", "live")
    doc.use_angles("live")
    assert angles == [AnglesChanged("live", doc.angle_method_of("live"))]
    config = doc.recorded.config.replace(cutoff_hz=6.0)
    n = doc.n_rows
    replay = Replay(config, {}, doc.recorded.heel_strike_idx[:0], doc.recorded.toe_off_idx[:0])
    doc.set_replay(replay)
    doc.set_replay(None)
    assert settings == [SettingsChanged(config, True), SettingsChanged(doc.session.config, False)]
    assert len(angles) == 1 and n == doc.n_rows
    doc.close()  # listeners are dropped with the document
    assert doc.events.angles.n_callbacks == 0


def test_emitter_calls_each_callback_once_in_order_and_forgets_them():
    e: Emitter[int] = Emitter("n")
    calls: list[tuple[str, int]] = []

    def first(x: int) -> None:
        calls.append(("first", x))

    def second(x: int) -> None:
        calls.append(("second", x))

    e.connect(first)
    e.connect(second)
    e.connect(first)
    e.emit(3)
    e.disconnect(first)
    e.emit(4)
    assert calls == [("first", 3), ("second", 3), ("second", 4)]


def test_settings_are_named_once():
    names = {f.name for f in fields(PipelineConfig)}
    assert {s.name for s in PIPELINE_SETTINGS} <= names
    a = PipelineConfig()
    b = a.replace(cutoff_hz=6.0, r=0.1)
    assert changed_settings(a, b) == f"cut-off {a.cutoff_hz:g} → 6 Hz, R {a.r:g} → 0.1"
    assert len({k.key for k in ReviewKey}) == len(ReviewKey)
    assert ReviewKey.RECENT.default == [] and isinstance(ReviewKey.LAST_FOLDER.default, str)
