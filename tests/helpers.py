"""Helpers shared by the tests that drive a live engine: one copy each (imported as
``from helpers import make_engine, wait_for``; pytest puts this folder on the path).

Waits are on a condition with a generous deadline, never a fixed sleep: a loaded machine makes
them slower, not wrong."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

from gaitmon.engine import Engine
from gaitmon.io.device import Device
from gaitmon.io.sim import FaultConfig, GaitConfig, SimulatedUnit
from gaitmon.io.transport import InProcessTransport

WAIT_S = 60.0  # long enough for a machine running other suites beside this one


def wait_for(pred: Callable[[], object], timeout_s: float = WAIT_S, what: str = "condition",
             poll_s: float = 0.005) -> None:  # fmt: skip
    """Return as soon as ``pred()`` is true; AssertionError naming ``what`` after
    ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not pred():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(poll_s)


class HeldClock:
    """A simulated unit's clock (``SimulatedUnit(clock=...)``) that runs with the wall clock but
    stands still at ``hold_s`` until :meth:`hold` moves that point or :meth:`release`, then runs
    on from there: the unit's time (``speed`` x this clock; its walk advances from its creation,
    streamed or not) cannot pass a phase of the walk however late a loaded machine gets to the
    step that needs it."""

    def __init__(self, hold_s: float | None = None) -> None:
        self._lock = threading.Lock()
        self._t0 = time.monotonic()
        self.hold_s = hold_s

    def __call__(self) -> float:
        with self._lock:
            t = time.monotonic() - self._t0
            return t if self.hold_s is None else min(t, self.hold_s)

    def hold(self, hold_s: float) -> None:
        """Run (with the wall clock) up to ``hold_s``, and stand still there."""
        with self._lock:
            self.hold_s = hold_s

    def release(self) -> None:
        with self._lock:
            if self.hold_s is not None:  # on from the held time, not a jump to the wall's
                self._t0 = min(self._t0, time.monotonic() - self.hold_s)
                self.hold_s = None


def make_engine(
    mode: str = "raw", *, speed: float = 20.0, faults: FaultConfig | None = None,
    standing_s: float = 3.0, seed: int = 3, stride_cv: float | None = None,
    clock: Callable[[], float] | None = None, **engine_kw: object,
) -> tuple[SimulatedUnit, Engine]:  # fmt: skip
    """A simulated unit (``GaitConfig(seed, standing_s[, stride_cv])`` at ``speed`` times real
    time on ``clock``, with ``faults``) and an engine on it over the in-process transport, not
    started. ``engine_kw`` go to :class:`Engine` (``config``, ``recorder_queue_blocks``...)."""
    gait = GaitConfig(seed=seed, standing_s=standing_s)
    if stride_cv is not None:
        gait = GaitConfig(seed=seed, standing_s=standing_s, stride_cv=stride_cv)
    unit = SimulatedUnit(gait, faults=faults, speed=speed, clock=clock or time.monotonic)
    eng = Engine(Device(InProcessTransport(unit)), mode, transport_label="simulated",
                 **engine_kw)  # type: ignore[arg-type]  # fmt: skip
    return unit, eng


def assert_blocks_equal(parts: list, whole) -> None:  # type: ignore[no-untyped-def]
    """Pipeline blocks (``PipelineBlock``) of one record processed in pieces equal the block of
    the record processed whole: every per-sample array joined, the per-block lists (gyro events,
    FSR faults) joined, the strides the engine makes of the events, the event source in force at
    the end."""
    import dataclasses

    import numpy as np

    from gaitmon.dsp.pipeline import PipelineBlock
    from gaitmon.engine.live_gait import GaitEvents

    per_block = ("gyro_heel_strike_idx", "gyro_toe_off_idx", "fsr_faults", "event_source")
    for f in dataclasses.fields(PipelineBlock):
        if f.name in ("start_idx", "kalman_bias_rad_s", *per_block):
            continue
        got = np.concatenate([getattr(b, f.name) for b in parts])
        np.testing.assert_array_equal(got, getattr(whole, f.name), err_msg=f.name)
    for name in per_block[:3]:  # decided in some block: the same list in any chunking
        assert [x for b in parts for x in getattr(b, name)] == list(getattr(whole, name)), name
    assert parts[-1].event_source == whole.event_source
    # the strides the engine makes of the events (GaitEvents), fed block by block
    live = GaitEvents(100.0)
    strides = [s for b in parts for s in live.strides(b.heel_strike_idx, b.toe_off_idx)]
    assert strides == GaitEvents(100.0).strides(whole.heel_strike_idx, whole.toe_off_idx)


