"""Which form of the inner loops runs: compiled (ahead of time, or by numba), or the same source
interpreted.

The loops (:mod:`gaitmon.dsp.loops`: the gait-aware filter's update, the smoother's banded
factorisation and substitutions, the per-block passes batch work runs in one sweep (counts to
units, the gravity reference, the motion inputs, the zeroed tilts, the smoother's turn and
right-hand side: :func:`to_physical`, :func:`zeroed_tilts` here, the others at their call
sites, which run numpy where the rule picks no compiled form); scipy's ``lfilter`` recursion,
which :class:`gaitmon.dsp.iir.LinearFilter` runs compiled where this rule picks a compiled form
and in its numpy block form elsewhere, counting no rows) have one source and two forms:
compiled (:mod:`gaitmon.dsp.kernel_aot`, :mod:`gaitmon.dsp.kernels_numba`), or run by the
interpreter on ``memoryview`` s of the arrays.
Both give the same numbers (to rounding: tests/test_kernels.py checks 1e-9 on simulated and
real walks in any chunking). Interpreted, a row of four segments costs ~7 us in the filter and
~8 us in the smoother; compiled, well under 1 us. The compiled form comes two ways: the module
the cache filler builds ahead of time (:mod:`gaitmon.dsp.kernel_aot`: it loads in well under a
millisecond and needs no numba), or numba's own cached loops, whose import and loading cost
~0.5 s of CPU (and ~100 MB, LLVM's runtime), and whose compile costs ~4 s more on a quiet
machine (30-40 s on a busy one). So the rule, per process, counting the rows run by the filter
and the smoother's solve:

* live blocks (calls of fewer than :data:`BATCH_CALL_ROWS` rows) always run interpreted: at
  100 Hz that is well under 1 % of a core, and no connect waits for a load;
* where the module built ahead of time is there, every other call runs in it (a call whose
  arguments do not fit the types it was built for runs in numba's loops, or interpreted);
* otherwise, batch work that says its size first (:func:`expect`: ``process``, ``batch``,
  recovery and a recording's close, through ``finish``'s replay and smoother) runs compiled
  when it is at least :data:`EXPECT_ROWS` rows (10 min at 100 Hz: interpreted, its filter and
  smoother would cost about what loading numba does) and numba's cache is ready for this
  install (:func:`gaitmon.dsp.kernel_cache.cache_ready`: the filler has compiled numba's loops
  and tried to build the module); when the cache is not ready, a background process fills it
  (:func:`gaitmon.dsp.kernel_cache.start_fill`; the live window starts one at its first
  connect) and the work goes on interpreted, going over to the compiled loops if the cache is
  ready before :data:`LOAD_ROWS` rows are done; only work of :data:`COMPILE_ROWS` rows or more
  (1 h at 100 Hz, where interpreting would cost more than compiling, ~4 s of CPU) compiles in
  its own process, right away;
* other batch work (calls of many rows that did not say their size) counts its rows: past
  :data:`FILL_ROWS` the background fill starts, past :data:`LOAD_ROWS` (counting the filter's
  and the smoother's rows) the compiled loops serve once the cache is ready;
* work in a thread that says it is live (:func:`live`: the engine's acquisition thread, and a
  simulated unit's pipeline when that thread runs it) always runs interpreted, however big its
  blocks (a simulated unit run faster than real time, or a catch-up after a stall, hands it
  thousands of rows at once): a live view never switches form mid-connection, and never waits
  for numba's import or a compile another thread started;
* once compiled loops are loaded in a process they serve every other call (numba's count as
  loaded only when their import has finished: another thread may be importing them);
* without numba (not installed, or failing to import) the interpreted loops serve everything.

:func:`use` forces one form (the tests, the benchmark, and the cache filler, which compiles);
its "compiled" is numba's own loops.
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon.dsp import kernel_aot, loops
from gaitmon.dsp.kernel_cache import (
    aot_file,
    cache_ready,
    numba_cache_dir,
    numba_origin,
    start_fill,
)

if TYPE_CHECKING:
    from gaitmon.dsp.channels import ChannelTable

__all__ = [
    "BATCH_CALL_ROWS",
    "COMPILE_ROWS",
    "EXPECT_ROWS",
    "FILL_ROWS",
    "LOAD_ROWS",
    "band_cholesky",
    "band_solve",
    "compiled_for",
    "compiled_loaded",
    "constant_map_solve",
    "expect",
    "gait_aware_update",
    "live",
    "motion_windows",
    "numba_available",
    "numba_cache_dir",
    "plain",
    "running_mean",
    "running_means",
    "to_physical",
    "use",
    "window_groups",
    "zeroed_tilts",
]

BATCH_CALL_ROWS = 1024
EXPECT_ROWS = 60_000
COMPILE_ROWS = 360_000
FILL_ROWS = 30_000
LOAD_ROWS = 120_000
log = logging.getLogger("gaitmon.dsp")

_batch_rows = 0  # rows of batch work done in this process
_forced: str | None = None  # "python" | "compiled" (:func:`use`)
_unavailable = False  # numba failed to import once: do not try again
# the compiled loops serving the rule, once loaded whole: the ahead-of-time module where it is
# built, else numba's kernels (``_jit``, once their import has finished)
_compiled: ModuleType | kernel_aot.Loops | None = None
_jit: ModuleType | None = None
_aot_file: list[str | None] = []  # aot_file(), looked up once per process
_load_lock = threading.Lock()
_thread = threading.local()  # .live: this thread's work is live (:func:`live`)


@contextmanager
def live() -> Iterator[None]:
    """The calling thread's work within the block is live: the interpreted loops run it,
    whatever this process has loaded (module doc); :func:`use` still forces a form."""
    before = getattr(_thread, "live", False)
    _thread.live = True
    try:
        yield
    finally:
        _thread.live = before


@contextmanager
def use(form: str) -> Iterator[None]:
    """Run the loops in one ``form`` ("python" or "compiled") within the block."""
    global _forced
    if form not in ("python", "compiled"):
        raise ValueError(f"form must be 'python' or 'compiled', got {form!r}")
    before, _forced = _forced, form
    try:
        yield
    finally:
        _forced = before


def numba_available() -> bool:
    """Whether numba can be imported here (looked up, not imported)."""
    return not _unavailable and numba_origin() is not None


def compiled_loaded() -> bool:
    """Whether compiled loops are loaded in this process (ahead-of-time or numba's: they then
    serve every call)."""
    return _compiled is not None


def expect(rows: int) -> None:
    """Batch work of ``rows`` rows (a whole record's replay or smoothing) is about to run in
    this process: from :data:`EXPECT_ROWS` rows on, load numba's loops now when its cache is
    ready, else start filling it in the background, and from :data:`COMPILE_ROWS` on compile
    them here too (module doc); where the loops compiled ahead of time are built, load them for
    any size. From :data:`BATCH_CALL_ROWS` rows on, the C heap is readied for batch work first
    (:func:`batch_heap`)."""
    if rows >= BATCH_CALL_ROWS:
        batch_heap()
    if _forced is not None or _unavailable or compiled_loaded():
        return
    if _aot_ready():  # (~1 ms to load: worth it for any batch work)
        _load()
        return
    if rows < EXPECT_ROWS:
        return
    if cache_ready():
        _load()
        return
    start_fill()  # (the whole set, marked ready for the next process)
    if rows >= COMPILE_ROWS:
        _load()  # compiled on first call, here: cheaper than interpreting such a record


HEAP_BYTES = 1 << 24
_heap_ready = False


def batch_heap() -> None:
    """Have the C heap serve batch work's arrays, once per process: one array of
    :data:`HEAP_BYTES` (16 MB) made and let go, untouched. glibc's malloc maps each block
    above its threshold (128 kB at the start) afresh and unmaps it when freed, and gives the
    heap's free top back to the system beyond twice that: a replay's and a smoother's
    arrays (0.2-8 MB each, made and freed per chunk) were faulted in anew every chunk, ~100 000
    page faults and ~0.15 s of system CPU for a 1-h record, a quarter of its pipeline and
    smoother. Freeing a mapped block raises both thresholds to its size (up to 32 MB), as the
    first smoother block did by itself: from the start, these arrays come from the heap, and
    freed pages stay for the next chunk. The peak is what the work holds at once, as before;
    resident memory between chunks keeps up to 32 MB more. Elsewhere (not glibc, or thresholds
    set by ``MALLOC_*`` variables) nothing changes."""
    global _heap_ready
    if not _heap_ready:
        _heap_ready = True
        block = np.empty(HEAP_BYTES, dtype=np.uint8)  # (made and freed: no page touched)
        del block


def _aot_ready() -> bool:
    """Whether the loops compiled ahead of time are built for this install (a file's test;
    its path is looked up once per process)."""
    if not _aot_file:
        _aot_file.append(None if _unavailable else aot_file())
    path = _aot_file[0]
    return path is not None and os.path.exists(path)


def _load(jit: bool = False) -> ModuleType | kernel_aot.Loops | None:
    """The compiled loops the rule serves (the ahead-of-time module where built, else
    numba's), loading them once; ``jit``: numba's own (:func:`use`'s "compiled")."""
    global _compiled
    with _load_lock:  # (one thread imports; the others wait for the whole module)
        if not jit and _compiled is not None:
            return _compiled
        if not jit and _aot_ready():
            path = _aot_file[0]
            assert path is not None
            aot = kernel_aot.load(path, _refused)
            if aot is not None:
                _compiled = aot
                return aot
        module = _load_jit()
        if _compiled is None:
            _compiled = module
        return module


def _load_jit() -> ModuleType | None:
    global _jit, _unavailable
    if _jit is None and not _unavailable:
        try:
            from gaitmon.dsp import kernels_numba
        except Exception as exc:  # the interpreted loops serve (the same numbers)
            # numba missing or broken (ImportError), or its cache unusable: it raises
            # RuntimeError "cannot cache function ... no locator available" where it cannot
            # write its cache folder or make a temporary file to test it
            _unavailable = True
            if not isinstance(exc, ImportError):
                log.warning("numba's compiled loops are not used (%s): the interpreted "
                            "loops serve, with the same numbers", exc)  # fmt: skip
            return None
        _jit = kernels_numba
    return _jit


def _refused(name: str) -> Any:
    """The loop ``name`` for a call the ahead-of-time module's signature refused: numba's,
    else interpreted."""
    log.info("a call of %s did not match the loops compiled ahead of time", name)
    with _load_lock:
        module = _load_jit()
    if module is not None:
        return getattr(module, name)
    return lambda *args: getattr(loops, name)(*_views(args))


def compiled_for(rows: int, *, count: bool = True) -> ModuleType | kernel_aot.Loops | None:
    """numba's kernels when they should run a call of ``rows`` rows (module doc), else None;
    ``count``: the call's rows are new batch work (not a second look at rows counted)."""
    global _batch_rows
    if _forced == "python":
        return None
    if _forced == "compiled":
        module = _load(jit=True)
        if module is None:
            raise ImportError("numba's kernels were asked for, and numba cannot be imported")
        return module
    if getattr(_thread, "live", False):
        return None
    if _compiled is not None:
        return _compiled
    if _unavailable or rows < BATCH_CALL_ROWS:
        return None
    if _aot_ready():
        return _load()
    if count:
        _batch_rows += rows
    if _batch_rows < FILL_ROWS:
        return None
    if not cache_ready():
        start_fill()
        return None
    return _load() if _batch_rows >= LOAD_ROWS else None


def _view(a: np.ndarray) -> memoryview:
    """A view the interpreted loops index fast (``mv[k, c]`` reads a Python float)."""
    return memoryview(a)  # type: ignore[arg-type]  # (numpy arrays are buffers; stubs differ)


def _views(args: tuple[Any, ...]) -> list[Any]:
    # (numpy arrays are buffers; the stubs differ)
    return [memoryview(a) if type(a) is np.ndarray else a for a in args]  # type: ignore[arg-type]


def window_groups(n_win: np.ndarray) -> list[tuple[int, slice | np.ndarray]]:
    """The segments' columns grouped by their motion window (samples), for
    :func:`motion_windows`: one group of every column (a slice: no copies) when all agree."""
    sizes = [int(v) for v in n_win]
    if len(set(sizes)) <= 1:
        return [(sizes[0] if sizes else 1, slice(None))]
    return [(v, np.flatnonzero(n_win == v)) for v in sorted(set(sizes))]


def motion_windows(
    tail: np.ndarray, dev: np.ndarray, rate: np.ndarray,
    groups: list[tuple[int, slice | np.ndarray]],
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(N, S) maxima of ``dev`` and ``rate`` over each segment's last n_win samples
    (``groups``: :func:`window_groups`), the samples before the block being ``tail``
    ((n_max - 1, 2, S), -inf before the first), which becomes the last n_max - 1 samples of
    this one. A window's maximum is NaN where its own sample is (an earlier NaN is passed
    over), as ``max(a, b)`` reads in the loop before."""
    m = tail.shape[0]
    n = len(dev)
    out = []
    for q, x in enumerate((dev, rate)):
        ext = np.concatenate([tail[:, q, :], x]) if m else x
        win = x.copy()
        for nw, cols in groups:
            part = win[:, cols]
            for j in range(1, nw):
                np.fmax(part, ext[m - j : m - j + n, cols], out=part)
            if not isinstance(cols, slice):
                win[:, cols] = part
        missing = np.isnan(x)
        if missing.any():
            win[missing] = np.nan
        if m:
            tail[:, q, :] = ext[n:]
        out.append(win)
    return out[0], out[1]


def gait_aware_update(*args: Any) -> None:
    """:func:`gaitmon.dsp.loops.gait_aware_update` in the form the rule picks (module doc)."""
    module = compiled_for(len(args[0]))
    if module is not None:
        module.gait_aware_update(*args)
    else:
        loops.gait_aware_update(*_views(args))


def constant_map_solve(*args: Any) -> None:
    """:func:`gaitmon.dsp.loops.constant_map_solve` in the form the rule picks."""
    module = compiled_for(len(args[2]) // 2)
    if module is not None:
        module.constant_map_solve(*args)
    else:
        loops.constant_map_solve(*_views(args))


def band_cholesky(ab: np.ndarray) -> None:
    """:func:`gaitmon.dsp.loops.band_cholesky` (in place) in the form the rule picks."""
    module = compiled_for(ab.shape[1] // 2)
    if module is not None:
        module.band_cholesky(ab)
    else:
        loops.band_cholesky(_view(ab))


def band_solve(cb: np.ndarray, g: np.ndarray) -> None:
    """:func:`gaitmon.dsp.loops.band_solve` (in place) in the form the rule picks."""
    module = compiled_for(len(g) // 2, count=False)
    if module is not None:
        module.band_solve(cb, g)
    else:
        loops.band_solve(_view(cb), _view(g))


def running_mean(x: np.ndarray, size: int, out: np.ndarray | None = None) -> np.ndarray:
    """:func:`gaitmon.dsp.loops.running_mean` along the last axis of x, zero outside: compiled
    where the rule picks numba (into ``out`` when given: float64, C-contiguous, x's shape), else
    :func:`gaitmon.dsp.windows.sliding_mean` (numpy; the same to rounding, ~3x slower on a long
    record than the compiled loop)."""
    module = compiled_for(x.shape[-1], count=False)
    if module is None:
        from gaitmon.dsp.windows import sliding_mean

        return sliding_mean(x, size, mode="constant")
    rows = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, x.shape[-1])
    dest = np.empty(rows.shape) if out is None else out.reshape(rows.shape)
    module.running_mean(rows, size, 0.0, dest)
    return dest.reshape(x.shape)


def running_means(
    x: np.ndarray, size: int, passes: int, spare: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`running_mean` applied ``passes`` times to x (R, N) float64 C-contiguous, which
    it may overwrite; (the result, a spare buffer of its shape or None). Compiled, the passes
    go from buffer to buffer (x, then ``spare`` or one new array): no temporaries."""
    module = compiled_for(x.shape[-1], count=False)
    if module is None or not plain(x) or x.ndim != 2:
        for _ in range(passes):
            x = running_mean(x, size)
        return x, None
    for _ in range(passes):
        dest = np.empty(x.shape) if spare is None else spare
        module.running_mean(x, size, 0.0, dest)
        x, spare = dest, x
    return x, spare


def plain(a: np.ndarray) -> bool:
    """Whether ``a`` is what the compiled loops are cached for: C-contiguous and writeable (numba
    compiles other layouts apart, at the call, and does not cache read-only arrays)."""
    return bool(a.flags.c_contiguous and a.flags.writeable)


def to_physical(table: ChannelTable, counts: np.ndarray,
                channels: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """``table.to_physical(counts, channels)``: compiled (:func:`gaitmon.dsp.loops.physical`,
    one pass, no temporaries) where the rule picks numba for (N, C) uint16 counts; the same
    numbers."""
    module = compiled_for(len(counts), count=False)
    if module is None or counts.dtype != np.uint16 or counts.ndim != 2 or not plain(counts):
        return table.to_physical(counts, channels)
    cols = np.arange(counts.shape[1]) if channels is None else np.asarray(channels, np.intp)
    zero = np.asarray(table.zero_counts, dtype=np.float64)[cols]
    scale = np.asarray(table.units_per_count, dtype=np.float64)[cols]
    out = np.empty((len(counts), len(cols)))
    module.physical(counts, cols.astype(np.intp), zero, scale, out)
    return out


def zeroed_tilts(tilt: np.ndarray, offset: np.ndarray, out_tilt: np.ndarray,
                 out_joint: np.ndarray | None = None) -> None:  # fmt: skip
    """``out_tilt[:] = wrap_angle(tilt - offset)`` (it may be ``tilt``) and, given
    ``out_joint``, ``out_joint[:] = joint_angles(out_tilt)``
    (:meth:`gaitmon.dsp.calibration.Calibration.apply_tilt`, :func:`gaitmon.dsp.angles.
    joint_angles`): in one compiled pass (:func:`gaitmon.dsp.loops.zeroed_tilts`) where the
    rule picks numba, else numpy; the same numbers."""
    from gaitmon.dsp.angles import JOINT_MINUS, JOINT_PLUS, joint_angles, wrap_angle

    module = compiled_for(len(tilt), count=False)
    if (module is None or tilt.dtype != np.float64 or not plain(tilt) or not plain(out_tilt)
            or (out_joint is not None and not plain(out_joint))):  # fmt: skip
        out_tilt[...] = wrap_angle(np.asarray(tilt, dtype=np.float64) - offset)
        if out_joint is not None:
            out_joint[...] = joint_angles(out_tilt)
        return
    plus, minus = (JOINT_PLUS, JOINT_MINUS) if out_joint is not None else (_NO_JOINT, _NO_JOINT)
    # (a calibration's offsets are read-only: a copy, as numba caches writeable arrays only)
    module.zeroed_tilts(tilt, np.array(offset, dtype=np.float64), plus, minus, out_tilt,
                        np.empty((len(tilt), 0)) if out_joint is None else out_joint)  # fmt: skip


_NO_JOINT = np.empty(0, dtype=np.intp)
