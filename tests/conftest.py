import atexit
import os
import pathlib
import shutil
import tempfile
import threading
import time
import uuid
from collections.abc import Callable

import pytest
from hypothesis import settings as hypothesis_settings

# no per-example deadline: hypothesis's default 200 ms is a timing in a pass/fail test, and on a
# loaded 2-core machine (the suite's three workers, CI's neighbours) a slow example is not a bug
hypothesis_settings.register_profile("gaitmon", deadline=None)
hypothesis_settings.load_profile("gaitmon")

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")


def _lsl_session_of_this_run() -> None:
    """This test run's own LSL session (liblsl's ``[lab] SessionID``): its outlets answer, and
    its resolvers see, only processes of the same session, so another run's streams on this
    machine (a second checkout's tests, a lab's LabRecorder) are never found and ours never
    reach them. Set before pylsl is first used; the ``gaitmon`` processes the tests start
    inherit it. liblsl's logs stay off (gaitmon quiets them only without a config of the
    user's). A user's own LSLAPICFG is kept. Each pytest-xdist worker is a run of its own (the
    workers inherit the controller's environment, so the session is made per worker): a test
    that looks for no stream never sees a test of another worker publish one."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    ours = os.environ.get("GAITMON_TESTS_LSL_SESSION_OF")
    if os.environ.get("LSLAPICFG") and (ours is None or ours == worker):
        return  # the user's own configuration, or this process's session made already
    folder = pathlib.Path(tempfile.mkdtemp(prefix="gaitmon-tests-lsl-"))
    cfg = folder / "lsl_api.cfg"
    cfg.write_text(f"[lab]\nSessionID = gaitmon-tests-{uuid.uuid4().hex}\n\n[log]\nlevel = -2\n")
    os.environ["LSLAPICFG"] = str(cfg)
    os.environ["GAITMON_TESTS_LSL_SESSION_OF"] = worker
    atexit.register(shutil.rmtree, folder, True)


_lsl_session_of_this_run()

QT_FIXTURES = {"qtbot", "qapp"}

# A test's timeout catches a hang, it does not hold a speed: the tighter ones some modules set
# (20-120 s) ended tests that were only slow on a machine running other suites beside this one,
# so none is shorter than pyproject's default.
TIMEOUT_FLOOR_S = 300.0


# Modules whose tests run for a minute or more each, run first: pytest-xdist hands out the
# tests in collection order, and test_walkthrough.py (its sessions recorded in real windows at
# 3x real time) came third from last, so one worker ran it alone at the end of the run, a
# minute or two after the others had finished. First, the other workers' short tests fill
# that time. (The order within a module is kept: its module fixtures are made once.)
# test_ui_first_connect.py waits 20-90 s for numba's background cache filler (at a lower
# priority, it gets the CPU last): near the end of the collection, it was the run's last test.
# The other modules holding a test of 30 s or more (--durations: a cache filled from empty, the
# loops built ahead of time, an hour of pacing, two units recorded) follow them.
RUN_FIRST = ("test_walkthrough.py", "test_ui_first_connect.py", "test_kernels.py",
             "test_kernel_aot.py", "test_sim_unit.py", "test_engine.py",
             "test_bilateral_record.py")  # fmt: skip


def pytest_collection_modifyitems(items):
    for item in items:
        marker = item.get_closest_marker("timeout")
        if marker is not None and marker.args and float(marker.args[0]) < TIMEOUT_FLOOR_S:
            item.add_marker(pytest.mark.timeout(TIMEOUT_FLOOR_S), append=False)
    items.sort(key=lambda item: item.path.name not in RUN_FIRST)  # stable


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """After a test that used Qt (its widgets closed, its fixtures dropped): delete what waits
    for deleteLater and collect the garbage cycles holding Qt objects here, on the GUI thread.

    Left for later, the next collection runs on whatever thread allocates - in the next
    test, an engine, device or recorder thread - and PySide destroys the QObjects there,
    handing some of them to the main thread; the two destructors deadlocked on a Qt mutex
    and the GIL (the main thread holding the GIL, so no timeout could end the run)."""
    yield
    if QT_FIXTURES.isdisjoint(item.fixturenames):
        return
    import gc

    from PySide6.QtCore import QCoreApplication, QEvent

    app = QCoreApplication.instance()
    if app is not None:
        QCoreApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)
    gc.collect()
    if app is not None:  # what the collection handed to deleteLater
        QCoreApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)


@pytest.fixture(autouse=True)
def user_data_dir(tmp_path_factory, monkeypatch) -> pathlib.Path:
    """Each test's own user data folder (gaitmon keeps exclusions there when a recording's
    folder is read-only): no test reads or writes the real ~/.local/share."""
    path = tmp_path_factory.mktemp("xdg-data")
    monkeypatch.setenv("XDG_DATA_HOME", str(path))
    # and its own log folder (gaitmon.paths.user_log_dir): the real log gets no test's lines
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path_factory.mktemp("xdg-state")))
    return path

SHARED_DATA = pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture
def shared_data() -> pathlib.Path:
    """The real recordings in ../shared/data; tests using it skip on a fresh clone without it."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present")
    return SHARED_DATA


