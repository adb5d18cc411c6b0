"""Two simulated units, one per leg, driven by one walking model, with their own clocks.

This module owns the bilateral simulation: one walk (:class:`BilateralWalk`) that times both
legs' heel strikes and toe offs on a common time line, each leg's motion (:class:`LegGaitModel`,
the single-unit gait model fed with that leg's events), two :class:`SimulatedUnit` s with their
own sample clocks, faults and identities (:class:`BilateralSim`), their ground truth on the
common time base (:class:`BilateralTruth`), and serving both on two pseudo-terminals at once
(:class:`BilateralPty`, :func:`serve_pair_on_ptys`). ``docs/simulator.md`` describes it.

The walk
--------
One stride schedule drives both legs: stride durations are drawn once (mean 120 / cadence,
coefficient of variation ``stride_cv``, from the same seeded generator as a single unit's), so
both legs share the stride-to-stride variability. The right leg steps off first and its heel
strikes H_k follow the single-unit model exactly (same seed, same times); the left heel strike
of stride k falls at H_k + phi_L * (H_{k+1} - H_k), where phi_L is the left step's share of the
stride (0.5 symmetric: the legs half a cycle apart). Each leg's toe off lies at its own stance
fraction of its own stride. The left leg stands until half a stride later than the right, then
walks in the same way (both ramp in over a stride from the standing pose).

Asymmetry ``"hemiparetic"``: the ``affected`` leg (L or R) has a shorter step (``step_ratio``
= affected step time / unaffected step time, default 0.85, so phi_affected = r / (1 + r)), a
shorter stance (default 0.60 of its stride against 0.66 on the unaffected side) and a stiff knee
in swing (the ``stiff-knee`` pattern's swing knee-flexion scale, 0.45). ``"none"`` (default):
symmetric, both legs with the ``pattern``'s stance and knee. Any of the four may be set
explicitly; both double supports must stay >= 2 % of the stride (``ValueError`` otherwise).

Clocks
------
Unit k's sample n is taken at common time ``offset_s + n / (fs (1 + ppm 1e-6))``
(:class:`gaitmon.io.sim.clock.CrystalClock`): defaults left 0.2537 s, +37 ppm; right 0.0412 s,
-22 ppm. Each leg's motion is the walk seen at its own samples' common times, so the two units'
data disagree about time exactly as real units would. Faults (``FaultConfig``: loss, bursts,
silences, link drops) are per unit, their times in that unit's device seconds (its sample index
/ fs, i.e. common time - offset, give or take the drift).

Truth
-----
:meth:`BilateralSim.truth` gives, per side, the heel-strike and toe-off times in common seconds
and the first sample at or after each in that unit's own clock (the same index
``unit.truth()`` gives), and the bilateral measures computed from those times by
:func:`gaitmon.dsp.bilateral.bilateral_gait` (step time, stride, stance, swing, double and
single support, symmetry ratio and index; definitions there).

Not simulated yet: stopping and walking on request (``SimulatedUnit.stand_still`` / ``walk``
raise ``NotImplementedError`` for a leg of a pair).
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

import numpy as np

from gaitmon.dsp.bilateral import BilateralGait, bilateral_gait
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.io.sim.clock import CrystalClock
from gaitmon.io.sim.faults import FaultConfig
from gaitmon.io.sim.kinematics import START_PHASE, TOE_OFF_PHASE, GaitConfig, GaitModel
from gaitmon.io.sim.patterns import PATTERNS
from gaitmon.io.sim.pty import PtySimulator
from gaitmon.io.sim.sensors import SensorConfig
from gaitmon.io.sim.unit import SimulatedUnit

SIDES = ("L", "R")
LEADING = "R"  # the leg that steps off first
ASYMMETRIES = ("none", "hemiparetic")
# hemiparetic defaults: (affected / unaffected step time, affected stance fraction,
# unaffected stance fraction, affected swing knee-flexion scale)
HEMIPARETIC = (0.85, 0.60, 0.66, PATTERNS["stiff-knee"][1])
MIN_DOUBLE_SUPPORT = 0.02  # of the stride: keeps the four events of a stride in order
_STRIDE_CHUNK = 512
_NO_STOPS = (
    "a simulated pair cannot stop or start walking on request yet; both legs stand for the "
    "configured standing time, then walk"
)


@dataclass(frozen=True)
class UnitSpec:
    """One unit of the pair: its serial number, sample clock, link faults and sensors."""

    serial: int
    clock: CrystalClock = field(default_factory=CrystalClock)
    faults: FaultConfig | None = None  # None: a clean link
    sensors: SensorConfig | None = None  # None: the default sensors, seeded per side

    def __post_init__(self) -> None:
        if not 0 <= self.serial < 2**32:
            raise ValueError(f"serial number must fit in 32 bits, got {self.serial}")


DEFAULT_LEFT = UnitSpec(serial=1001, clock=CrystalClock(offset_s=0.2537, ppm=37.0))
DEFAULT_RIGHT = UnitSpec(serial=1002, clock=CrystalClock(offset_s=0.0412, ppm=-22.0))


@dataclass(frozen=True)
class BilateralConfig:
    """The pair's settings (module doc); ``ValueError`` if one is bad."""

    cadence_steps_min: float = 110.0
    stride_cv: float = 0.02
    pattern: str = "normal"  # both legs' base pattern (PATTERNS)
    standing_s: float = 5.0  # both stand still this long (common time) before walking
    seed: int = 0
    speed: float = 1.0  # 1 = real time; math.inf = as fast as each client reads
    asymmetry: str = "none"  # ASYMMETRIES
    affected: str = "L"  # the affected leg of an asymmetric pattern
    step_ratio: float | None = None  # affected / unaffected step time (None: the asymmetry's)
    affected_stance_fraction: float | None = None
    unaffected_stance_fraction: float | None = None
    affected_knee_scale: float | None = None  # swing knee flexion, x normal
    left: UnitSpec = DEFAULT_LEFT
    right: UnitSpec = DEFAULT_RIGHT

    def __post_init__(self) -> None:
        if self.asymmetry not in ASYMMETRIES:
            raise ValueError(f"unknown asymmetry {self.asymmetry!r}; use one of {ASYMMETRIES}")
        if self.affected not in SIDES:
            raise ValueError(f"affected side must be L or R, got {self.affected!r}")
        if not self.speed > 0:
            raise ValueError(
                f"speed must be > 0 (math.inf = as fast as possible), got {self.speed}"
            )
        if not 0.0 <= self.standing_s < math.inf:
            raise ValueError(
                f"standing time must be finite for a pair (>= 0 s), got {self.standing_s}"
            )
        if not 0.5 <= self.step_time_ratio <= 2.0:
            raise ValueError(f"step ratio {self.step_time_ratio} is outside 0.5..2")
        for side in SIDES:
            spec = self.unit_spec(side)
            if spec.clock.offset_s > self.standing_s:
                raise ValueError(
                    f"the {side} unit's clock offset {spec.clock.offset_s} s is after walking "
                    f"starts ({self.standing_s} s): a unit must start while the subject stands (a "
                    "longer standing time or a smaller offset)"
                )
            self.gait_config(side)  # the stance and knee ranges, with GaitConfig's messages
        if self.left.serial == self.right.serial:
            raise ValueError("the two units need different serial numbers")
        for side in SIDES:
            other = "R" if side == "L" else "L"
            ds = self.stance_fraction(side) - self.step_share(other)
            if ds < MIN_DOUBLE_SUPPORT:
                raise ValueError(
                    f"the {side} stance ({self.stance_fraction(side):.2f} of the stride) must "
                    f"outlast the {other} step ({self.step_share(other):.2f}) by "
                    f"{MIN_DOUBLE_SUPPORT:.2f}: lengthen it or change the step ratio"
                )

    # ---- what each leg gets -----------------------------------------------------------------
    @property
    def step_time_ratio(self) -> float:
        """affected / unaffected step time (1 when symmetric)."""
        if self.step_ratio is not None:
            return self.step_ratio
        return HEMIPARETIC[0] if self.asymmetry == "hemiparetic" else 1.0

    def step_share(self, side: str) -> float:
        """The side's step time as a fraction of the stride (L + R = 1)."""
        r = self.step_time_ratio
        affected_share = r / (1.0 + r)
        return affected_share if side == self.affected else 1.0 - affected_share

    def stance_fraction(self, side: str) -> float:
        base = PATTERNS[self.pattern][0]
        hemi = self.asymmetry == "hemiparetic"
        if side == self.affected:
            v = self.affected_stance_fraction
            return v if v is not None else (HEMIPARETIC[1] if hemi else base)
        v = self.unaffected_stance_fraction
        return v if v is not None else (HEMIPARETIC[2] if hemi else base)

    def knee_scale(self, side: str) -> float:
        base = PATTERNS[self.pattern][1]
        if side != self.affected:
            return base
        if self.affected_knee_scale is not None:
            return self.affected_knee_scale
        return HEMIPARETIC[3] if self.asymmetry == "hemiparetic" else base

    def unit_spec(self, side: str) -> UnitSpec:
        return self.left if side == "L" else self.right

    def gait_config(self, side: str) -> GaitConfig:
        return GaitConfig(
            cadence_steps_min=self.cadence_steps_min,
            stride_cv=self.stride_cv,
            seed=self.seed,
            pattern=self.pattern,
            stance_fraction=self.stance_fraction(side),
            knee_swing_scale=self.knee_scale(side),
            standing_s=self.standing_s,
        )

    def sensor_config(self, side: str) -> SensorConfig:
        spec = self.unit_spec(side)
        if spec.sensors is not None:
            return spec.sensors
        return SensorConfig(seed=side_seed(self.seed, side, 2))

    def fault_config(self, side: str) -> FaultConfig:
        spec = self.unit_spec(side)
        return (
            spec.faults
            if spec.faults is not None
            else FaultConfig(seed=side_seed(self.seed, side, 4))
        )


