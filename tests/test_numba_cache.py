"""numba's compiled loops are cached in the user's cache folder, never in the installed package
(files pip does not know of, left there, hide a later editable install), and a missing numba
costs nothing but speed on long records (the loops run interpreted). Each test runs a fresh
interpreter: numba picks a cache folder once per process."""

import os
import subprocess
import sys
import time
from pathlib import Path

import gaitmon

PACKAGE = Path(gaitmon.__file__).resolve().parent
ROOT = PACKAGE.parent

COMPILE_ONE = """
import numpy as np
from gaitmon.dsp import kernels_numba
kernels_numba.constant_map_solve(np.ones((3, 6)), np.ones(6), np.zeros((6, 1)))
print(kernels_numba.constant_map_solve._cache._cache_path)
"""


def run(code_or_args: str | list[str], env: dict[str, str], **kw) -> subprocess.CompletedProcess:
    args = ["-c", code_or_args] if isinstance(code_or_args, str) else code_or_args
    return subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True,
                          timeout=240, cwd=kw.get("cwd"))  # fmt: skip


def clean_env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *extra.pop("PYTHONPATH", "").split(os.pathsep)])
    env.update(extra)
    return env


def cache_files(folder: Path, since: float) -> list[Path]:
    return [p for p in folder.rglob("*.nb*") if p.stat().st_mtime >= since]


def test_compiled_loops_are_cached_in_the_users_cache_folder_not_in_the_package(tmp_path):
    start = time.time() - 1.0  # file systems with coarse times
    proc = run(COMPILE_ONE, clean_env(XDG_CACHE_HOME=str(tmp_path / "cache")))
    assert proc.returncode == 0, proc.stderr
    cache = tmp_path / "cache" / "gaitmon" / "numba"
    assert Path(proc.stdout.strip()).is_relative_to(cache)
    written = cache_files(cache, start)
    assert {p.suffix for p in written} == {".nbi", ".nbc"}, written
    assert all("constant_map_solve" in p.name for p in written)
    assert cache_files(PACKAGE, start) == []


WHERE = """
from gaitmon.dsp import kernels, kernels_numba
print(kernels.numba_cache_dir())
print(kernels_numba.gait_aware_update._cache._cache_path)
print(kernels_numba.constant_map_solve._cache._cache_path)
"""


def test_an_explicit_NUMBA_CACHE_DIR_is_kept(tmp_path):
    """(Where numba would write, read off the kernels: the test above compiles for real.)"""
    mine = tmp_path / "mine"
    proc = run(WHERE, clean_env(NUMBA_CACHE_DIR=str(mine), XDG_CACHE_HOME=str(tmp_path / "c")))
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.split()
    assert lines[0] == str(mine)
    assert all(Path(p).is_relative_to(mine) for p in lines[1:])
    assert not (tmp_path / "c").exists()


def test_without_numba_record_works_and_says_nothing_of_it(tmp_path):
    """Issue 28: numba is a speed-up of long batch work, not a requirement (the old code stopped
    here with "pip install numba"); a recording's filters run interpreted."""
    hide = tmp_path / "hide"
    hide.mkdir()
    (hide / "sitecustomize.py").write_text("import sys\nsys.modules['numba'] = None\n")
    out = tmp_path / "walk.h5"
    proc = run(["-m", "gaitmon", "record", "--simulate", "--duration", "4", "--speed", "20",
                "--standing-s", "1", "--quiet", "-o", str(out)],
               clean_env(PYTHONPATH=str(hide), QT_QPA_PLATFORM="offscreen"),
               cwd=str(tmp_path))  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "pip install" not in proc.stderr and "Traceback" not in proc.stderr
    import h5py

    with h5py.File(out, "r") as f:
        assert len(f["processed/tilt_deg"]) == 400
        assert len(f["smoothed/tilt_deg"]) == 400
