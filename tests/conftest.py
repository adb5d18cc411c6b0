import os
import pathlib
from collections.abc import Callable

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")


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