class StalledDisk:
    """``SessionWriter.append`` waits (as on a stalled disk) until ``go`` is set, once the file
    holds ``after_rows`` rows (0: from the first block on); ``stalled`` is set when it does."""

    def __init__(self, monkeypatch, after_rows: int = 0) -> None:  # type: ignore[no-untyped-def]
        import threading

        from gaitmon.io.session import SessionWriter

        self.real = SessionWriter.append
        self.stalled = threading.Event()
        self.go = threading.Event()
        stall = self

        def append(self, *a, **kw):  # type: ignore[no-untyped-def]
            if not stall.go.is_set() and self.rows >= after_rows:
                stall.stalled.set()
                stall.go.wait(30)
            return stall.real(self, *a, **kw)

        monkeypatch.setattr(SessionWriter, "append", append)


def numeric_datasets(path: Path) -> dict[str, np.ndarray]:
    """Every numeric dataset of an HDF5 file, by its path (two runs' files compared)."""
    out: dict[str, np.ndarray] = {}
    with h5py.File(path, "r") as f:
        def keep(name: str, obj: object) -> None:
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu":
                out[name] = obj[()]
        f.visititems(keep)
    return out


def killed_recording(folder: Path) -> Path:
    """A 1-min raw recording killed (SIGKILL) before its close, in a child process, copied
    with its journal into ``folder`` as ``copy.h5``: the first open recovers it."""
    import shutil
    import subprocess
    import sys

    from gaitmon.io.journal import journal_path

    killed = folder / "killed.h5"
    argv = [sys.executable, "-m", "gaitmon.commands.bench_memory", "_killed", "1min", str(killed)]
    r = subprocess.run(argv, capture_output=True, text=True, check=False)
    assert journal_path(killed).exists(), r.stderr[-500:]
    src = folder / "copy.h5"
    shutil.copyfile(killed, src)
    shutil.copyfile(journal_path(killed), journal_path(src))
    return src


# ---- two-leg files whose clock fits disagree (a host that read one link late) ------------------

TWO_LEGS = Path(__file__).resolve().parent / "data" / "golden" / "two_legs.h5"  # kept, real


def parts_with_late_rows(
    both: Path, target: Path, side: str, shift_s: float = 0.0,
    common_s: Callable[[h5py.File, str], np.ndarray] | None = None,
) -> None:
    """``both``'s legs as the parts of ``target``, with receive times made from each row's
    common time (``common_s(f, side)``; default: the unit's own clock ``t_s``) at 4x real time,
    plus a link's usual few ms, rather than this machine's load; ``side``'s late by 50 ms to 0.3
    s (growing) from its second second on: a host that fell behind that unit's link (its clock
    fit is bent by far more than two crystals differ). ``shift_s``: the right unit's rows taken
    that many common seconds later (it started later)."""
    from gaitmon.finish.bilateral import part_path

    rng = np.random.default_rng(5)
    with h5py.File(both, "r") as f:
        for s in ("L", "R"):
            with h5py.File(part_path(target, s), "w") as g:
                u = f[f"units/{s}"]
                g.attrs.update(dict(u.attrs))
                for name in u:
                    f.copy(u[name], g, name=name)
                t = g["timeline/t_s"][()]
                usual = np.where(rng.random(len(t)) < 0.3, 0.0, rng.exponential(0.004, len(t)))
                common = t if common_s is None else common_s(f, s)
                host = 500.0 + (common + (shift_s if s == "R" else 0.0)) / 4.0
                host += usual
                if s == side:
                    host += np.where(t > 1.0, 0.05 + 0.25 * (t - 1.0) / (t[-1] - 1.0), 0.0)
                g["timeline/host_time_s"][...] = host


def two_legs_with_caveat(folder: Path, late_side: str = "R", shift_s: float = 0.0) -> Path:
    """The kept two-leg recording (``TWO_LEGS``) combined again from parts with late receive
    times (:func:`parts_with_late_rows`): with ``late_side`` its clock fits disagree and the
    file's ``/sync`` warning says so; with ``late_side=""`` and ``shift_s`` seconds the legs
    were recorded together briefly."""
    from gaitmon.finish.combine import combine_parts

    out = folder / ("late.h5" if late_side else "apart.h5")
    parts_with_late_rows(TWO_LEGS, out, late_side, shift_s)
    combine_parts(out)
    return out
