"""The tilt-method registry (gaitmon.dsp.methods): a method registered in one place is offered
everywhere (``gaitmon process --method``, the reprocess dialog, ``gaitmon lab accuracy``,
``estimate_tilt``), and the built-in methods give exactly the numbers of their own classes."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import h5py
import numpy as np
import pytest
from conftest import write_simulated_session

from gaitmon.dsp.angles import accel_tilt
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, FSR_IDX, GYRO_IDX, SEGMENTS
from gaitmon.dsp.complementary import AdaptiveCutoff, ComplementaryFilter
from gaitmon.dsp.estimate import estimate_tilt
from gaitmon.dsp.events import (
    FALLBACK,
    PRIMARY,
    EventInput,
    EventRecord,
    Events,
    EventSettings,
    event_sources,
    get_event_source,
    register_event_source,
    unregister_event_source,
)
from gaitmon.dsp.events.foot_gyro import FootGyro
from gaitmon.dsp.filters import Butterworth
from gaitmon.dsp.gait import GaitEventDetector
from gaitmon.dsp.gyro_events import gyro_gait_events
from gaitmon.dsp.kalman import TiltKalman
from gaitmon.dsp.methods import (
    REGISTRY,
    TiltFilter,
    TiltMethod,
    feeds_smoother,
    get_method,
    live_names,
    methods,
    register,
    smoothing_method,
    unregister,
)
from gaitmon.dsp.motion_kalman import GaitAwareKalman
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.dsp.smoother import smooth_tilt
from gaitmon.engine.snapshot import EVENTS_FSR, EVENTS_GYRO

FS = 100.0
NAME = "test-acc-only"
LABEL = "accelerometer only (test)"


class _PassThrough:
    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray:
        return np.array(acc_tilt_rad, dtype=np.float64, copy=True)

    def reset(self) -> None:
        pass


@dataclass(frozen=True)
class AccOnly(TiltMethod):
    """A throw-away method: the accelerometer tilt, offered by the app."""

    name: ClassVar[str] = NAME
    label: ClassVar[str] = LABEL
    live: ClassVar[bool] = True

    def lab_filter(self, dt_s: float) -> TiltFilter:
        return _PassThrough()


@pytest.fixture
def throwaway():
    register(AccOnly())
    try:
        yield NAME
    finally:
        unregister(NAME)
    assert NAME not in REGISTRY


@pytest.fixture(scope="module")
def walk():
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import simulate

    return simulate(2500, GaitModel(GaitConfig(seed=11, standing_s=2.0))).counts


def test_a_registered_method_is_offered_by_process(throwaway, tmp_path, capsys):
    from gaitmon.cli import main

    with pytest.raises(SystemExit):
        main(["process", "--help"])
    assert f"--method {{gait-aware,paper,{NAME}}}" in capsys.readouterr().out
    src = write_simulated_session(tmp_path / "walk.h5", n=1500)
    out = tmp_path / "acc.h5"
    assert main(["process", str(src), "-o", str(out), "-q", "--method", NAME]) == 0
    with h5py.File(out, "r") as f:
        assert f["config"].attrs["tilt_method"] == NAME
        assert f["processed"].attrs["tilt_method"] == LABEL
        tilt, acc = f["processed/tilt_deg"][:], f["processed/tilt_acc_deg"][:]
    with h5py.File(src, "r") as f:
        recorded = f["processed/tilt_deg"][:]
    np.testing.assert_array_equal(tilt, acc)  # the method passes the accelerometer tilt on
    assert not np.allclose(recorded, acc, atol=0.5)  # the recording's gait-aware filter did not


def test_info_shows_the_settings_each_method_reads(throwaway, tmp_path, capsys):
    """``gaitmon info``'s settings line: the paper's Kalman settings for the method that reads
    them, the label alone for a method that reads none (TiltMethod.reads_settings)."""
    from gaitmon.cli import main

    src = write_simulated_session(tmp_path / "walk.h5", n=1200)
    for method, shown in (
        ("paper", "Kalman Q_angle 0.001 Q_gyro 0.003 R 0.3 ("),
        (NAME, f"order 2, {LABEL}, FSR threshold"),
    ):
        out = tmp_path / f"{method}.h5"
        assert main(["process", str(src), "-o", str(out), "-q", "--method", method]) == 0
        capsys.readouterr()
        assert main(["info", str(out)]) == 0
        line = next(x for x in capsys.readouterr().out.splitlines() if "settings " in x)
        assert shown in line, line


def test_an_unknown_method_is_refused_by_process(tmp_path, capsys):
    from gaitmon.cli import main

    src = write_simulated_session(tmp_path / "walk.h5", n=600)
    with pytest.raises(SystemExit):
        main(["process", str(src), "-o", str(tmp_path / "x.h5"), "--method", NAME])
    assert "invalid choice" in capsys.readouterr().err


def test_a_registered_method_is_in_the_reprocess_dialog(throwaway, qtbot):
    from gaitmon.ui.review.reprocess_dialog import ReprocessDialog

    dlg = ReprocessDialog(None, PipelineConfig())
    qtbot.addWidget(dlg)
    combo = dlg.method_combo
    items = [(combo.itemText(i), combo.itemData(i)) for i in range(combo.count())]
    assert items == [("gait-aware Kalman", "gait-aware"), ("Kalman (paper, seed 000)", "paper"),
                     (LABEL, NAME)]  # fmt: skip
    combo.setCurrentIndex(combo.findData(NAME))
    assert dlg.method == NAME
    assert not dlg.edits["r"].isEnabled()  # the paper's R: this method does not read it
    assert dlg.parsed().tilt_method == NAME


def test_a_registered_method_is_a_column_of_lab_accuracy(throwaway, walk):
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.lab.accuracy import Accuracy, columns, format_table, tilts

    cols = columns()
    assert [c.key for c in cols] == ["paper", "live", "offline", NAME]
    assert cols[-1].label == LABEL and not cols[-1].offline
    cal = Calibration.identity()
    got = tilts(walk, cal, NAME)
    np.testing.assert_array_equal(got, Pipeline(calibration=cal).process(walk).tilt_acc_rad)
    acc = Accuracy()
    for k in (c.key for c in cols):
        acc.joint_rmse_deg.setdefault("normal", {})[k] = np.array([1.0, 2.0, 3.0])
        acc.peak_knee_err_deg.setdefault("normal", {})[k] = 0.5
        acc.peak_knee_strides_deg.setdefault("normal", {})[k] = np.array([0.5, -0.5])
    head = format_table(acc).splitlines()[0]
    assert head.endswith(f"| {LABEL} | goal |")


def test_a_registered_method_is_run_by_estimate_tilt(throwaway, walk):
    ph = DEFAULT_TABLE.to_physical(walk)
    ax, az, w = ph[:, ACC_X_IDX[3]], ph[:, ACC_Z_IDX[3]], ph[:, GYRO_IDX[3]]
    got = estimate_tilt(ax, az, w, FS, method=NAME)
    np.testing.assert_array_equal(got, np.arctan2(az, ax))
    with pytest.raises(ValueError, match="no offline"):
        estimate_tilt(ax, az, w, FS, method=NAME, offline=True)


def test_the_registry_lists_the_apps_choices_as_before():
    assert live_names() == ("gait-aware", "paper")
    assert [m.name for m in methods(live=False)] == [
        "accelerometer",
        "gyro",
        "complementary",
        "complementary-adaptive",
        "constant-rate",
    ]
    assert get_method("paper").label == "Kalman (paper, seed 000)"
    assert get_method("gait-aware").label == "gait-aware Kalman"
    assert get_method("gait-aware").offline_label == "gait-aware Kalman + RTS smoother"
    # the files' smoothed angles are the default's offline pass, fed its causal filter
    assert smoothing_method().offline_label == "gait-aware Kalman + RTS smoother"
    assert feeds_smoother("gait-aware") and not feeds_smoother("paper")
    with pytest.raises(ValueError, match="registered already"):
        register(get_method("paper"))
    with pytest.raises(ValueError, match="unknown tilt method"):
        PipelineConfig(tilt_method="complementary")  # lab-only: the app does not offer it


def test_the_lab_filters_are_the_registrys_in_the_labs_order():
    from gaitmon.dsp.lab_filters import TILT_FILTERS
    from gaitmon.review.filters import PARAMS, build_filter

    assert list(TILT_FILTERS) == [
        "accelerometer", "gyro", "complementary", "complementary (adaptive)",
        "kalman (paper 000)", "kalman constant-rate (paper 001)",
    ]  # fmt: skip
    assert list(PARAMS) == list(TILT_FILTERS)[2:]
    rng = np.random.default_rng(3)
    z, w = rng.normal(0, 0.3, 600), rng.normal(0, 1.0, 600)
    for name, ref in (
        ("complementary", ComplementaryFilter(0.01, cutoff_hz=3.0)),
        ("complementary (adaptive)", ComplementaryFilter(0.01, cutoff_hz=3.0,
                                                         adaptive=AdaptiveCutoff())),
        ("kalman (paper 000)", TiltKalman(0.01)),
    ):  # fmt: skip
        np.testing.assert_array_equal(TILT_FILTERS[name](0.01).process(z, w), ref.process(z, w))
    tuned = build_filter("kalman (paper 000)", 0.01, {"q_angle": 0.01, "q_gyro": 0.003, "r": 0.1})
    np.testing.assert_array_equal(tuned.process(z, w), TiltKalman(0.01, 0.01, 0.003, 0.1)
                                  .process(z, w))  # fmt: skip


def test_get_params_and_clone():
    paper = get_method("paper")
    assert paper.get_params() == {"q_angle": 0.001, "q_gyro": 0.003, "r": 0.3}
    tuned = paper.clone(r=0.1)
    assert tuned.get_params()["r"] == 0.1 and paper.get_params()["r"] == 0.3
    with pytest.raises(TypeError):
        paper.clone(bogus=1.0)


def test_estimate_tilt_by_the_registry_equals_the_classes(walk):
    ph = DEFAULT_TABLE.to_physical(walk)
    for j, seg in enumerate(SEGMENTS):
        ax, az, w = ph[:, ACC_X_IDX[j]], ph[:, ACC_Z_IDX[j]], ph[:, GYRO_IDX[j]]
        acc = Butterworth(4.0, FS, 2).process(np.stack([ax, az], axis=1))
        paper = TiltKalman(dt_s=1.0 / FS).process(np.arctan2(acc[:, 1], acc[:, 0]), w)
        np.testing.assert_array_equal(estimate_tilt(ax, az, w, FS, segment=seg, method="paper"),
                                      paper)  # fmt: skip
        live = GaitAwareKalman(FS, segments=(seg,)).process(ax, az, w)
        np.testing.assert_array_equal(estimate_tilt(ax, az, w, FS, segment=seg), live)
    ax, az, w = ph[:, ACC_X_IDX[2]], ph[:, ACC_Z_IDX[2]], ph[:, GYRO_IDX[2]]
    np.testing.assert_array_equal(estimate_tilt(ax, az, w, FS, segment="shank", offline=True),
                                  smooth_tilt(ax, az, w, FS, "shank"))  # fmt: skip


def test_the_pipelines_tilt_stages_equal_the_classes(walk):
    ph = DEFAULT_TABLE.to_physical(walk)
    gyro = ph[:, GYRO_IDX]
    acc = Butterworth(4.0, FS, 2).process(ph[:, np.concatenate([ACC_X_IDX, ACC_Z_IDX])])
    paper = TiltKalman(0.01).process(accel_tilt(acc[:, :4], acc[:, 4:]), gyro)
    got = Pipeline(PipelineConfig(tilt_method="paper")).process(walk)
    np.testing.assert_array_equal(got.tilt_kalman_continuous_rad, paper)
    live = GaitAwareKalman(FS).process(ph[:, ACC_X_IDX], ph[:, ACC_Z_IDX], gyro)
    np.testing.assert_array_equal(Pipeline().process(walk).tilt_kalman_continuous_rad, live)


def test_the_live_menu_reads_the_registry():
    pytest.importorskip("PySide6")
    from gaitmon.ui.live.actions import tilt_methods

    assert [(k, t) for k, t, _ in tilt_methods()] == [
        ("gait-aware", "Gait-aware Kalman (default)"),
        ("paper", "Kalman (paper, seed 000)"),
    ]
    assert all(tip for _, _, tip in tilt_methods())


def test_a_method_registered_at_run_time_is_in_the_live_tilt_filter_menu(
    qtbot, tmp_path, no_leaked_threads
):
    """The live window reads the registry when it is made, not when its modules were imported:
    a method registered afterwards is in Device ▸ Tilt filter, chosen from there it is the
    filter in force and remembered, and a window made after it is unregistered lists it no
    more (and falls back to the default for the stored choice)."""
    pytest.importorskip("PySide6")
    from PySide6.QtCore import QSettings

    from gaitmon.ui.live import MainWindow

    settings = QSettings(str(tmp_path / "gaitmon.ini"), QSettings.Format.IniFormat)

    def window() -> MainWindow:
        win = MainWindow(settings, confirm_close=False)
        qtbot.addWidget(win)
        return win

    def tilt_menu(win: MainWindow) -> dict[str, object]:
        bar = {a.text(): a.menu() for a in win.menuBar().actions()}
        device = {a.text(): a for a in bar["&Device"].actions()}
        return {a.text(): a for a in device["Tilt filter"].menu().actions()}

    def close(win: MainWindow) -> None:
        win.close()
        assert win.errors == []

    win = window()
    built_in = list(tilt_menu(win))
    assert built_in == ["Gait-aware Kalman (default)", "Kalman (paper, seed 000)"]
    close(win)
    shown = "Accelerometer only (test)"  # the label, capitalised as the menu shows labels
    register(AccOnly())  # after every module of the window was imported
    try:
        win = window()
        menu = tilt_menu(win)
        assert list(menu) == [*built_in, shown]
        assert menu[shown].isCheckable() and not menu[shown].isChecked()
        menu[shown].trigger()
        assert win.ctx.config.tilt_method == NAME
        assert [t for t, a in menu.items() if a.isChecked()] == [shown]
        close(win)
        assert settings.value("pipeline/tilt_method") == NAME
    finally:
        unregister(NAME)
    win = window()
    assert list(tilt_menu(win)) == built_in
    assert win.ctx.config.tilt_method == "gait-aware"  # the stored one is gone: the default
    close(win)


# --------------------------------------------------------------------------------------------
# event sources (gaitmon.dsp.events)


@dataclass(frozen=True)
class _ShankGyro(FootGyro):
    """A throw-away source: the foot gyro's rule on the shank gyro."""

    name: ClassVar[str] = "test shank gyro"
    label: ClassVar[str] = "the shank gyro (test)"
    lab_key: ClassVar[str] = "shank"
    lab_label: ClassVar[str] = "shank-gyro (test)"
    lab_goal: ClassVar[str] = "(test)"

    def offline(self, record: EventRecord, settings: EventSettings) -> Events:
        return Events(*gyro_gait_events(record.gyro_rad_s[:, 2], record.fs_hz))


