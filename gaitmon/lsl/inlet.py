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

A marker stream is input from another process, maybe another computer, and is trusted with
nothing (docs/trust-model.md): each label is cleaned as it is pulled (``clean_label``: control
characters escaped, at most 256 characters; bytes that are not UTF-8 replaced, never a lost
chunk), and a stream that sends more than ``MarkerBudget`` allows has the excess dropped and
counted (a flood neither grows memory nor stalls the engine thread).
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

from gaitmon.errors import UserError
from gaitmon.lsl.network import configure
from gaitmon.text import MAX_LABEL_CHARS, clean_label

INSTALL_HINT = "install gaitmon[lsl] (pip install 'gaitmon[lsl]')"
PULL_TIMEOUT_S = 0.05  # how long the puller thread waits for a sample: also how soon it stops
CLOCK_REMEASURE_S = 10.0
PULL_MAX_SAMPLES = 1024  # per pull: a flood is taken in bounded bites
# the bytes of a string sample decoded at most: a label is cut to MAX_LABEL_CHARS anyway
# (4 bytes a character in UTF-8 at most, and room for the truncation mark to show)
_MAX_LABEL_BYTES = 4 * 4 * MAX_LABEL_CHARS


def import_pylsl(scope: str | None = None) -> ModuleType:
    """pylsl with gaitmon's network settings applied (``network.configure``: ``scope``, by
    default this computer only), or a one-line UserError saying how to install it."""
    try:
        import pylsl
    except (ImportError, OSError, RuntimeError) as exc:  # missing, or its liblsl missing
        raise UserError(
            f"Lab Streaming Layer needs pylsl, which could not be loaded ({exc}); {INSTALL_HINT}"
        ) from None
    configure(pylsl, scope)
    return pylsl


def resolve_marker_stream(
    pylsl: ModuleType,
    name: str,
    timeout_s: float,
    option: str,
    source_id: str | None = None,
) -> Any:
    """The ``StreamInfo`` of the irregular-rate stream named ``name`` (and, if given, with the
    source id ``source_id``); a one-line UserError if there is none within ``timeout_s``
    (naming the streams that are there), if several streams of that name are there and no
    source id says which (a stream's name is no proof of who sends it: any program on the
    network may use it), or if it is a regular stream. ``option`` is the command-line option
    that named it, for the message."""
    if not name.strip():
        raise UserError(f"{option} needs the name of an LSL marker stream")
    if source_id is not None and not source_id.strip():
        raise UserError(f"{option}-source-id needs the source id of the LSL stream {name!r}")
    # one continuous resolver, polled: it answers as soon as the stream is seen, and knows what
    # else it saw for the message (liblsl's one-shot resolves overran their timeout by 5-15 s
    # on a loaded machine)
    resolver = pylsl.ContinuousResolver(forget_after=max(5.0, timeout_s))
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            streams = resolver.results()
            named = [s for s in streams if s.name() == name]
            found = [s for s in named if source_id is None or s.source_id() == source_id]
            if found or time.monotonic() >= deadline:
                break
            time.sleep(0.02)
        if len({s.uid() for s in found}) > 1 or (found and source_id is None):
            # a second stream of the same name may answer a moment later: look a little more
            until = time.monotonic() + min(0.5, timeout_s)
            while time.monotonic() < until:
                time.sleep(0.05)
            named = [s for s in resolver.results() if s.name() == name] or named
            found = [s for s in named if source_id is None or s.source_id() == source_id]
    finally:
        del resolver
    if not found and named:
        raise UserError(
            f"no LSL stream named {name!r} with source id {source_id!r} ({option}-source-id) "
            f"found within {timeout_s:g} s; the streams of that name have {_sources(named)}"
        )
    if len({s.uid() for s in found}) > 1:
        how = (
            f"say which with {option}-source-id ID"
            if source_id is None
            else "stop the other sender, or give each a source id of its own"
        )
        raise UserError(
            f"{len(found)} LSL streams are named {name!r} ({option}): {_sources(found)}; {how}"
        )
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


def _sources(streams: Sequence[Any]) -> str:
    """"source id 'a' on host 'h', ..." for a message (each cleaned: they come from outside)."""
    return ", ".join(
        f"source id {clean_label(s.source_id())!r} on host {clean_label(s.hostname())!r}"
        for s in streams[:4]
    ) + (" ..." if len(streams) > 4 else "")


def _label(value: object) -> str:
    """A sample's first channel as a clean label (``clean_label``): a number as its code
    ("12", not "12.0"); a string's bytes as UTF-8, invalid bytes replaced."""
    if isinstance(value, float) and math.isfinite(value) and value.is_integer():
        return str(int(value))  # a numeric trigger code: "12", not "12.0"
    if isinstance(value, bytes | bytearray):
        value = bytes(value[:_MAX_LABEL_BYTES]).decode("utf-8", errors="replace")
    return clean_label(value)


