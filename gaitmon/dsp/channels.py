"""The unit's 14 ADC channels, described as data, and the count <-> physical-unit conversion.

Mounting convention (every IMU board, both legs): with the subject standing upright the board's
x axis points up along the segment, z points forward (anterior) and y points to the subject's
right. Then the accelerometer tilt atan2(a_z, a_x) is ~0 when standing (far from the +-pi jump of
atan2), grows when the segment rotates counter-clockwise as seen from the subject's right side,
and its rate is +gyro (the gyro measures the rate about y).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

STANDARD_GRAVITY_MS2 = 9.80665
SEGMENTS: tuple[str, ...] = ("body", "thigh", "shank", "foot")
JOINTS: tuple[str, ...] = ("hip", "knee", "ankle")
N_CHANNELS = 14


@dataclass(frozen=True)
class ChannelSpec:
    """One ADC channel: counts -> physical = (counts * vref_v / 2**adc_bits - zero_v) / sens."""

    index: int
    name: str
    segment: str  # body | thigh | shank | foot | heel | toe
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
_GYRO_SENS_V_PER_RAD_S = 0.002 * 180.0 / np.pi
_GYRO_ZERO_V = 1.35
_FSR_SENS_V_PER_COUNT = _VREF_V / (1 << _ADC_BITS)


def _build_table() -> tuple[ChannelSpec, ...]:
    specs: list[ChannelSpec] = []
    for seg in SEGMENTS:
        for kind in ("acc_x", "acc_z", "gyro"):
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
    for seg in ("heel", "toe"):
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


def _index(kind: str) -> np.ndarray:
    return np.array([c.index for c in CHANNELS if c.kind == kind], dtype=np.intp)


ACC_X_IDX = _index("acc_x")  # (4,) body, thigh, shank, foot
ACC_Z_IDX = _index("acc_z")
GYRO_IDX = _index("gyro")
FSR_IDX = _index("fsr")  # (2,) heel, toe


@dataclass(frozen=True)
class ChannelTable:
    """Vectorised conversion for a full channel table (the device's, or one read from a file)."""

    channels: tuple[ChannelSpec, ...] = CHANNELS

    @cached_property
    def zero_counts(self) -> np.ndarray:
        return np.array([c.zero_counts for c in self.channels])

    @cached_property
    def units_per_count(self) -> np.ndarray:
        return np.array([c.units_per_count for c in self.channels])

    @cached_property
    def full_scale_counts(self) -> np.ndarray:
        return np.array([c.full_scale_counts for c in self.channels])

    def to_physical(self, counts: np.ndarray, channels: np.ndarray | None = None) -> np.ndarray:
        """(N, 14) counts -> (N, 14) float64 in each channel's unit (m/s^2, rad/s, count); with
        ``channels`` (indices), only those columns (the same numbers)."""
        counts = np.asarray(counts)
        if channels is None:
            return (counts.astype(np.float64) - self.zero_counts) * self.units_per_count
        x = counts[:, channels].astype(np.float64)
        x -= self.zero_counts[channels]
        x *= self.units_per_count[channels]
        return x

    def to_counts(self, physical: np.ndarray) -> np.ndarray:
        """(N, 14) physical -> (N, 14) uint16 counts, rounded and saturated to the ADC range."""
        physical = np.asarray(physical, dtype=np.float64)
        c = np.rint(physical / self.units_per_count + self.zero_counts)
        return np.clip(c, 0, self.full_scale_counts).astype(np.uint16)


DEFAULT_TABLE = ChannelTable()
