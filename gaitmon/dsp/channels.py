"""The numpy side of the unit's channel table: index arrays by channel kind and the vectorised
count <-> physical-unit conversion (``ChannelTable``).

The table itself (segments, joints, channels, counts, the mounting convention) is data in
``gaitmon.dsp.channel_table``, numpy-free; its names are re-exported here for the code that
converts.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from gaitmon.dsp.channel_table import (
    CHANNEL_NAMES,
    CHANNELS,
    JOINTS,
    N_CHANNELS,
    SEGMENTS,
    STANDARD_GRAVITY_MS2,
    ChannelSpec,
)

__all__ = [
    "ACC_X_IDX",
    "ACC_Z_IDX",
    "CHANNELS",
    "CHANNEL_NAMES",
    "DEFAULT_TABLE",
    "FSR_IDX",
    "GYRO_IDX",
    "JOINTS",
    "N_CHANNELS",
    "SEGMENTS",
    "STANDARD_GRAVITY_MS2",
    "ChannelSpec",
    "ChannelTable",
]


def _index(kind: str) -> np.ndarray:
    return np.array([c.index for c in CHANNELS if c.kind == kind], dtype=np.intp)


ACC_X_IDX = _index("acc_x")  # (N_SEGMENTS,) in SEGMENTS order
ACC_Z_IDX = _index("acc_z")
GYRO_IDX = _index("gyro")
FSR_IDX = _index("fsr")  # (N_FSR,) heel, toe


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
        """(N, N_CHANNELS) counts -> float64 in each channel's unit (m/s^2, rad/s, count); with
        ``channels`` (indices), only those columns (the same numbers)."""
        counts = np.asarray(counts)
        if channels is None:
            return (counts.astype(np.float64) - self.zero_counts) * self.units_per_count
        x = counts[:, channels].astype(np.float64)
        x -= self.zero_counts[channels]
        x *= self.units_per_count[channels]
        return x

    def to_counts(self, physical: np.ndarray) -> np.ndarray:
        """(N, N_CHANNELS) physical -> uint16 counts, rounded and saturated to the ADC range."""
        physical = np.asarray(physical, dtype=np.float64)
        c = np.rint(physical / self.units_per_count + self.zero_counts)
        return np.clip(c, 0, self.full_scale_counts).astype(np.uint16)


DEFAULT_TABLE = ChannelTable()
