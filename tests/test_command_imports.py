"""A command imports what it uses (issue 28): checked by the modules a whole ``gaitmon`` process
holds when it ends, never by timing it.

Each command runs in a fresh interpreter (``gaitmon.cli.main``, as ``python -m gaitmon`` runs
it), which then prints the names in ``sys.modules``. ``gaitmon info`` reads a session and
computes its measures: numpy, h5py and gaitmon's reader, never scipy (its filters design
nothing), numba (it compiles no loop), the pipeline's filters, the simulator or a GUI or
plotting library. ``--help`` of a command loads that command's module and its options only.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

GOLDEN = Path(__file__).parent / "data" / "golden"

# a marker line after whatever the command printed, then the modules as JSON
_CODE = """\
import json, sys
from gaitmon.cli import main
try:
    rc = main(sys.argv[1:])
except SystemExit as exc:  # --help, --version
    rc = exc.code or 0
sys.stdout.flush()
print("\\nMODULES " + json.dumps({"rc": rc, "modules": sorted(sys.modules)}))
"""

# never for reading a file or printing help (scipy.signal, numba: issue 28's "Done when")
NEVER = ("scipy", "scipy.signal", "numba", "PySide6", "matplotlib", "pandas", "pyqtgraph")
# gaitmon's own heavy parts a reader does not need: the filters' models and compiled loops,
# the simulator (its options' light config module aside), the writer, the engine, the UI
NOT_TO_READ = ("gaitmon.dsp.kalman_models", "gaitmon.dsp.motion_kalman",
               "gaitmon.dsp.complementary", "gaitmon.dsp.smoother", "gaitmon.dsp.kernels",
               "gaitmon.io.sim.unit", "gaitmon.io.sim.sensors", "gaitmon.io.sim.kinematics",
               "gaitmon.io.session.writer", "gaitmon.engine", "gaitmon.ui")  # fmt: skip


# what reading a finished session does not need (issue 28: gaitmon info <= 1.2x a bare h5py open)
READ_ONLY_NEEDS_NOT = ("gaitmon.io.journal", "gaitmon.io.session.truth", "gaitmon.dsp.estimate",
                       "mmap", "gaitmon.dsp.pipeline", "numpy.typing")  # fmt: skip
# no tilt method nor event source built (their registries say their names, labels and the
# settings a method reads unbuilt), no filter (gaitmon.dsp.setting_checks checks settings), no
# platformdirs (gaitmon.paths applies the XDG rule on Linux), no shutil (argparse's help width:
# gaitmon.cli.terminal_columns): ~20 ms of imports
NOT_BUILT_TO_READ = ("gaitmon.dsp.methods.base", "gaitmon.dsp.methods.gait_aware",
                     "gaitmon.dsp.methods.paper", "gaitmon.dsp.methods.accelerometer",
                     "gaitmon.dsp.events.base", "gaitmon.dsp.events.fsr",
                     "gaitmon.dsp.events.foot_gyro", "gaitmon.dsp.gyro_events",
                     "gaitmon.dsp.kalman", "gaitmon.dsp.filters", "gaitmon.dsp.iir",
                     "platformdirs", "tempfile", "shutil")  # fmt: skip


def modules_of(*argv: str) -> set[str]:
    """The modules a ``gaitmon ARGV`` process had imported when it finished (asserting rc 0)."""
    out = subprocess.run([sys.executable, "-c", _CODE, *argv], capture_output=True, text=True,
                         check=True, timeout=300)  # fmt: skip
    line = out.stdout.rstrip().rsplit("\n", 1)[-1]
    assert line.startswith("MODULES "), out.stdout[-500:] + out.stderr[-2000:]
    result = json.loads(line.removeprefix("MODULES "))
    assert result["rc"] == 0, out.stderr[-2000:]
    return set(result["modules"])


def _loaded(modules: set[str], names: tuple[str, ...]) -> list[str]:
    """Those of ``names`` (a package counts with any module under it) that were imported."""
    return sorted({n for n in names for m in modules if m == n or m.startswith(n + ".")})


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> dict[str, Path]:
    """The golden one-leg and two-leg sessions, copied (info may write beside a file)."""
    folder = tmp_path_factory.mktemp("imports")
    for f in GOLDEN.glob("*.h5*"):
        shutil.copy(f, folder / f.name)
    return {"one leg": folder / "one_leg.h5", "two legs": folder / "two_legs.h5"}


@pytest.mark.parametrize("which", ["one leg", "two legs"])
def test_info_reads_a_session_without_scipy_numba_or_the_filters(sessions, which):
    modules = modules_of("info", str(sessions[which]))
    assert {"numpy", "h5py", "gaitmon.analysis", "gaitmon.io.session.reader"} <= modules
    assert _loaded(modules, NEVER) == []
    assert _loaded(modules, NOT_TO_READ) == []
    assert "numpy.ma" not in modules  # np.unique imports it (~20 ms): the reader avoids it
    # a finished file: no journal's record layout (gaitmon.io.journal_files names and locks
    # it), no simulator truth, no tilt-method estimation (a writer's label), no pipeline stages
    # (its settings are gaitmon.dsp.pipeline_config's); each ~1-5 ms
    assert _loaded(modules, READ_ONLY_NEEDS_NOT) == []
    if sys.platform == "linux":
        assert _loaded(modules, NOT_BUILT_TO_READ) == []
    if which == "one leg":  # descriptions of the file's attributes are written, not read;
        # the review's settings table only for a method that reads settings (not gait-aware)
        assert _loaded(modules, ("gaitmon.io.session.attributes", "gaitmon.review")) == []


@pytest.mark.skipif(sys.platform != "linux", reason="platformdirs decides the folders elsewhere")
def test_info_of_a_file_without_lost_frames_or_user_store_hashes_nothing(tmp_path, monkeypatch):
    """hashlib (~3 ms) only where a hash is taken: the user store of exclusions when its
    folder exists (the path's hash names the file), a /strides stamp when lost frames were
    filled in; a simulated walk has neither."""
    from conftest import write_simulated_session

    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "no-store-yet"))
    path = write_simulated_session(tmp_path / "walk.h5", n=1500)
    modules = modules_of("info", str(path))
    assert "gaitmon.finish.strides" in modules  # its stored measures were read
    assert _loaded(modules, ("hashlib",)) == []


def test_info_reads_stored_stride_measures_without_computing_them(sessions, tmp_path):
    """A file whose ``/strides`` are current (what every close, recovery and ``process`` now
    store): info checks their stamp (gaitmon.dsp.stride_method) and loads none of the
    stride-length computation (gaitmon.dsp.stride_length and its steps)."""
    import h5py

    from gaitmon.finish import open_session
    from gaitmon.finish.strides import store_strides

    path = tmp_path / "stored.h5"
    shutil.copy(sessions["one leg"], path)  # golden: /strides of an older method, recomputed
    with open_session(path) as s:
        table, cal, fs = s.header.table, s.calibration, s.sample_rate_hz
    with h5py.File(path, "r+") as f:
        store_strides(f, table, cal, fs)
    modules = modules_of("info", str(path))
    assert "gaitmon.finish.strides" in modules  # the stored measures were read
    assert _loaded(modules, ("gaitmon.dsp.stride_length", "gaitmon.dsp.stride_anchors",
                             "gaitmon.dsp.stride_integrate", "gaitmon.dsp.stride_streaming")) == []


@pytest.mark.parametrize("command", ["process", "info", "export", "report", "record", "batch"])
def test_a_commands_help_loads_no_scipy_numba_or_gui(command):
    modules = modules_of(command, "--help")
    assert f"gaitmon.commands.{command}" in modules  # its own options are there
    assert _loaded(modules, NEVER) == []
    assert _loaded(modules, NOT_TO_READ) == []
    assert _loaded(modules, ("gaitmon.dsp.pipeline", "h5py")) == []  # options read no file


@pytest.mark.parametrize("argv", [("--help",), ("--version",)])
def test_top_level_help_and_version_load_no_numpy_nor_a_command(argv):
    """Every command is listed from ``cli.SUBCOMMANDS`` alone; the help adds the live window's
    simulator options (from the light ``commands.simulate``/``live_pair``), the version not."""
    modules = modules_of(*argv)
    window = {"gaitmon.commands.simulate", "gaitmon.commands.live_pair"}
    if argv != ("--help",):
        window = set()
    assert {m for m in modules if m.startswith("gaitmon.commands.")} <= window
    assert _loaded(modules, ("numpy", "h5py", *NEVER)) == []
    assert "logging.handlers" not in modules  # gaitmon.logs rotates its file itself


@pytest.mark.parametrize("argv", [[], ["--verbose"], ["--simulate", "--version"]])
def test_the_live_window_still_gets_its_simulator_options(argv):
    """Only --version/--log-path (with --verbose) skip the window's simulator options: without
    a command anything else opens the window, which reads them from the parsed arguments."""
    from gaitmon.cli import build_parser

    args = build_parser(None, argv).parse_args([a for a in argv if a != "--version"])
    assert hasattr(args, "cadence") and hasattr(args, "pattern")


_THREADS = """\
import os, sys
{first}
import numpy
print(len(os.listdir("/proc/self/task")), len(os.sched_getaffinity(0)))
"""


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="threads counted in /proc")
@pytest.mark.parametrize("users", [None, "2"])
def test_a_command_starts_one_blas_thread_unless_the_user_chose(users):
    """Issue 28: OpenBLAS started a thread per core at numpy's import (~35 ms of CPU on two
    cores, then spinning beside the live view); gaitmon's commands need one. A user's own
    OPENBLAS_NUM_THREADS is kept, and the benchmark's references run in the user's."""
    import os

    # (OpenBLAS also reads OMP_NUM_THREADS and GOTO_NUM_THREADS: a library run before in this
    # process may have set one)
    blas = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "GOTO_NUM_THREADS")
    env = {k: v for k, v in os.environ.items() if k not in blas}
    if users is not None:
        env["OPENBLAS_NUM_THREADS"] = users

    cores = 0  # the CPUs the child may run on (OpenBLAS's default: a thread each)

    def threads(first: str) -> int:
        nonlocal cores
        code = _THREADS.format(first=first)
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=env, check=True)  # fmt: skip
        counted, cores = (int(v) for v in out.stdout.split()[-2:])
        return counted

    plain = threads("")
    mine = threads("from gaitmon.cli import main\n"
                   "from gaitmon.commands import user_environ\n"
                   "assert 'numpy' not in sys.modules\n"
                   "assert ('OPENBLAS_NUM_THREADS' in user_environ()) == "
                   f"{users is not None}")  # fmt: skip
    if users is None:
        assert mine == 1
        assert plain == cores  # (what the test would see without the setting)
    else:
        assert mine == plain == min(int(users), cores)


@pytest.mark.parametrize("columns", ["40", "97", "not a number", None])
def test_the_help_is_wrapped_as_argparse_wraps_it(monkeypatch, columns):
    """gaitmon.cli.HelpFormatter asks the width without shutil: the same help, word for word,
    as argparse's own formatter gives (``$COLUMNS`` set, not a number, or unset: no terminal
    here, so 80)."""
    import argparse

    from gaitmon.cli import HelpFormatter, build_parser

    if columns is None:
        monkeypatch.delenv("COLUMNS", raising=False)
    else:
        monkeypatch.setenv("COLUMNS", columns)
    for command in (None, "info", "process"):
        parser = build_parser(command, [command] if command else ["--version"])
        sub = parser._subparsers._group_actions[0].choices  # type: ignore[union-attr]
        shown = [parser, *([sub[command]] if command else [])]
        for p in shown:
            assert p.formatter_class is HelpFormatter
            ours = p.format_help()
            p.formatter_class = argparse.HelpFormatter
            assert p.format_help() == ours


def test_process_of_a_finished_file_loads_no_journal_nor_link_protocol(sessions, tmp_path):
    """The replay is its own module (gaitmon.finish.replay): reprocessing a finished file loads
    neither the journal's record layout nor the link protocol a recovery needs (~7 ms of a
    1-min ``process``; it loaded both through gaitmon.finish.recovery)."""
    modules = modules_of("process", str(sessions["one leg"]), "-o", str(tmp_path / "new.h5"),
                         "--quiet")  # fmt: skip
    assert "gaitmon.finish.replay" in modules
    assert _loaded(modules, ("gaitmon.io.journal", "gaitmon.io.protocol", "gaitmon.io.wire",
                             "gaitmon.finish.recovery")) == []  # fmt: skip


def test_process_with_the_gait_aware_filter_loads_no_other_methods_filter(sessions, tmp_path):
    """The settings options (``--method``'s choices and help, the paper-only settings) come
    from the registry's declarations: a gait-aware reprocessing imports neither the paper's
    method nor its Kalman filter (~13 ms of a 1-min ``process``; both were imported to read
    a class attribute), while the gait-aware method it runs is loaded."""
    modules = modules_of("process", str(sessions["one leg"]), "-o", str(tmp_path / "new.h5"),
                         "--quiet", "--method", "gait-aware")  # fmt: skip
    assert "gaitmon.dsp.methods.gait_aware" in modules
    assert _loaded(modules, ("gaitmon.dsp.methods.paper", "gaitmon.dsp.kalman",
                             "gaitmon.dsp.methods.complementary")) == []  # fmt: skip
