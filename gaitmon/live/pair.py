"""Both legs in the live window, Qt-free: opening the pair of units and the live bilateral view.

:func:`open_pair` starts one :class:`Engine` per leg, from two serial ports (left first) or a
simulated pair (:class:`~gaitmon.io.sim.bilateral.BilateralSim`) served on two pseudo-terminals
and reached through the real ``SerialTransport``, exactly as one unit is
(:mod:`gaitmon.live.connection`). The engines stream without recording; Record asks their
:class:`~gaitmon.engine.pair.EnginePair` to record (the path ``gaitmon record --ports`` takes).

:class:`LegClock` puts a leg's snapshot on the host's clock: each unit counts its own samples
(``t_s``), so the newest samples of two units are not "now" for the same reason. The host
receive times lie on or above "sample time + the link's shortest delay" (``docs/bilateral.md``),
so a line under the window's points (unit time, host receive time), touching the quickest
read, maps the unit's time onto the host's to within the link's shortest delay (a few ms, the
same for two links of one kind): the recorded file's own lower-envelope fit
(``dsp.clock_fit.envelope_line``), over the display window. Both legs are then drawn against one
"seconds before now", and a leg whose link is cut shows the time since its last sample.

:class:`LiveBilateral` keeps both legs' recent heel strikes and toe offs, puts the right leg's
on the left unit's clock (the distance between the two units' clocks, from their host-time
lines, averaged over about a second of ticks), and computes the measured cadence, step times
and double support with :func:`gaitmon.dsp.bilateral.bilateral_gait`, the function the
recorded file's analysis (``analysis.analyse_bilateral``) uses. A leg's events before its
last gap or filter settling are dropped, so no step or stride spans a gap.
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass, field

import numpy as np

from gaitmon.dsp.bilateral import BilateralGait, bilateral_gait
from gaitmon.dsp.clock_fit import envelope_line
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine, EngineError, Mode, Snapshot
from gaitmon.engine.pair import EnginePair
from gaitmon.io.device import Device
from gaitmon.io.ports import make_transport
from gaitmon.io.sim.bilateral import BilateralConfig, BilateralPty, serve_pair_on_ptys
from gaitmon.io.transport import LinkError

SIDES = ("L", "R")
SIDE_NAMES = {"L": "left", "R": "right"}
EVENTS_KEPT = 24  # per side: the last ~12 strides' heel strikes and toe offs
MAX_STRIDE_S = 3.0  # a longer "stride" spans a stop or a gap: not a stride
SMOOTHING = 0.05  # per tick, of the distance between the two units' clocks (~1 s at 30 Hz)
JUMP_S = 0.1  # a reading this far from it starts it again (a unit restarted its clock)


@dataclass(frozen=True)
class PairSource:
    """What to connect both legs to: two ports (left, right) or the simulated pair."""

    ports: tuple[str, str] | None = None
    sim: BilateralConfig | None = None  # used when ports is None (default: BilateralConfig())

    @property
    def simulated(self) -> bool:
        return self.ports is None

    def label(self) -> str:
        if self.ports is None:
            return "the simulated pair"
        return f"{self.ports[0]} (left) and {self.ports[1]} (right)"


@dataclass
class PairConnection:
    """Both legs' started engines and, for the simulated pair, the simulator behind them."""

    pair: EnginePair
    source: PairSource
    simulator: BilateralPty | None = None

    @property
    def engines(self) -> dict[str, Engine]:
        return self.pair.engines

    @property
    def simulated(self) -> bool:
        return self.simulator is not None

    def port_name(self, side: str) -> str:
        """How the link banner names this leg's port."""
        if self.source.ports is None:
            return f"the simulated {SIDE_NAMES[side]} unit"
        return self.source.ports[SIDES.index(side)]

    def close(self) -> None:
        """Stop both engines (a recording running is finished, not combined: the next reader
        of its file combines the parts), then the simulator. Idempotent."""
        try:
            for eng in self.engines.values():
                with contextlib.suppress(Exception):
                    eng.stop()
        finally:
            if self.simulator is not None:
                with contextlib.suppress(RuntimeError):
                    self.simulator.stop()
                self.simulator.sim.close()


def open_pair(source: PairSource, mode: Mode | str, config: PipelineConfig) -> PairConnection:
    """Connect both units, each identified and streaming; ``EngineError`` with one line (and
    nothing left running) when either cannot start."""
    simulator: BilateralPty | None = None
    if source.ports is None:
        try:
            simulator = serve_pair_on_ptys(source.sim or BilateralConfig())
        except OSError as exc:
            raise EngineError(
                f"cannot create the simulated pair's pseudo-terminals: {exc}"
            ) from None
        paths = tuple(str(p) for p in simulator.link_paths)
        labels = ("simulated", "simulated")
    else:
        left, right = source.ports
        if not left or not right or left == right:
            raise EngineError("both legs need two different ports, the left one first")
        paths = labels = (left, right)
    engines: list[Engine] = []
    try:
        for path, label in zip(paths, labels, strict=True):
            eng = Engine(Device(make_transport(path)), mode, config, transport_label=label)
            try:
                eng.start()
            except (EngineError, LinkError) as exc:
                side = SIDE_NAMES[SIDES[len(engines)]]
                raise EngineError(f"the {side} unit: {exc}") from None
            engines.append(eng)
    except BaseException:
        for eng in engines:
            with contextlib.suppress(Exception):
                eng.stop()
        if simulator is not None:
            with contextlib.suppress(RuntimeError):
                simulator.stop()
            simulator.sim.close()
        raise
    return PairConnection(EnginePair(engines[0], engines[1]), source, simulator)