def test_the_event_sources_are_the_pipelines(walk):
    assert [s.name for s in event_sources()] == ["foot gyro", "fsr"]
    assert (PRIMARY, FALLBACK) == ("fsr", "foot gyro")
    assert (EVENTS_FSR, EVENTS_GYRO) == (PRIMARY, FALLBACK)
    cfg = PipelineConfig()
    blk = Pipeline(cfg).process(walk)
    assert blk.event_source == PRIMARY
    ph = DEFAULT_TABLE.to_physical(walk)
    fsr = Butterworth(4.0, FS, 2).process(ph[:, FSR_IDX])
    contacts = GaitEventDetector(fs_hz=FS).process(fsr)
    record = EventRecord(contacts, ph[:, GYRO_IDX], FS)
    # the force sensors' events are the detector's, moved back by the low-pass delay
    fsr_ev = get_event_source("fsr").offline(record, cfg)
    np.testing.assert_array_equal(fsr_ev.heel_strike_idx, blk.heel_strike_idx)
    np.testing.assert_array_equal(
        fsr_ev.heel_strike_idx, contacts.heel_strike_idx - cfg.event_delay_samples
    )
    # the foot gyro's streaming stage, block by block, decides what the pipeline reports
    stage = get_event_source("foot gyro").stage(cfg)
    hs = [stage.process(EventInput(contacts, ph[a : a + 97, GYRO_IDX])).heel_strike_idx
          for a in range(0, len(walk), 97)]  # fmt: skip
    np.testing.assert_array_equal(np.concatenate(hs), blk.gyro_heel_strike_idx)
    np.testing.assert_array_equal(
        get_event_source("foot gyro").offline(record, cfg).heel_strike_idx,
        gyro_gait_events(ph[:, GYRO_IDX[3]], FS)[0],
    )


