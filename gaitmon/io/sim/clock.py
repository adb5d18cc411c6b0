"""A simulated unit's sample clock: when, on a common time line, its sample n is taken.

Each real unit counts samples on its own crystal, started when it was switched on. On one
common time line (seconds; 0 = when the simulation starts), unit k's sample n is taken at

    t = offset_s + n / (fs_hz * (1 + ppm * 1e-6))

``offset_s`` >= 0 is the common time of its sample 0 (when it was started); ``ppm`` is its
crystal's error: a crystal that runs fast (ppm > 0) takes more samples per common second, so its
counter gains on a perfect one (37 ppm: 0.133 s, 13 samples, an hour). The unit's own *device
time* n / fs_hz is what its gait model, sensors and faults run on; it is
``(t - offset_s) * (1 + ppm * 1e-6)``.

The identity clock (0 s, 0 ppm) is a single unit's: device time = common time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

MAX_PPM = 10_000.0  # 1 %: far beyond any crystal, but lets tests exaggerate the drift


@dataclass(frozen=True)
class CrystalClock:
    """How a simulated unit's crystal *produces* its sample times: its start offset (s) and its
    error (ppm); ``ValueError`` if bad. (Not a sample clock: that is the host's estimate of a
    unit's counter, ``gaitmon.dsp.sample_clock``.)"""

    offset_s: float = 0.0
    ppm: float = 0.0

    def __post_init__(self) -> None:
        if not (0.0 <= self.offset_s < math.inf):
            raise ValueError(f"clock offset must be >= 0 s, got {self.offset_s}")
        if not abs(self.ppm) <= MAX_PPM:
            raise ValueError(f"clock drift {self.ppm} ppm is outside +-{MAX_PPM:g} ppm")

    @property
    def rate(self) -> float:
        """Device seconds per common second (1 + ppm * 1e-6)."""
        return 1.0 + self.ppm * 1e-6

    def common_time_s(self, sample_idx: float, fs_hz: float) -> float:
        """Common time at which sample ``sample_idx`` is taken."""
        return self.offset_s + sample_idx / (fs_hz * self.rate)

    def device_time_s(self, common_s: float) -> float:
        """This unit's device time (sample index / fs) at common time ``common_s``."""
        return (common_s - self.offset_s) * self.rate

    def samples_due(self, common_s: float, fs_hz: float) -> int:
        """How many samples have been taken by common time ``common_s`` (a sample counts once
        its tick has passed, as for a single unit: floor(device time * fs)); <= 0 before."""
        return math.floor((common_s - self.offset_s) * fs_hz * self.rate)
