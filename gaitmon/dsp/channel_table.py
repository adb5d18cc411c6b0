"""The unit's channel table as data, the one source for its shape: IMU segments, the joints between
them, the ADC channels, and the counts everything else derives from.

The wire protocol's payload lengths (``gaitmon.io.wire``), the journal's and the session file's
row shapes, the joint angles (``gaitmon.dsp.angles``), the displays' colours and ranges, the
exports' column names and the LSL streams all read this table; adding a segment is a row here
(plus the simulator's motion for it: ``docs/protocol.md``, "A fifth segment").

Pure Python, no numpy: the protocol imports it, and ``gaitmon --help`` must not pay for numpy
(``docs/architecture.md``, "Lazy at the edges"). The numpy side (index arrays, the vectorised
counts <-> physical conversion) is ``gaitmon.dsp.channels``.

Mounting convention (every IMU board, both legs): with the subject standing upright the board's
x axis points up along the segment, z points forward (anterior) and y points to the subject's
right. Then the accelerometer tilt atan2(a_z, a_x) is ~0 when standing (far from the +-pi jump of
atan2), grows when the segment rotates counter-clockwise as seen from the subject's right side,
and its rate is +gyro (the gyro measures the rate about y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

STANDARD_GRAVITY_MS2 = 9.80665


@dataclass(frozen=True)
class Segment:
    """One body segment carrying an IMU board (accelerometer x, z and a gyro about y)."""

    name: str
    tilt_range_deg: tuple[float, float]  # the displays' y range (normal and pathological gait)
    colour_light: str  # its raw traces' colour on a light theme, then on a dark one
    colour_dark: str
    still_in_stance: bool = False  # lies still once every stance (the foot): its tilt filter
    # trusts the accelerometer then; the others take gravity live (gaitmon.dsp.motion_kalman)


@dataclass(frozen=True)
class Joint:
    """A joint angle: ``plus`` segment's tilt minus ``minus`` segment's, wrapped to (-pi, pi], so
    that its clinical sign (``motion``, e.g. flexion) is positive."""

    name: str  # hip
    motion: str  # flexion
    plus: str
    minus: str
    range_deg: tuple[float, float]  # the displays' y range

    @property
    def label(self) -> str:
        """``hip flexion``."""
        return f"{self.name} {self.motion}"

    @property
    def key(self) -> str:
        """``hip_flexion``: the exports' and the LSL streams' channel name."""
        return f"{self.name}_{self.motion}"


# Body at the sacrum/trunk, thigh and shank boards mid-segment, the foot board on the dorsum.
SEGMENT_TABLE: tuple[Segment, ...] = (
    Segment("body", (-25, 25), "#7b3fb5", "#c792ea"),
    Segment("thigh", (-45, 50), "#e07b00", "#ffb74d"),
    Segment("shank", (-75, 50), "#00838f", "#4dd0e1"),
    Segment("foot", (-80, 60), "#6d4c41", "#a1887f", still_in_stance=True),
)
# Clinical signs: hip flexion +, knee flexion +, ankle dorsiflexion +.
JOINT_TABLE: tuple[Joint, ...] = (
    Joint("hip", "flexion", plus="thigh", minus="body", range_deg=(-25, 55)),
    Joint("knee", "flexion", plus="thigh", minus="shank", range_deg=(-10, 80)),
    Joint("ankle", "dorsiflexion", plus="foot", minus="shank", range_deg=(-35, 35)),
)
IMU_KINDS: tuple[str, ...] = ("acc_x", "acc_z", "gyro")  # each segment's channels, in order
FSR_SENSORS: tuple[str, ...] = ("heel", "toe")  # force sensors under the foot, after the IMUs

SEGMENTS: tuple[str, ...] = tuple(s.name for s in SEGMENT_TABLE)
JOINTS: tuple[str, ...] = tuple(j.name for j in JOINT_TABLE)
# (plus, minus) index into SEGMENTS per joint
JOINT_PAIRS: tuple[tuple[int, int], ...] = tuple(
    (SEGMENTS.index(j.plus), SEGMENTS.index(j.minus)) for j in JOINT_TABLE
)
N_SEGMENTS = len(SEGMENTS)
N_JOINTS = len(JOINTS)
N_FSR = len(FSR_SENSORS)


def joint_convention() -> str:
    """The sign convention in words, as a session file states it."""
    text = "; ".join(f"{j.label} + = {j.plus} - {j.minus}" for j in JOINT_TABLE)
    return text[:1].upper() + text[1:]


@dataclass(frozen=True)
class ChannelSpec:
    """One ADC channel: counts -> physical = (counts * vref_v / 2**adc_bits - zero_v) / sens."""

    index: int
    name: str
    segment: str  # a SEGMENTS name, or a force sensor's (heel | toe)
    kind: str  # acc_x | acc_z | gyro | fsr
    unit: str  # m/s^2 | rad/s | count
    adc_bits: int
    vref_v: float
    zero_v: float  # output voltage at zero physical input
    sensitivity_v_per_unit: float

    @property
    def full_scale_counts(self) -> int:
        return (1 << self.adc_bits) - 1

    @property
    def volts_per_count(self) -> float:
        return self.vref_v / (1 << self.adc_bits)

    @property
    def zero_counts(self) -> float:
        return self.zero_v / self.volts_per_count

    @property
    def units_per_count(self) -> float:
        return self.volts_per_count / self.sensitivity_v_per_unit

    def as_dict(self) -> dict[str, object]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


# Reference design: dsPIC30F4013 12-bit ADC on a 3.3 V reference; ratiometric analog accelerometer
# (300 mV/g, zero-g at 1.65 V, ~+-5.5 g span); analog gyro (2.0 mV/(deg/s), zero rate at 1.35 V,
# ~+-500 deg/s); FSR voltage dividers reported as raw counts (threshold 1000 LSB in the paper).
_ADC_BITS = 12
_VREF_V = 3.3
_ACC_SENS_V_PER_MS2 = 0.300 / STANDARD_GRAVITY_MS2
_ACC_ZERO_V = 1.65
_GYRO_SENS_V_PER_RAD_S = 0.002 * 180.0 / math.pi
_GYRO_ZERO_V = 1.35
_FSR_SENS_V_PER_COUNT = _VREF_V / (1 << _ADC_BITS)


def _build_table() -> tuple[ChannelSpec, ...]:
    specs: list[ChannelSpec] = []
    for seg in SEGMENTS:
        for kind in IMU_KINDS:
            is_acc = kind != "gyro"
            specs.append(
                ChannelSpec(
                    index=len(specs),
                    name=f"{seg}_{kind}",
                    segment=seg,
                    kind=kind,
                    unit="m/s^2" if is_acc else "rad/s",
                    adc_bits=_ADC_BITS,
                    vref_v=_VREF_V,
                    zero_v=_ACC_ZERO_V if is_acc else _GYRO_ZERO_V,
                    sensitivity_v_per_unit=(
                        _ACC_SENS_V_PER_MS2 if is_acc else _GYRO_SENS_V_PER_RAD_S
                    ),
                )
            )
    for seg in FSR_SENSORS:
        specs.append(
            ChannelSpec(
                index=len(specs),
                name=f"{seg}_fsr",
                segment=seg,
                kind="fsr",
                unit="count",
                adc_bits=_ADC_BITS,
                vref_v=_VREF_V,
                zero_v=0.0,
                sensitivity_v_per_unit=_FSR_SENS_V_PER_COUNT,
            )
        )
    return tuple(specs)


CHANNELS: tuple[ChannelSpec, ...] = _build_table()
CHANNEL_NAMES: tuple[str, ...] = tuple(c.name for c in CHANNELS)
N_CHANNELS = len(CHANNELS)  # 14 on today's unit: 4 segments x 3 + 2 force sensors
