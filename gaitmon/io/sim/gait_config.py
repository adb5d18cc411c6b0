"""What shapes the simulated leg's true motion (:class:`GaitConfig`), the gait cycle's phase
landmarks, and the containers of the truth (:class:`KinematicsBlock`, :class:`StrideTruth`).

The motion itself, and its description, is :mod:`gaitmon.io.sim.kinematics` (its module doc);
these live here so that its parts can share them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitmon.io.sim.patterns import PATTERNS

DEG = np.pi / 180.0
TOE_OFF_PHASE = 0.60  # normative toe off, fraction of the cycle
FOOT_FLAT_PHASE = 0.10  # normative end of loading response (toe FSR starts to load)
HEEL_OFF_PHASE = 0.35  # normative heel rise (heel FSR unloads)
START_PHASE = 0.25  # the standing pose is taken as mid-stance (both FSRs loaded)


@dataclass(frozen=True)
class GaitConfig:
    """Everything that shapes the true motion. ``None`` fields take the pattern's default."""

    fs_hz: float = 100.0
    cadence_steps_min: float = 110.0
    stride_cv: float = 0.02  # coefficient of variation of stride duration
    seed: int = 0
    pattern: str = "normal"
    stance_fraction: float | None = None
    knee_swing_scale: float | None = None
    standing_s: float = 5.0
    ramp_strides: float = 1.0
    height_m: float = 1.70
    stride_length_m: float | None = None  # default 0.8 * height; 0.4 .. 1.2 * height
    body_lean_rad: float = -3.0 * DEG  # pelvis leans forward while walking (tilt < 0)
    body_osc_rad: float = 1.5 * DEG
    # realism (module doc, "Realism"; docs/simulator.md): the defaults leave the motion as it was
    stride_length_cv: float = 0.0  # stride-to-stride CV of stride length
    stance_micro_rad: float = 0.0  # median amplitude of the stance foot's roll-over (toe-down)
    stance_micro_spread: float = 0.5  # SD of its log amplitude from stride to stride
    stance_pivot_m: tuple[float, float] = (0.0, 0.0)  # where the roll-over turns: (forward, up)
    # from the foot sensor's point in the foot's frame; (0, 0): about the sensor's point
    roll_sd_deg: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)  # RMS slow roll out of the plane
    swing_roll_deg: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)  # peak roll in every swing
    swing_yaw_deg: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)  # peak yaw in every swing (out, back)
    turn_every_strides: float = 0.0  # 0: straight; else a turn starts every this many strides
    turn_strides: float = 2.0  # how long a turn lasts
    turn_deg: float = 180.0  # heading change of one turn (> 0: to the left)
    first_turn_strides: float = 3.0  # strides walked (after the ramp-in) before the first turn
    turn_in_swing: bool = False  # the foot board turns only in swing (toe off .. the next
    # foot-flat) and keeps its heading through stance, as a real foot does; False: it turns
    # with the walking direction all through the stride

    def __post_init__(self) -> None:
        if self.pattern not in PATTERNS:
            raise ValueError(
                f"unknown gait pattern {self.pattern!r}; use one of {sorted(PATTERNS)}"
            )
        if not 20.0 <= self.cadence_steps_min <= 200.0:
            raise ValueError(f"cadence {self.cadence_steps_min} steps/min is outside 20..200")
        if not 0.0 <= self.stride_cv <= 0.2:
            raise ValueError(f"stride CV {self.stride_cv} is outside 0..0.2")
        if not 0.4 <= self.stance_frac <= 0.85:
            raise ValueError(f"stance fraction {self.stance_frac} is outside 0.4..0.85")
        if not 0.4 <= self.stride_len_m / self.height_m <= 1.2:
            # the joint angles do not shrink with the stride: shorter ones would walk backwards
            raise ValueError(
                f"stride length {self.stride_len_m} m is outside 0.4..1.2 x height "
                f"({0.4 * self.height_m:.2f}..{1.2 * self.height_m:.2f} m)"
            )
        if self.fs_hz <= 0 or self.standing_s < 0 or self.ramp_strides <= 0:
            raise ValueError("fs_hz and ramp_strides must be > 0 and standing_s >= 0")
        if not 0.0 <= self.stride_length_cv <= 0.2:
            raise ValueError(f"stride length CV {self.stride_length_cv} is outside 0..0.2")
        if not 0.0 <= self.stance_micro_rad <= 0.3 or self.stance_micro_spread < 0:
            raise ValueError("stance_micro_rad must be in 0..0.3 rad, stance_micro_spread >= 0")
        if len(self.stance_pivot_m) != 2 or not all(abs(x) <= 0.3 for x in self.stance_pivot_m):
            raise ValueError(f"stance_pivot_m needs (forward, up) within 0.3 m, "
                             f"got {self.stance_pivot_m}")  # fmt: skip
        for name in ("roll_sd_deg", "swing_roll_deg", "swing_yaw_deg"):
            v = getattr(self, name)
            if len(v) != 4 or not all(-30.0 <= r <= 30.0 for r in v) or min(self.roll_sd_deg) < 0:
                raise ValueError(f"{name} needs 4 values in -30..30 deg (sd >= 0), got {v}")
        if self.turn_every_strides and not (
            self.turn_every_strides > self.turn_strides > 0 and self.first_turn_strides >= 0
        ):
            raise ValueError("turn_every_strides must be 0 or longer than turn_strides > 0")

    @property
    def out_of_plane(self) -> bool:
        """Whether the boards leave the sagittal plane (turns or roll): the sensors then project
        the 3-D motion (gaitmon.io.sim.sensors)."""
        return bool(self.turn_every_strides) or any(
            self.roll_sd_deg + self.swing_roll_deg + self.swing_yaw_deg
        )

    @property
    def stance_frac(self) -> float:
        return PATTERNS[self.pattern][0] if self.stance_fraction is None else self.stance_fraction

    @property
    def knee_scale(self) -> float:
        return PATTERNS[self.pattern][1] if self.knee_swing_scale is None else self.knee_swing_scale

    @property
    def stride_s(self) -> float:
        """Mean stride duration: one stride is two steps."""
        return 120.0 / self.cadence_steps_min

    @property
    def stride_len_m(self) -> float:
        return 0.8 * self.height_m if self.stride_length_m is None else self.stride_length_m

    @property
    def thigh_m(self) -> float:
        return 0.245 * self.height_m

    @property
    def shank_m(self) -> float:
        return 0.246 * self.height_m


