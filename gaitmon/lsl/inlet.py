"""Recording an external LSL marker stream (a stimulator's triggers, an experiment's events)
into a session: finding the stream by name, and a thread that hands every sample on with its
instant on this computer's ``time.monotonic()`` clock, the engine's host clock
(``Engine.add_marker(label, host_time_s=...)`` puts it on the row whose sample was taken then).

An LSL timestamp is on the sender's clock: ``+ inlet.time_correction()`` puts it on this
computer's LSL clock (``pylsl.local_clock``), and a measured offset on ``time.monotonic()``
(the same clock on Linux; not promised elsewhere, so measured, and measured again now and
then).

pylsl is imported here only (``import_pylsl``), when the user asked for LSL: without the
options, nothing opens a socket.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

from gaitmon.errors import UserError

INSTALL_HINT = "install gaitmon[lsl] (pip install 'gaitmon[lsl]')"
PULL_TIMEOUT_S = 0.05  # how long the puller thread waits for a sample: also how soon it stops
CLOCK_REMEASURE_S = 10.0

_quieted = False


def import_pylsl() -> ModuleType:
    """pylsl, or a one-line UserError saying how to install it."""
    try:
        import pylsl
    except (ImportError, OSError, RuntimeError) as exc:  # missing, or its liblsl missing
        raise UserError(
            f"Lab Streaming Layer needs pylsl, which could not be loaded ({exc}); {INSTALL_HINT}"
        ) from None
    _quiet_logs(pylsl)
    return pylsl


def _quiet_logs(pylsl: ModuleType) -> None:
    """liblsl logs at INFO on standard error; a command line wants its errors only. Never over
    a user's own lsl_api.cfg (it may hold the lab's network settings)."""
    global _quieted
    if _quieted:
        return
    _quieted = True
    cfgs = [Path("lsl_api.cfg"), Path.home() / "lsl_api" / "lsl_api.cfg",
            Path("/etc/lsl_api/lsl_api.cfg")]  # fmt: skip
    if os.environ.get("LSLAPICFG") or any(p.is_file() for p in cfgs):
        return
    with contextlib.suppress(Exception):  # too late (LSL already in use) or an old liblsl
        pylsl.set_config_content("[log]\nlevel = -2\n")


def resolve_marker_stream(pylsl: ModuleType, name: str, timeout_s: float, option: str) -> Any:
    """The ``StreamInfo`` of the irregular-rate stream named ``name``; a one-line UserError if
    there is none within ``timeout_s`` (naming the streams that are there) or it is a regular
    stream. ``option`` is the command-line option that named it, for the message."""
    if not name.strip():
        raise UserError(f"{option} needs the name of an LSL marker stream")
    # one continuous resolver, polled: it answers as soon as the stream is seen, and knows what
    # else it saw for the message (liblsl's one-shot resolves overran their timeout by 5-15 s
    # on a loaded machine)
    resolver = pylsl.ContinuousResolver(forget_after=max(5.0, timeout_s))
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            streams = resolver.results()
            found = [s for s in streams if s.name() == name]
            if found or time.monotonic() >= deadline:
                break
            time.sleep(0.02)
    finally:
        del resolver
    if not found:
        seen = sorted({s.name() for s in streams})
        listed = ", ".join(repr(s) for s in seen[:8]) + (" ..." if len(seen) > 8 else "")
        there = f"streams seen: {listed}" if seen else "no LSL stream is visible at all"
        raise UserError(
            f"no LSL stream named {name!r} ({option}) found within {timeout_s:g} s ({there}); "
            "start its sender, check the name (case matters), or wait longer with --lsl-timeout"
        )
    info = found[0]
    rate = float(info.nominal_srate())
    if rate != 0:
        raise UserError(
            f"LSL stream {name!r} ({option}) is a regular {rate:g} Hz stream, not a marker "
            "stream; give the name of an irregular-rate (marker) stream"
        )
    return info


def _label(value: object) -> str:
    if isinstance(value, float) and math.isfinite(value) and value.is_integer():
        return str(int(value))  # a numeric trigger code: "12", not "12.0"
    return str(value)


class MarkerInlet:
    """One marker stream, connected; ``start(on_marker)`` starts a thread that calls
    ``on_marker(label, host_time_s)`` per sample, in the order received (``host_time_s`` on
    ``time.monotonic()``'s clock). The label is the sample's first channel (a number as its
    code: "12")."""

    def __init__(
        self,
        pylsl: ModuleType,
        info: Any,
        *,
        open_timeout_s: float = 5.0,
        thread_name: str = "gaitmon-lsl-inlet",
    ) -> None:
        self.name = str(info.name())
        self._pylsl = pylsl
        self._on_marker: Callable[[str, float], None] | None = None
        self.received = 0
        self.error = ""  # the last failure to pull or to hand a sample on
        self._stop = threading.Event()
        self._inlet = pylsl.StreamInlet(info, max_buflen=360, recover=True)
        try:
            self._inlet.open_stream(timeout=open_timeout_s)
            self._correction_s = float(self._inlet.time_correction(timeout=open_timeout_s))
        except Exception as exc:  # pylsl raises TimeoutError, or RuntimeError on a lost stream
            self._inlet.close_stream()
            raise UserError(
                f"could not connect to the LSL stream {self.name!r} within {open_timeout_s:g} s "
                f"({type(exc).__name__}: {exc}); check that its sender is still running"
            ) from None
        self._offset_s = self._measure_offset()
        self._measured_at = time.monotonic()
        self._thread = threading.Thread(target=self._run, name=thread_name, daemon=True)

    def start(self, on_marker: Callable[[str, float], None]) -> None:
        self._on_marker = on_marker
        self._thread.start()

    def close(self) -> None:
        """Stop the thread and close the stream. Idempotent."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        with contextlib.suppress(Exception):
            self._inlet.close_stream()

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def _measure_offset(self) -> float:
        """``time.monotonic() - pylsl.local_clock()``, from the tightest of a few readings."""
        best: tuple[float, float] | None = None
        for _ in range(5):
            t0 = time.monotonic()
            lsl = self._pylsl.local_clock()
            t1 = time.monotonic()
            if best is None or t1 - t0 < best[0]:
                best = (t1 - t0, (t0 + t1) / 2 - lsl)
        assert best is not None
        return best[1]

    def _clock(self) -> float:
        """The offset from the sender's clock to ``time.monotonic()``, kept up to date."""
        now = time.monotonic()
        if now - self._measured_at >= CLOCK_REMEASURE_S:
            self._measured_at = now
            self._offset_s = self._measure_offset()
            with contextlib.suppress(Exception):  # the last estimate is still good
                self._correction_s = float(self._inlet.time_correction(timeout=0.5))
        return self._correction_s + self._offset_s

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                samples, stamps = self._inlet.pull_chunk(timeout=PULL_TIMEOUT_S)
            except Exception as exc:  # a broken stream: say so, keep trying
                self.error = f"{type(exc).__name__}: {exc}"
                self._stop.wait(0.5)
                continue
            if not stamps:
                continue
            offset_s = self._clock()
            self._deliver(samples, stamps, offset_s)

    def _deliver(self, samples: Sequence[Sequence[object]], stamps: Sequence[float],
                 offset_s: float) -> None:  # fmt: skip
        for sample, ts in zip(samples, stamps, strict=True):
            self.received += 1
            try:
                assert self._on_marker is not None
                self._on_marker(_label(sample[0]) if len(sample) else "", float(ts) + offset_s)
            except Exception as exc:  # one bad sample must not end the inlet
                self.error = f"{type(exc).__name__}: {exc}"