def test_a_registered_event_source_is_judged_by_lab_accuracy(walk):
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.lab.accuracy import Accuracy, _events, table_rows

    register_event_source(_ShankGyro())
    try:
        with pytest.raises(ValueError, match="registered already"):
            register_event_source(_ShankGyro())
        acc = Accuracy()
        gait = GaitModel(GaitConfig(seed=11, standing_s=2.0))
        _events(gait, walk, Calibration.identity(), len(walk), acc)
        assert sorted(acc.hs_err_ms) == ["fsr", "gyro", "shank"]
        assert len(acc.hs_err_ms["shank"]) > 5
        rows = [r for r in table_rows_without_methods(acc, table_rows) if "shank" in r[0]]
        assert rows and rows[0][-1] == "(test)"
    finally:
        unregister_event_source(_ShankGyro.name)
    assert _ShankGyro.name not in [s.name for s in event_sources()]


def table_rows_without_methods(acc, table_rows):
    """The event rows of the lab table for an Accuracy with no tilt figures."""
    for k in ("paper", "live", "offline"):
        acc.joint_rmse_deg.setdefault("normal", {})[k] = np.zeros(3)
        acc.peak_knee_err_deg.setdefault("normal", {})[k] = 0.0
        acc.peak_knee_strides_deg.setdefault("normal", {})[k] = np.zeros(1)
    return table_rows(acc)


