"""Where numba caches gaitmon's compiled loops, and whether they are in it for this install.

numba caches a compiled function in the user's cache folder (:func:`numba_cache_dir`) and
drops that cache when the function's source file changes (a new install). Whether the cache is
ready is asked before numba is imported (importing it costs ~0.4 s of CPU), so the answer is a
mark of our own, written once every kernel is compiled or loaded and the filler has tried to
build them ahead of time too (:func:`mark_ready`, :func:`aot_file`), named by what numba's own
check reads: the stamp (modification time, size) of the kernels' source
(``gaitmon/dsp/loops.py`` and ``loops_stride.py``), of numba's and the interpreter's version. A
cache made by another install, numba or Python has another name and is not taken as ready.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.machinery
import importlib.util
import os
import subprocess
import sys
import time

from gaitmon import paths
from gaitmon.dsp import loops, loops_stride


def numba_cache_dir() -> str:
    """Where numba caches the compiled loops: ``NUMBA_CACHE_DIR`` when the user set it, else
    ``numba`` in gaitmon's folder of the user's cache (platformdirs: ~/.cache/gaitmon/numba on
    Linux)."""
    explicit = os.environ.get("NUMBA_CACHE_DIR", "")
    if explicit:
        return explicit
    try:
        folder = str(paths.user_cache_dir())
    except ModuleNotFoundError:  # an environment installed before gaitmon required platformdirs
        from numba.misc import appdirs  # the same rules, vendored by numba

        folder = str(appdirs.user_cache_dir("gaitmon", False))  # type: ignore[no-untyped-call]
    return os.path.join(folder, "numba")


def numba_origin() -> str | None:
    """The file numba would be imported from, or None where it is not installed (or blocked):
    found without importing it."""
    if "numba" in sys.modules:  # (None there: blocked on purpose)
        module = sys.modules["numba"]
        return None if module is None else (getattr(module, "__file__", None) or "loaded")
    try:
        spec = importlib.util.find_spec("numba")
    except (ImportError, ValueError):  # (sys.modules["numba"] = None: blocked on purpose)
        return None
    return None if spec is None else (spec.origin or "namespace")


def _stamp(path: str) -> str:
    st = os.stat(path)
    return f"{st.st_mtime_ns}:{st.st_size}"


def ready_mark() -> str | None:
    """The mark's path for this install, numba and interpreter; None without numba."""
    origin = numba_origin()
    if origin is None:
        return None
    try:
        numba_stamp = _stamp(origin)
    except OSError:
        numba_stamp = origin
    # ("aot": a cache made before the filler also built the ahead-of-time module is not ready)
    key = "|".join([_stamp(loops.__file__), numba_stamp, sys.version, sys.platform, "aot",
                    _stamp(loops_stride.__file__)])  # (the loops' second file)
    digest = hashlib.sha1(key.encode(), usedforsecurity=False).hexdigest()[:16]
    return os.path.join(numba_cache_dir(), f"gaitmon-ready-{digest}")


def cache_ready() -> bool:
    """Whether every kernel is in numba's cache for this install (loading it costs ~0.5 s of
    CPU with numba's import; compiling it, 5-10 s on a quiet machine)."""
    mark = ready_mark()
    return mark is not None and os.path.exists(mark)


def mark_ready() -> None:
    """Say that every kernel is in the cache for this install (after compiling them all)."""
    mark = ready_mark()
    if mark is None:
        return
    os.makedirs(os.path.dirname(mark), exist_ok=True)
    with open(mark, "w") as f:
        f.write(f"{loops.__file__}\n")


_FILL_STALE_S = 900.0  # a filler's lock older than this is from one that died
_fill: subprocess.Popen[bytes] | None = None  # the filler this process started


def aot_file() -> str | None:
    """Where the loops compiled ahead of time are for this install (:mod:`gaitmon.dsp.kernel_aot`;
    the file may not exist); None without numba."""
    mark = ready_mark()
    if mark is None:
        return None
    digest = os.path.basename(mark).rsplit("-", 1)[-1]  # (the same key as the mark's)
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    return os.path.join(os.path.dirname(mark), f"gaitmon_loops_{digest}{suffix}")


def start_fill() -> bool:
    """Compile the kernels into numba's cache in a background process (``python -m
    gaitmon.dsp.kernel_fill``, at a lower priority), unless the cache is ready, numba is
    missing, this process started one already, or another process is filling it now. Nothing
    waits for it: the interpreted loops serve meanwhile. True when one was started."""
    global _fill
    if _fill is not None or cache_ready() or numba_origin() is None:
        return False
    lock = os.path.join(numba_cache_dir(), "gaitmon-filling")
    try:
        os.makedirs(os.path.dirname(lock), exist_ok=True)
        if os.path.exists(lock) and time.time() - os.path.getmtime(lock) < _FILL_STALE_S:
            return False
        with open(lock, "w") as f:
            f.write(str(os.getpid()))
    except OSError:  # a read-only cache folder: the loops still run, interpreted
        return False
    try:
        _fill = subprocess.Popen(
            [sys.executable, "-m", "gaitmon.dsp.kernel_fill", lock],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            env={**os.environ, "NUMBA_CACHE_DIR": numba_cache_dir()},
        )  # fmt: skip
    except OSError:  # no interpreter to start: the loops still run, interpreted
        with contextlib.suppress(OSError):
            os.remove(lock)
        return False
    return True


def wait_fill(timeout_s: float | None = None) -> int | None:
    """Wait for the filler this process started (tests, a command's end); its exit status,
    or None when none was started or it is still running after ``timeout_s``."""
    if _fill is None:
        return None
    try:
        return _fill.wait(timeout_s)
    except subprocess.TimeoutExpired:
        return None