class LegClock:
    """A leg's unit time <-> host time (``time.monotonic()``), from its snapshots (module doc):
    the line ``host = h_ref + slope (t - t_ref)`` under every (t_s, host_time_s) of the window,
    touching the quickest read (``dsp.clock_fit.envelope_line``, the file's fit). Its slope:
    1 within tens of ppm for a real unit, 1 / speed for a simulator run faster than real
    time; a window shorter than ``MIN_SPAN_S`` keeps the slope it had."""

    MIN_SPAN_S = 1.0  # a shorter window keeps the slope it had (1 at first)

    def __init__(self) -> None:
        self.t_ref = math.nan
        self.h_ref = math.nan
        self.slope = 1.0

    @property
    def known(self) -> bool:
        return math.isfinite(self.h_ref)

    def update(self, snap: Snapshot) -> None:
        s = snap.series
        t, h = s["t_s"], s["host_time_s"]
        ok = np.isfinite(t) & np.isfinite(h)
        if ok.sum() < 2:
            return
        t, h = t[ok], h[ok]
        # the one lower-envelope fit (the file's, the markers'); ~0.1 ms for a 10-s window
        a, self.slope = envelope_line(t - t[-1], h - h[-1], self.slope, self.MIN_SPAN_S)
        self.t_ref = float(t[-1])
        self.h_ref = float(h[-1]) + a

    def host_s(self, t_s: np.ndarray | float) -> np.ndarray:
        """Host time of unit times (NaN before any data)."""
        return np.asarray(self.h_ref + self.slope * (np.asarray(t_s, np.float64) - self.t_ref))

    def unit_s(self, host_s: float) -> float:
        """Unit time at a host time (NaN before any data)."""
        return self.t_ref + (host_s - self.h_ref) / self.slope


@dataclass
class _SideEvents:
    heel_strike_t_s: np.ndarray = field(default_factory=lambda: np.empty(0))
    toe_off_t_s: np.ndarray = field(default_factory=lambda: np.empty(0))
    break_t_s: float = -math.inf  # the newest lost or settling row seen (unit time)

    def add(self, snap: Snapshot) -> None:
        s = snap.series
        broken = (s["lost"] > 0) | (s["settling"] > 0)
        if broken.any():
            self.break_t_s = max(self.break_t_s, float(s["t_s"][np.flatnonzero(broken)[-1]]))
        for name in ("heel_strike_t_s", "toe_off_t_s"):
            got = np.union1d(getattr(self, name), getattr(snap, name))
            got = got[got > self.break_t_s]
            setattr(self, name, got[-EVENTS_KEPT:])


class LiveBilateral:
    """Both legs' clocks and recent events, and the live bilateral measures (module doc)."""

    def __init__(self) -> None:
        self.clocks: dict[str, LegClock] = {}
        self._events: dict[str, _SideEvents] = {}
        self.reset()

    def reset(self) -> None:
        """A new connection: no clock, no events."""
        self.clocks = {side: LegClock() for side in SIDES}
        self._events = {side: _SideEvents() for side in SIDES}
        self.r_to_l_s = math.nan  # left unit time - right unit time, at one instant

    def update(self, snaps: dict[str, Snapshot]) -> None:
        """Feed both legs' newest snapshots (each tick)."""
        for side, snap in snaps.items():
            self.clocks[side].update(snap)
            self._events[side].add(snap)
        left, right = self.clocks["L"], self.clocks["R"]
        if left.known and right.known:
            now = time.monotonic()
            d = left.unit_s(now) - right.unit_s(now)
            # the two units' clocks keep their distance (tens of ppm apart): average each
            # tick's reading, whose quickest reads jitter by a few ms on a busy host
            if not math.isfinite(self.r_to_l_s) or abs(d - self.r_to_l_s) > JUMP_S:
                self.r_to_l_s = d
            else:
                self.r_to_l_s += SMOOTHING * (d - self.r_to_l_s)

    def x_now(self, side: str, now_s: float | None = None) -> float:
        """Unit time of ``side`` at host time ``now_s`` (default: now): subtract it from the
        leg's ``t_s`` for "seconds before now" (NaN before any data)."""
        return self.clocks[side].unit_s(time.monotonic() if now_s is None else now_s)

    def gait(self) -> BilateralGait:
        """Step, stride, stance, support and symmetry over both legs' recent events
        (``bilateral_gait``), on the left unit's clock: the right leg's events moved by
        ``r_to_l_s`` (none before both legs have data). Unit seconds are the crystals'
        seconds (tens of ppm from true), also when a simulator runs faster than real time."""
        d = self.r_to_l_s if math.isfinite(self.r_to_l_s) else math.nan
        left, right = self._events["L"], self._events["R"]
        return bilateral_gait(
            left.heel_strike_t_s, left.toe_off_t_s,
            right.heel_strike_t_s + d, right.toe_off_t_s + d,
            max_stride_s=MAX_STRIDE_S,
        )  # fmt: skip