def test_mypy_checks_the_stage_wiring(tmp_path):
    """The stage seam is typed: a stage fed the wrong block is a mypy error, not a crash."""
    pytest.importorskip("mypy")
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    snippet = tmp_path / "wiring.py"
    snippet.write_text(
        "import numpy as np\n"
        "from gaitmon.dsp.events import EventInput, EventStage\n"
        "from gaitmon.dsp.filters import Butterworth\n"
        "from gaitmon.dsp.methods import TiltInput, TiltStage, get_method\n"
        "from gaitmon.dsp.pipeline import PipelineConfig\n"
        "def wire(block: TiltInput, events: EventStage) -> None:\n"
        "    stage: TiltStage = get_method('paper').causal_stage(PipelineConfig())\n"
        "    tilt: np.ndarray = stage.process(block)\n"
        "    events.process(block)\n"  # line 9: a tilt block into an event stage
        "    bad: TiltStage = Butterworth(4.0, 100.0, 2)\n"  # line 10: not a tilt stage
    )
    proc = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(root / "pyproject.toml"),
         str(snippet)],
        cwd=root, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    report = proc.stdout + proc.stderr
    errors = [ln for ln in report.splitlines() if ": error:" in ln]
    assert [int(ln.split(":")[1]) for ln in errors] == [9, 10], report


