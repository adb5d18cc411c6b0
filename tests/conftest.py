import os
import pathlib
from collections.abc import Callable

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

QT_FIXTURES = {"qtbot", "qapp"}


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
    return path

SHARED_DATA = pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture
def shared_data() -> pathlib.Path:
    """The real recordings in ../shared/data; tests using it skip on a fresh clone without it."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present")
    return SHARED_DATA


@pytest.fixture(scope="session")
def record_simulated() -> Callable[..., pathlib.Path]:
    """``record_simulated(path, *options, duration_s=30, standing_s=2)`` records a session from
    the simulator with ``gaitmon record --simulate`` in-process (quiet, 20x real time) into
    ``path``, asserts the command succeeded and returns ``path``. ``options`` are further
    ``gaitmon record`` options (patient, losses, mode...). Session-scoped so module-scoped
    fixtures can record once per module with it."""

    def record(
        path: pathlib.Path, *options: str, duration_s: float = 30, standing_s: float = 2
    ) -> pathlib.Path:
        from gaitmon.cli import main

        rc = main(
            ["record", "--simulate", "--duration", f"{duration_s:g}", "-o", str(path),
             "--speed", "20", "--standing-s", f"{standing_s:g}", "--quiet", *options]
        )  # fmt: skip
        assert rc == 0
        return path

    return record