def side_seed(seed: int, side: str, stream: int) -> int:
    """A seed of its own for one side's sensors (stream 2) or faults (stream 4)."""
    ss = np.random.SeedSequence(seed, spawn_key=(17, SIDES.index(side), stream))
    return int(ss.generate_state(1)[0])


class BilateralWalk:
    """The one walking model: both legs' heel strikes and toe offs in common seconds.

    Strides are drawn lazily, ``_STRIDE_CHUNK`` at a time and always in the same order, so the
    events never depend on which leg asked first or how far.
    """

    def __init__(self, config: BilateralConfig) -> None:
        self.config = config
        self._rng = np.random.default_rng(np.random.SeedSequence(config.seed, spawn_key=(1,)))
        self._d = np.empty(0)

    @property
    def n_strides(self) -> int:
        return len(self._d)

    def ensure_strides(self, n: int) -> None:
        cfg = self.config
        stride_s = 120.0 / cfg.cadence_steps_min
        while len(self._d) < n:  # the same draws as GaitModel._extend_schedule
            z = self._rng.standard_normal(_STRIDE_CHUNK)
            d = stride_s * np.clip(1.0 + cfg.stride_cv * z, 0.5, 1.5)
            self._d = np.concatenate([self._d, d])

    def schedule(self, side: str, n: int) -> tuple[float, float, np.ndarray, np.ndarray]:
        """(walk start, first toe off, heel strikes, toe offs after each) of ``side`` from the
        first ``n`` strides drawn, in common seconds (the knots of GaitModel._schedule)."""
        self.ensure_strides(max(n, 3))
        d = self._d[: max(n, 3)]
        cfg = self.config
        lead_ramp = (TOE_OFF_PHASE - START_PHASE) / TOE_OFF_PHASE  # mid-stance to toe off
        s = cfg.stance_fraction(LEADING)
        t_walk = cfg.standing_s
        first_to = t_walk + d[0] * s * lead_ramp
        hs = first_to + d[0] * (1.0 - s) + np.concatenate([[0.0], np.cumsum(d[1:])])
        if side == LEADING:
            to = hs + s * np.concatenate([d[1:], [d[-1]]])
            return t_walk, float(first_to), hs, to
        # the trailing leg: its heel strike at its step share of each leading stride
        phi = cfg.step_share(side)
        s = cfg.stance_fraction(side)
        g = hs[:-1] + phi * d[1:]
        e = np.concatenate([np.diff(g), [d[-1]]])  # its own stride durations
        to = g + s * e
        e_first = (1.0 - phi) * d[0] + phi * d[1]  # the stride before its first heel strike
        first_to = g[0] - (1.0 - s) * e_first
        t_walk = first_to - e_first * s * lead_ramp
        return float(t_walk), float(first_to), g, to

    def events_s(self, side: str, until_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(heel strikes, toe offs) of ``side`` in common seconds, up to ``until_s``."""
        n = max(self.n_strides, _STRIDE_CHUNK)
        while True:
            _, first_to, hs, to = self.schedule(side, n)
            if hs[-1] > until_s:
                break
            n += _STRIDE_CHUNK
        to_all = np.concatenate([[first_to], to])
        return hs[hs <= until_s], to_all[to_all <= until_s]


class LegGaitModel(GaitModel):
    """One leg's motion in its unit's device time: the single-unit gait model with its heel
    strikes and toe offs taken from the shared walk and mapped through the unit's clock."""

    def __init__(
        self, config: GaitConfig, walk: BilateralWalk, side: str, clock: CrystalClock
    ) -> None:
        self.shared = walk  # not .walk: that is GaitModel's method
        self.side = side
        self.crystal_clock = clock
        self._n_strides = 0
        super().__init__(config)
        t_walk, _, _, _ = walk.schedule(side, 3)
        self._t_walk_s = float(self.to_device_s(t_walk))

    def to_device_s(self, common_s: np.ndarray | float) -> np.ndarray:
        return np.asarray(
            (np.asarray(common_s) - self.crystal_clock.offset_s) * self.crystal_clock.rate
        )

    def _extend_schedule(self) -> None:
        self._n_strides += _STRIDE_CHUNK
        self.shared.ensure_strides(self._n_strides)

    def _schedule(self) -> tuple[float, np.ndarray, np.ndarray]:
        _, first_to, hs, to = self.shared.schedule(self.side, self._n_strides)
        return float(self.to_device_s(first_to)), self.to_device_s(hs), self.to_device_s(to)

    def stand(self, after_t_s: float) -> float:
        raise NotImplementedError(_NO_STOPS)

    def walk(self, after_t_s: float) -> None:
        raise NotImplementedError(_NO_STOPS)


@dataclass(frozen=True)
class SideTruth:
    """One leg's true events: common seconds, and the first sample at or after each in that
    unit's own clock."""

    side: str
    serial: int
    clock: CrystalClock
    heel_strike_s: np.ndarray
    toe_off_s: np.ndarray
    heel_strike_idx: np.ndarray
    toe_off_idx: np.ndarray


@dataclass(frozen=True)
class BilateralTruth:
    """What really happened on both legs over common time [start_s, stop_s)."""

    start_s: float
    stop_s: float
    left: SideTruth
    right: SideTruth
    gait: BilateralGait  # dsp.bilateral measures of these events (step, support, symmetry)
    asymmetry: str
    affected: str
    step_time_ratio: float  # configured affected / unaffected step time

    def side(self, side: str) -> SideTruth:
        if side not in SIDES:
            raise ValueError(f"side must be L or R, got {side!r}")
        return self.left if side == "L" else self.right


class BilateralSim:
    """Two simulated units (``left``, ``right``) walking one walk, in process.

    Each unit is an ordinary :class:`SimulatedUnit` (byte interface, faults, ledger, per-unit
    ``truth``) whose samples follow its own clock; both share ``epoch``: the ``clock()``
    reading at common time 0 (now, by default).
    """

    def __init__(
        self,
        config: BilateralConfig | None = None,
        *,
        clock: Callable[[], float] = time.monotonic,
        epoch: float | None = None,
        pipeline_config: PipelineConfig | None = None,
        afap_block: int = 100,
    ) -> None:
        self.config = config or BilateralConfig()
        self.walk = BilateralWalk(self.config)
        given = epoch
        epoch = clock() if given is None else given
        units = []
        for side in SIDES:
            spec = self.config.unit_spec(side)
            model = LegGaitModel(self.config.gait_config(side), self.walk, side, spec.clock)
            units.append(
                SimulatedUnit(
                    sensors=self.config.sensor_config(side),
                    faults=self.config.fault_config(side),
                    speed=self.config.speed,
                    clock=clock,
                    pipeline_config=pipeline_config,
                    serial=spec.serial,
                    side=side,
                    afap_block=afap_block,
                    gait_model=model,
                    crystal_clock=spec.clock,
                    epoch=epoch,
                )
            )
        if given is None:
            # common time 0 is now, once both are built: the first unit of a fresh process
            # takes seconds to build (imports), which at 4x ate the standing time
            epoch = clock()
            for u in units:
                u._t0 = epoch
        self.epoch = epoch
        self.left, self.right = units

    def unit(self, side: str) -> SimulatedUnit:
        if side not in SIDES:
            raise ValueError(f"side must be L or R, got {side!r}")
        return self.left if side == "L" else self.right

    @property
    def units(self) -> tuple[SimulatedUnit, SimulatedUnit]:
        return self.left, self.right

    def common_time_s(self, side: str, sample_idx: np.ndarray | float) -> np.ndarray:
        """Common time at which ``side``'s unit took these samples."""
        c = self.config.unit_spec(side).clock
        fs = self.unit(side).fs_hz
        return np.asarray(c.offset_s + np.asarray(sample_idx, dtype=np.float64) / (fs * c.rate))

    def produced_until_s(self) -> float:
        """Common time up to which both units have taken their samples (0 before any)."""
        ends = [
            self.config.unit_spec(s).clock.common_time_s(self.unit(s).samples_produced, u.fs_hz)
            for s, u in zip(SIDES, self.units, strict=True)
        ]
        return max(0.0, min(ends))

    def truth(self, start_s: float = 0.0, stop_s: float | None = None) -> BilateralTruth:
        """Both legs' true events in common time [start_s, stop_s) (default: up to where both
        units have produced samples) and the bilateral measures from them."""
        stop = self.produced_until_s() if stop_s is None else stop_s
        sides = []
        for side in SIDES:
            unit = self.unit(side)
            model = unit.gait
            assert isinstance(model, LegGaitModel)
            hs, to = self.walk.events_s(side, stop)
            hs, to = hs[(hs >= start_s) & (hs < stop)], to[(to >= start_s) & (to < stop)]
            fs = unit.fs_hz

            def idx(t: np.ndarray, m: LegGaitModel = model, fs: float = fs) -> np.ndarray:
                # the same rounding as GaitModel.events, on the same device times
                return np.ceil(m.to_device_s(t) * fs - 1e-9).astype(np.int64)

            spec = self.config.unit_spec(side)
            sides.append(SideTruth(side, spec.serial, spec.clock, hs, to, idx(hs), idx(to)))
        left, right = sides
        gait = bilateral_gait(left.heel_strike_s, left.toe_off_s, right.heel_strike_s,
                              right.toe_off_s)  # fmt: skip
        cfg = self.config
        return BilateralTruth(
            start_s=float(start_s),
            stop_s=float(stop),
            left=left,
            right=right,
            gait=gait,
            asymmetry=cfg.asymmetry,
            affected=cfg.affected,
            step_time_ratio=cfg.step_time_ratio,
        )

    def close(self) -> None:
        for u in self.units:
            u.close()


class BilateralPty:
    """Both units of a :class:`BilateralSim` on two pseudo-terminals at once (two
    :class:`PtySimulator` threads), until ``stop()``. Also a context manager.

    ``link_paths`` (left, right): stable symlinks; by default ``ttyGAIT-L`` and ``ttyGAIT-R`` in
    a new ``<tmp>/gaitmon-bisim-XXXX`` directory.
    """

    def __init__(
        self,
        sim: BilateralSim,
        link_paths: tuple[str | os.PathLike[str], str | os.PathLike[str]] | None = None,
    ) -> None:
        self.sim = sim
        self._tmpdir: str | None = None
        if link_paths is None:
            self._tmpdir = tempfile.mkdtemp(prefix="gaitmon-bisim-")
            link_paths = (Path(self._tmpdir) / "ttyGAIT-L", Path(self._tmpdir) / "ttyGAIT-R")
        if Path(link_paths[0]) == Path(link_paths[1]):
            raise ValueError("the two units need two different link paths")
        self.left = PtySimulator(sim.left, link_paths[0])
        try:
            self.right = PtySimulator(sim.right, link_paths[1])
        except OSError:
            self.left.stop()
            raise

    @property
    def link_paths(self) -> tuple[Path, Path]:
        return self.left.link_path, self.right.link_path

    def pty(self, side: str) -> PtySimulator:
        if side not in SIDES:
            raise ValueError(f"side must be L or R, got {side!r}")
        return self.left if side == "L" else self.right

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop both threads, remove both links (and the directory made for them)."""
        try:
            self.left.stop(timeout_s)
        finally:
            self.right.stop(timeout_s)
            if self._tmpdir is not None:
                shutil.rmtree(self._tmpdir, ignore_errors=True)
                self._tmpdir = None

    def __enter__(self) -> BilateralPty:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()


def serve_pair_on_ptys(
    config: BilateralConfig | None = None,
    link_paths: tuple[str | os.PathLike[str], str | os.PathLike[str]] | None = None,
) -> BilateralPty:
    """Build the pair and serve it on two pseudo-terminals (``.sim``, ``.link_paths``).

    ``OSError`` when a pseudo-terminal or link cannot be made; the units are closed then.
    """
    sim = BilateralSim(config)
    try:
        return BilateralPty(sim, link_paths)
    except (OSError, ValueError):
        sim.close()
        raise