def test_the_plugin_registry_keeps_order_refuses_a_second_name_and_names_the_choices():
    from gaitmon.dsp.registry import Registry

    class Plugin:
        def __init__(self, name: str) -> None:
            self.name = name

    reg: Registry[Plugin] = Registry("widget")
    a, b = reg.add(Plugin("b-first")), reg.add(Plugin("a-second"))
    assert reg.all() == (a, b) and list(reg) == ["b-first", "a-second"] and "a-second" in reg
    with pytest.raises(ValueError, match="a widget named 'b-first' is registered already"):
        reg.add(Plugin("b-first"))
    assert reg.get("a-second") is b
    choices = r"unknown widget 'c'; use one of \['a-second', 'b-first'\]"
    with pytest.raises(ValueError, match=choices):
        reg.get("c")
    with pytest.raises(ValueError, match=r"use one of \['b-first'\]"):  # a registered one not among
        reg.get("a-second", among=["b-first"])
    reg.remove("b-first")
    reg.remove("b-first")  # removing twice is harmless
    assert reg.all() == (b,)


def test_a_plugin_registered_by_name_is_built_once_when_first_asked_for_in_its_place():
    """Registry.add_lazy (issue 28: a reader naming one method loads that one alone): built
    on the first get (once), listed in its registration place, a builder of another name
    refused."""
    from gaitmon.dsp.registry import Registry

    class Plugin:
        def __init__(self, name: str) -> None:
            self.name = name

    built: list[str] = []

    def build(name: str, bears: str | None = None):
        def make() -> Plugin:
            built.append(name)
            return Plugin(bears or name)

        return make

    reg: Registry[Plugin] = Registry("widget")
    reg.add_lazy("first", build("first"))
    eager = reg.add(Plugin("second"))
    reg.add_lazy("third", build("third"))
    assert list(reg) == ["first", "second", "third"] and "third" in reg and built == []
    assert reg.built("first") is None
    reg.check("third")  # a name is checked without building it
    with pytest.raises(ValueError, match=r"unknown widget 'x'; use one of \['first', 'second'"):
        reg.check("x")
    third = reg.get("third")
    assert built == ["third"] and reg.get("third") is third and built == ["third"]
    assert [p.name for p in reg.all()] == ["first", "second", "third"] and built[-1] == "first"
    assert reg.all()[1] is eager
    reg.add_lazy("fourth", build("fourth", bears="other"))
    with pytest.raises(ValueError, match="the widget registered as 'fourth' is 'other'"):
        reg.get("fourth")