@pytest.fixture(scope="session")
def record_simulated(tmp_path_factory) -> Callable[..., pathlib.Path]:
    """``record_simulated(path, *options, duration_s=30, standing_s=2)`` records a session from
    the simulator with ``gaitmon record --simulate`` in-process (quiet, 20x real time) into
    ``path``, asserts the command succeeded and returns ``path``. ``options`` are further
    ``gaitmon record`` options (patient, losses, mode...). Session-scoped so module-scoped
    fixtures can record once per module with it.

    A recording is made once per test process for each set of options, duration and standing
    time; a later call with the same ones gets a copy of that file at its own ``path`` (a
    40-s recording costs ~8 s of CPU, and several modules record the same walk). The copy is
    the test's own: changing it changes no other test's file."""
    made: dict[tuple[object, ...], pathlib.Path] = {}

    def record(
        path: pathlib.Path, *options: str, duration_s: float = 30, standing_s: float = 2
    ) -> pathlib.Path:
        from gaitmon.cli import main

        key = (options, float(duration_s), float(standing_s))
        if key not in made:
            first = tmp_path_factory.mktemp("recorded") / "walk.h5"
            rc = main(
                ["record", "--simulate", "--duration", f"{duration_s:g}", "-o", str(first),
                 "--speed", "20", "--standing-s", f"{standing_s:g}", "--quiet", *options]
            )  # fmt: skip
            assert rc == 0
            made[key] = first
        shutil.copyfile(made[key], path)
        return path

    return record


CUT_MARKER = "walk start"


@pytest.fixture(scope="session")
def cut_recording(tmp_path_factory) -> pathlib.Path:
    """A recording with a real link cut: the simulated unit over a pty drops the link for 3 s
    of device time (the engine reconnects into the same file: one gap, one reconnect), and a
    marker labelled ``CUT_MARKER`` before the cut. Read-only: copy it before changing it.

    The cut is scheduled once the marker is placed, 2 s of the unit's time ahead: a cut at a
    fixed time of the unit's clock (12 s from its creation) came while a busy machine was
    still connecting (IDENTIFY then failed: "link lost")."""
    import time
    from dataclasses import replace

    from gaitmon.engine import Engine
    from gaitmon.io.device import Device
    from gaitmon.io.session import SessionMeta
    from gaitmon.io.sim import FaultConfig, GaitConfig, SimulatedUnit
    from gaitmon.io.sim.pty import PtySimulator
    from gaitmon.io.transport import SerialTransport

    out = tmp_path_factory.mktemp("cut") / "cut.h5"
    unit = SimulatedUnit(GaitConfig(seed=3, standing_s=2.0), faults=FaultConfig(), speed=5.0)
    with PtySimulator(unit) as sim:
        eng = Engine(Device(SerialTransport(str(sim.link_path))), "raw", transport_label="pty")
        with eng:
            eng.start_recording(out, SessionMeta(patient_id="G1"))
            deadline = time.monotonic() + 90
            while eng.recording.rows < 400 and time.monotonic() < deadline:
                time.sleep(0.01)
            eng.add_marker(CUT_MARKER)
            while True:  # scheduled in time, else again from the unit's time now
                at = unit.device_time_s + 2.0
                unit.faults = replace(unit.faults, link_drops=((at, 3.0),))
                if unit.device_time_s < at - 1.0:
                    break
            while eng.recording.rows < 2700 and time.monotonic() < deadline:
                time.sleep(0.02)
            eng.stop_recording()
    return out