@dataclass(frozen=True)
class KinematicsBlock:
    """True motion for samples ``sample_idx`` (all angles in rad, tilt convention of dsp.angles)."""

    sample_idx: np.ndarray  # (N,) int64
    t_s: np.ndarray  # (N,) device time
    phase: np.ndarray  # (N,) continuous normative phase (integer part = stride count)
    phase_rate_hz: np.ndarray  # (N,) d(phase)/dt, 0 while standing
    walking: np.ndarray  # (N,) ramp-in envelope, 0 standing .. 1 walking
    joint_rad: np.ndarray  # (N, 3) hip, knee, ankle (clinical signs)
    tilt_rad: np.ndarray  # (N, 4) body, thigh, shank, foot
    rate_rad_s: np.ndarray  # (N, 4) d(tilt)/dt
    lin_acc_ms2: np.ndarray  # (N, 4, 2) sensor-point acceleration in the world frame (F, U)
    position_m: np.ndarray  # (N, 4, 2) sensor-point position (F, U); F grows with walking
    velocity_m_s: np.ndarray  # (N, 4, 2) sensor-point velocity (F, U)
    heading_rad: np.ndarray  # (N,) walking direction (turns; > 0 to the left), 0 straight
    yaw_rate_rad_s: np.ndarray  # (N,) its rate
    roll_rad: np.ndarray  # (N, 4) each board's roll about the walking direction
    roll_rate_rad_s: np.ndarray  # (N, 4) its rate
    board_yaw_rad: np.ndarray  # (N, 4) each board's yaw from the walking direction (swing)
    board_yaw_rate_rad_s: np.ndarray  # (N, 4) its rate


@dataclass(frozen=True)
class StrideTruth:
    """True strides (GaitModel.strides): one entry per heel strike that starts a stride."""

    heel_strike_idx: np.ndarray  # (K,) first sample at/after the heel strike
    stride_length_m: np.ndarray  # (K,) foot sensor's displacement, foot-flat to foot-flat
    stride_time_s: np.ndarray  # (K,) to the next heel strike
    foot_clearance_m: np.ndarray  # (K,) sensor's highest point above its foot-flat height
    # with turns: the length above is the straight line between the two foot-flats (the
    # footprints' distance); the path is the sensor's forward travel along its (curved) way
    path_length_m: np.ndarray | None = None  # (K,) forward travel; None: = stride_length_m
    turn_rad: np.ndarray | None = None  # (K,) heading change foot-flat to foot-flat

    @property
    def speed_m_s(self) -> np.ndarray:
        return self.stride_length_m / self.stride_time_s