def test_the_built_in_methods_say_before_they_are_built_what_their_classes_say():
    """The registration lines of gaitmon.dsp.methods declare each built-in method's live
    flag, label and settings read (what info, the settings' checks and the app's lists read
    unbuilt): a fresh interpreter reads them, then builds every method and compares."""
    import json
    import subprocess
    import sys

    code = (
        "import json, sys\n"
        "from gaitmon.dsp import methods as m\n"
        "names = list(m.REGISTRY)\n"
        "before = [m.live_names()] + [[m.method_label(n), list(m.settings_read_by(n))] "
        "for n in names]\n"
        "built = sorted(k for k in sys.modules if k.startswith('gaitmon.dsp.methods.'))\n"
        "after = [list(m.live_names())] + [[x.label, list(x.reads_settings)] "
        "for x in m.methods()]\n"
        "print(json.dumps([[list(before[0])] + before[1:], after, built]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120).stdout  # fmt: skip
    before, after, built = json.loads(out)
    assert before == after
    assert built == ["gaitmon.dsp.methods.registry"]  # nothing built to say it
    assert after[0] == ["gait-aware", "paper"]
    assert ["Kalman (paper, seed 000)", ["q_angle", "q_gyro", "r"]] in after[1:]


def test_a_method_whose_class_disagrees_with_its_registration_is_refused_when_built():
    from gaitmon.dsp.methods import register_lazy

    register_lazy("test-misnamed", AccOnly, True, LABEL)  # AccOnly is NAME
    try:
        with pytest.raises(ValueError, match="registered as 'test-misnamed' is 'test-acc-only'"):
            get_method("test-misnamed")
        unregister("test-misnamed")
        register_lazy(NAME, AccOnly, True, "another label")
        assert NAME in live_names()  # declared, unbuilt
        with pytest.raises(ValueError, match="its class says \\(True, 'accelerometer only"):
            get_method(NAME)
    finally:
        unregister("test-misnamed")
        unregister(NAME)
