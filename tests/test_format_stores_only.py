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


def _record(path: Path, n: int = 3000):
    """A raw recording of ``n`` simulated rows, not yet closed."""
    import numpy as np

    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionWriter
    from gaitmon.io.sim.sensors import simulate

    counts = simulate(n).counts
    w = SessionWriter(path, SessionHeader("raw"))
    pipe = Pipeline()
    for a in range(0, n, 100):
        seq = np.arange(a, min(n, a + 100), dtype=np.int64)
        blk = SampleBlock(FrameKind.RAW, seq, seq / 100.0, 1.7e9,
                          lost_before=np.zeros(len(seq), np.int64), adc=counts[seq])  # fmt: skip
        w.append(blk, pipe.process(counts[seq]))
    return w


def test_the_writer_stores_only_and_the_finishing_close_adds_smoothed_and_strides(tmp_path):
    import h5py

    from gaitmon.finish import close_recording
    from gaitmon.io.session import journal_path

    plain, finished = tmp_path / "plain.h5", tmp_path / "finished.h5"
    _record(plain).close()
    close_recording(_record(finished))
    for path, derived in ((plain, False), (finished, True)):
        assert not journal_path(path).exists()
        with h5py.File(path, "r") as f:
            assert bool(f.attrs["complete"]) and int(f.attrs["n_samples"]) == 3000
            assert ("smoothed" in f, "strides" in f) == (derived, derived)


def test_a_close_that_fails_while_deriving_keeps_the_journal_and_recovery_finishes(tmp_path):
    """Crash safety is the writer's: the derived datasets are written before the file is
    marked complete, so a failure there (a full disk) leaves the journal, and the next open
    recovers the file with them stored."""
    import h5py
    import pytest

    from gaitmon.finish import open_session
    from gaitmon.io.session import SessionError, journal_path

    def full_disk(f, header, fs_hz):
        raise OSError(28, "No space left on device")

    path = tmp_path / "s.h5"
    w = _record(path)
    with pytest.raises(SessionError, match="disk full or write error"):
        w.close(derive=full_disk)
    assert journal_path(path).exists()
    with h5py.File(path, "r") as f:
        assert not bool(f.attrs.get("complete", False))
    with open_session(path) as s:
        assert s.recovered and s.n_samples == 3000 and s.smoothed_stored
        assert s.foot_stride_measures() is not None
    assert not journal_path(path).exists()