def write_simulated_session(path: pathlib.Path, *, pattern: str = "normal", seed: int = 7,
                            n: int = 2500, patient_id: str = "P001",
                            created_utc: str = "2026-10-01T09:00:00Z",
                            side: str = "R") -> pathlib.Path:
    """A raw session of the simulator's ``pattern`` written with SessionWriter from simulated
    counts (so the test chooses its date and patient id): 2 s standing, then walking."""
    import numpy as np

    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
    from gaitmon.finish import close_recording
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import simulate

    fs = 100.0
    gait = GaitModel(GaitConfig(seed=seed, pattern=pattern, standing_s=2.0))
    counts = simulate(n, gait).counts
    header = SessionHeader("raw", fs, meta=SessionMeta(patient_id=patient_id, side=side),
                           config=PipelineConfig(), calibration=Calibration.identity(),
                           created_utc=created_utc)  # fmt: skip
    w = SessionWriter(path, header)
    pipe = Pipeline(PipelineConfig())
    for i in range(0, n, 50):
        adc = counts[i : i + 50]
        seq = np.arange(i, i + len(adc), dtype=np.int64)
        blk = SampleBlock(FrameKind.RAW, seq, seq / fs, 1.7e9,
                          lost_before=np.zeros(len(adc), np.int64), adc=adc)  # fmt: skip
        w.append(blk, pipe.process(adc))
    close_recording(w)
    return path


@pytest.fixture(scope="session")
def gap_recording(tmp_path_factory) -> pathlib.Path:
    """A 40 s simulated walk (SessionWriter, as the recorder writes it) with one link outage:
    the frames of 24.63-30.00 s never arrived (537 frames, "link lost"), so rows 2463 and
    2464 are 5.37 s apart. Deterministic, unlike :func:`cut_recording`. Read-only."""
    import itertools

    import numpy as np

    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
    from gaitmon.finish import close_recording
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import simulate

    fs, n, cut = 100.0, 4000, (2463, 3000)
    counts = simulate(n, GaitModel(GaitConfig(seed=11, standing_s=2.0))).counts
    path = tmp_path_factory.mktemp("gap") / "gap.h5"
    header = SessionHeader("raw", fs, meta=SessionMeta(patient_id="G2", side="R"),
                           config=PipelineConfig(), calibration=Calibration.identity(),
                           created_utc="2026-10-01T09:00:00Z")  # fmt: skip
    w = SessionWriter(path, header)
    pipe = Pipeline(PipelineConfig())
    bounds = [*range(0, cut[0], 50), cut[0], *range(cut[1], n + 1, 50)]
    for a, b in itertools.pairwise(bounds):
        if a == cut[0]:
            continue  # the outage
        lost = np.zeros(b - a, np.int64)
        if a == cut[1]:
            lost[0] = cut[1] - cut[0]
            w.add_gap(int(lost[0]), lost[0] / fs, "link lost: test cut")
        seq = np.arange(a, b, dtype=np.int64)
        blk = SampleBlock(FrameKind.RAW, seq, seq / fs, 1.7e9, lost_before=lost,
                          adc=counts[a:b])  # fmt: skip
        w.append(blk, pipe.process(counts[a:b], lost))
    close_recording(w)
    return path


