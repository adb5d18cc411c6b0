"""The frozen values a viewer gets from the engine: the mode, and the snapshot a GUI pulls
(~30 Hz) with its recording and live gait status, the tilt filter in force and the force
sensors found faulty. Nothing here is mutable or shared.

``Mode`` lives here rather than beside ``Engine`` because a ``Snapshot`` carries it and the
engine imports this module (so no import circle).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from gaitmon.dsp.events import FALLBACK, PRIMARY
from gaitmon.io.device import LinkStats
from gaitmon.io.protocol import FrameKind


class Mode(enum.StrEnum):
    RAW = "raw"  # raw ADC frames, everything computed on the PC
    TILT = "tilt"  # the unit's own accelerometer and Kalman tilts
    JOINT = "joint"  # the unit's own joint angles, contacts and gait phase

    @property
    def frame_kind(self) -> FrameKind:
        return {Mode.RAW: FrameKind.RAW, Mode.TILT: FrameKind.TILT, Mode.JOINT: FrameKind.JOINT}[
            self
        ]


# what made the Kalman series in the unit's own modes (the file's /processed tilt_method says
# "the unit's own"; the unit runs the paper's Kalman filter on its own counts)
UNIT_ANGLE_METHOD = "the unit's own Kalman"
# Snapshot.event_source: where the gait events come from
EVENTS_FSR = PRIMARY  # the PC pipeline, from the force sensors (gaitmon.dsp.events)
EVENTS_GYRO = FALLBACK  # the PC pipeline, after a force sensor was found faulty
EVENTS_UNIT = "unit"  # the unit's own foot contacts (joint mode); "" in tilt mode: no events


@dataclass(frozen=True)
class FsrFaultNotice:
    """A force sensor the PC pipeline's check flagged (gaitmon.dsp.fsr_check), for a viewer."""

    sensor: str  # heel | toe
    reason: str  # never loads | never unloads | disagrees with the foot gyro
    message: str  # "heel force sensor never loads: gait events from the foot gyro"
    t_s: float  # when it was decided (events from the gyro from then on), on series["t_s"]


@dataclass(frozen=True)
class RecordingStatus:
    active: bool = False
    path: str = ""
    started_monotonic_s: float = 0.0
    elapsed_s: float = 0.0
    rows: int = 0
    file_bytes: int = 0
    dropped_blocks: int = 0  # recorder queue overflows (never expected; never silent)
    dropped_frames: int = 0  # their rows: received, shown, not saved (gaps in the file)
    error: str = ""  # why the last recording stopped on its own ("" if it did not)


@dataclass(frozen=True)
class GaitStatus:
    """The live gait panel: latest strides and the cycle overlay."""

    n_strides: int = 0
    last_stride_time_s: float = float("nan")
    last_stance_pct: float = float("nan")
    cadence_derived_steps_per_min: float = float("nan")
    # mean over the last included strides that have one (foot IMU; NaN until one is known)
    speed_mean_m_s: float = float("nan")
    stride_length_mean_m: float = float("nan")
    cycles_deg: np.ndarray = field(default_factory=lambda: np.empty((0, 101, 3)))  # last N strides
    current_pct: np.ndarray = field(default_factory=lambda: np.empty(0))  # current stride so far
    current_deg: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))
    # every stride since the engine started (counted or not): the engine index of its opening
    # heel strike, ascending (a viewer counts a recording's strides from its row 0 on)
    stride_start_idx: np.ndarray = field(default_factory=lambda: np.empty(0, np.int64))
    last_stride_end_t_s: float = float("nan")  # when the last stride ended, on series["t_s"]


@dataclass(frozen=True)
class Snapshot:
    """What a viewer needs, copied out under a short lock. Angles in degrees."""

    series: dict[str, np.ndarray]
    heel_strike_t_s: np.ndarray
    toe_off_t_s: np.ndarray
    markers: tuple[tuple[float, str], ...]
    samples_total: int
    frame_rate_hz: float
    last_data_age_s: float
    link: LinkStats | None
    link_state: str
    link_reason: str
    seconds_to_reconnect: float | None
    recording: RecordingStatus
    gait: GaitStatus
    mode: Mode
    calibrated: bool
    # the last block the engine could not read or process ("" if none) and how many; such a
    # block is not shown, and a recording gets a gap in its place
    engine_error: str = ""
    engine_errors: int = 0
    # what made the Kalman series: PipelineConfig.tilt_method_label, or UNIT_ANGLE_METHOD
    angle_method: str = ""
    # where the angles' zero comes from (gaitmon.dsp.calibration.zero_source)
    zero_source: str = ""
    # force sensors flagged since the engine started (one per sensor and reason), oldest first
    fsr_faults: tuple[FsrFaultNotice, ...] = ()
    event_source: str = ""  # EVENTS_FSR | EVENTS_GYRO | EVENTS_UNIT | "" (tilt mode)
    # wall time without a frame while the unit streams, once it reaches STALL_AFTER_S (1 s);
    # 0.0 while frames arrive (gaitmon.engine.stream.stalled_s): what "no data for N s" shows
    stalled_s: float = 0.0