@dataclass
class MarkerBudget:
    """How many markers a stream may send: ``burst`` at once, then ``rate_hz`` a second
    (a token bucket), and ``total`` in all. What is over is dropped and counted: a stream
    that floods gaitmon must not grow its memory without bound, fill the recording with
    junk, or keep the engine thread busy placing markers."""

    rate_hz: float = 100.0
    burst: int = 1000
    total: int = 100_000
    _tokens: float = -1.0
    _at: float = 0.0
    _taken: int = 0

    def take(self, now_s: float) -> bool:
        """True if one more marker may pass at ``now_s`` (and it is counted)."""
        return self.allow(now_s, 1) == 1

    def allow(self, now_s: float, n: int) -> int:
        """How many of ``n`` markers arriving at ``now_s`` may pass (the first ones; counted).
        One call per chunk: a flood costs no Python work per marker dropped."""
        if self._tokens < 0:
            self._tokens, self._at = float(self.burst), now_s
        self._tokens = min(float(self.burst), self._tokens + (now_s - self._at) * self.rate_hz)
        self._at = now_s
        ok = max(0, min(n, int(self._tokens), self.total - self._taken))
        self._tokens -= ok
        self._taken += ok
        return ok

    def describe(self) -> str:
        return (
            f"more than {self.burst:,} at once, {self.rate_hz:g} a second or "
            f"{self.total:,} in all"
        )


class MarkerInlet:
    """One marker stream, connected; ``start(on_marker)`` starts a thread that calls
    ``on_marker(label, host_time_s)`` per sample, in the order received (``host_time_s`` on
    ``time.monotonic()``'s clock). The label is the sample's first channel, cleaned
    (``_label``: a number as its code, "12"). With a ``budget``, the samples over it are
    dropped and counted in ``dropped`` (``received`` counts every sample pulled)."""

    def __init__(
        self,
        pylsl: ModuleType,
        info: Any,
        *,
        open_timeout_s: float = 5.0,
        thread_name: str = "gaitmon-lsl-inlet",
        budget: MarkerBudget | None = None,
    ) -> None:
        self.name = str(info.name())
        self._pylsl = pylsl
        self._on_marker: Callable[[str, float], None] | None = None
        self._budget = budget
        self._raw_strings = info.channel_format() == pylsl.cf_string
        self.received = 0
        self.dropped = 0  # over the budget: not handed on
        self.error = ""  # the last failure to pull or to hand a sample on
        self._stop = threading.Event()
        # liblsl buffers max_buflen x 100 samples of an irregular stream (36,000) for a slow
        # puller and drops the oldest beyond that, uncounted (LSL samples carry no sequence
        # number): the puller keeps up (each label cut before any other work)
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
    def budget_text(self) -> str:
        """What the budget allows, for a message ("" without one)."""
        return "" if self._budget is None else self._budget.describe()

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
                samples, stamps = self._pull()
            except Exception as exc:  # a broken stream: say so, keep trying
                self.error = f"{type(exc).__name__}: {exc}"
                self._stop.wait(0.5)
                continue
            if len(stamps) == 0:
                continue
            offset_s = self._clock()
            self._deliver(samples, stamps, offset_s)

    def _pull(self) -> tuple[Sequence[Sequence[object]], Sequence[float]]:
        """A chunk; a string stream's values as bytes (pylsl's own decoding raises on bytes
        that are not UTF-8, losing the whole chunk), decoded by ``_label``."""
        if self._raw_strings:
            try:
                return self._inlet.pull_chunk(
                    timeout=PULL_TIMEOUT_S, max_samples=PULL_MAX_SAMPLES, as_numpy=True
                )
            except TypeError:  # a pylsl before 1.18: no as_numpy
                self._raw_strings = False
        return self._inlet.pull_chunk(
            timeout=PULL_TIMEOUT_S, max_samples=PULL_MAX_SAMPLES
        )

    def _deliver(self, samples: Sequence[Sequence[object]], stamps: Sequence[float],
                 offset_s: float) -> None:  # fmt: skip
        n = len(stamps)
        ok = n if self._budget is None else self._budget.allow(time.monotonic(), n)
        self.received += n
        self.dropped += n - ok
        for sample, ts in zip(samples[:ok], stamps[:ok], strict=True):
            try:
                assert self._on_marker is not None
                self._on_marker(_label(sample[0]) if len(sample) else "", float(ts) + offset_s)
            except Exception as exc:  # one bad sample must not end the inlet
                self.error = f"{type(exc).__name__}: {exc}"