@pytest.fixture(scope="session")
def normal_and_stiff_knee(tmp_path_factory) -> tuple[pathlib.Path, pathlib.Path]:
    """Two sessions of patient P001: normal gait on 2026-10-01, stiff-knee on 2026-11-01
    (same seed: only the pattern differs). Read-only: copy them before changing them."""
    d = tmp_path_factory.mktemp("compare")
    return (
        write_simulated_session(d / "visit1_normal.h5", pattern="normal"),
        write_simulated_session(d / "visit2_stiff.h5", pattern="stiff-knee",
                                created_utc="2026-11-01T09:30:00Z"),
    )


@pytest.fixture(scope="session")
def assert_stored():
    """``assert_stored(got, expected, name, version=2)``: a per-sample series read from a
    session equals the pipeline's values within what the file format promises
    (``gaitmon.io.session.codec.tolerance``: half the resolution of a quantised series, one
    resolution for a joint angle; exact otherwise; angle differences wrapped), plus float32
    rounding."""
    import numpy as np

    from gaitmon.io.session.codec import tolerance

    def check(got, expected, name: str, version: int = 2) -> None:
        got = np.asarray(got)
        expected = np.asarray(expected)
        assert got.shape == expected.shape, (name, got.shape, expected.shape)
        tol = tolerance(name, version)
        if tol == 0.0:
            assert np.array_equal(got, expected.astype(got.dtype), equal_nan=True), name
            return
        err = got.astype(np.float64) - expected.astype(np.float64)
        if name.endswith("_deg"):
            err = (err + 180.0) % 360.0 - 180.0
        ok = np.isfinite(expected)
        assert np.array_equal(np.isfinite(got), ok), name
        big = float(np.abs(expected[ok]).max()) if ok.any() else 0.0
        slack = 4 * float(np.spacing(np.float32(big)))
        worst = float(np.abs(err[ok]).max()) if ok.any() else 0.0
        assert worst <= tol + slack, f"{name}: off by {worst} > {tol} (+{slack})"

    return check


@pytest.fixture
def no_leaked_threads():
    """Fails the test if a gaitmon thread it started is still running 30 s after it (a loaded
    machine ends threads late, not never)."""

    def ours() -> list[threading.Thread]:
        return [t for t in threading.enumerate() if t.name.startswith("gaitmon")]

    before = set(ours())
    yield
    deadline = time.monotonic() + 30
    left: list[threading.Thread] = []
    while time.monotonic() < deadline:
        left = [t for t in ours() if t not in before and t.is_alive()]
        if not left:
            return
        time.sleep(0.05)
    pytest.fail(f"gaitmon threads left running: {[t.name for t in left]}")


def _review_threads() -> list:
    import threading

    return [t for t in threading.enumerate() if t.name.startswith("gaitmon-review")]


@pytest.fixture
def review_win(qtbot, tmp_path):
    """A real review window with its own settings file; on closing, it must have reported no
    error and its worker threads must have stopped."""
    import time

    from PySide6.QtCore import QSettings

    from gaitmon.ui.review.window import ReviewWindow

    before = set(_review_threads())
    settings = QSettings(str(tmp_path / "settings" / "gaitmon.ini"), QSettings.Format.IniFormat)
    w = ReviewWindow(settings)
    qtbot.addWidget(w)
    w.show()
    yield w
    w.close()
    assert w.errors == []
    deadline = time.monotonic() + 30
    while [t for t in _review_threads() if t not in before and t.is_alive()]:
        if time.monotonic() > deadline:
            pytest.fail("review worker threads left running")
        time.sleep(0.05)


@pytest.fixture
def ui_settings(tmp_path):
    """An isolated settings file for a window under test (no user's preferences leak in)."""
    from PySide6.QtCore import QSettings

    path = tmp_path / "settings" / "gaitmon.ini"
    path.parent.mkdir()
    return QSettings(str(path), QSettings.Format.IniFormat)
