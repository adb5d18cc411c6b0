"""The session format stores and reads; it never runs the pipeline (issue 23, layers by concern).

Checked from the source, as ``tests/test_layers.py`` checks the layers: no module of
``gaitmon.io.session`` imports the finishing layer or the offline methods, and from
``gaitmon.dsp.pipeline`` it takes the data types only (the settings and the block it stores),
never the pipeline itself. The finishing layer's session computes what the format's reader
does not.
"""

from __future__ import annotations

import ast
from pathlib import Path

import gaitmon

SESSION = Path(gaitmon.__file__).resolve().parent / "io" / "session"

# modules that compute: the pipeline's filters and the offline methods, and the layer above
FORBIDDEN = ("gaitmon.finish", "gaitmon.dsp.smoother", "gaitmon.dsp.stride_length",
             "gaitmon.dsp.motion_kalman", "gaitmon.dsp.kalman", "gaitmon.dsp.kalman_models",
             "gaitmon.dsp.complementary", "gaitmon.dsp.lab_filters", "gaitmon.dsp.kernels",
             "gaitmon.dsp.gyro_events", "gaitmon.dsp.clock_fit")  # fmt: skip
# what the format may take from gaitmon.dsp.pipeline: what it stores, not what runs
PIPELINE_DATA = {"PipelineConfig", "PipelineBlock"}


def imported(source: str) -> list[tuple[str, str]]:
    """(module, name) of every ``from X import name`` and (module, "") of ``import X``."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.extend((node.module, a.name) for a in node.names)
        elif isinstance(node, ast.Import):
            out.extend((a.name, "") for a in node.names)
    return out


def problems_of(name: str, source: str) -> list[str]:
    found = []
    for mod, what in imported(source):
        if any(mod == f or mod.startswith(f + ".") for f in FORBIDDEN):
            found.append(f"{name} imports {mod}")
        elif mod == "gaitmon.dsp.pipeline" and what not in PIPELINE_DATA:
            found.append(f"{name} imports {what or 'the module'} from gaitmon.dsp.pipeline")
        elif mod == "gaitmon.dsp" and what in ("pipeline", "smoother", "stride_length"):
            found.append(f"{name} imports gaitmon.dsp.{what}")
    return found


def test_the_session_format_never_runs_the_pipeline() -> None:
    files = sorted(SESSION.glob("*.py"))
    assert len(files) > 10 and SESSION / "reader.py" in files
    found = [p for f in files for p in problems_of(f.name, f.read_text(encoding="utf-8"))]
    assert found == []


def test_the_check_catches_a_pipeline_run_and_a_finishing_import() -> None:
    src = ("from gaitmon.dsp.pipeline import Pipeline, PipelineConfig\n"
           "def f():\n    from gaitmon.finish.smoothed import smooth_into\n"
           "import gaitmon.dsp.smoother\n")  # fmt: skip
    assert sorted(problems_of("m.py", src)) == [
        "m.py imports Pipeline from gaitmon.dsp.pipeline",
        "m.py imports gaitmon.dsp.smoother",
        "m.py imports gaitmon.finish.smoothed",
    ]


def test_the_format_reader_computes_nothing_the_finishing_session_computes(tmp_path) -> None:
    """A raw file without ``/smoothed``: the format's reader refuses its smoothed angles (it
    does not run the smoother); the finishing layer's session computes them."""
    import h5py
    import numpy as np
    import pytest
    from conftest import write_simulated_session

    from gaitmon.finish import Session, open_session
    from gaitmon.io.session import SessionError, StoredSession, read_stored

    path = write_simulated_session(tmp_path / "s.h5", n=1500)
    with h5py.File(path, "r+") as f:
        del f["smoothed"]
    with read_stored(path) as s:
        assert type(s) is StoredSession and not s.smoothed_stored
        assert not hasattr(s, "foot_stride_measures")
        with pytest.raises(SessionError, match="does not store its smoothed angles"):
            s.read("processed/tilt_deg")
        live = s.with_angles("live").read("processed/tilt_deg")
    with open_session(path) as s:
        assert isinstance(s, Session) and s.angle_source == "smoothed"
        smoothed = s.read("processed/tilt_deg")
        assert smoothed.shape == live.shape == (1500, 4)
        assert not np.array_equal(smoothed, live)  # the smoother's, not the live filter's
        assert s.foot_stride_measures() is not None
