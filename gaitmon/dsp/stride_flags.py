"""The stride-length result (:class:`StrideMeasures`) and its per-stride quality flags.

Part of the stride-length method: the method is the module doc of
:mod:`gaitmon.dsp.stride_length` (its steps, which "module doc, step N" below refers to).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# StrideMeasures.flag bits
FLAG_NO_FOOT_FLAT = 1  # NaN: a foot-flat was not found
FLAG_PAUSE = 2  # NaN: the foot-flats are more than MAX_STRIDE_S apart
FLAG_OUT_OF_PLANE = 4  # a turn or roll: the planar model does not close (a value, not trusted)
FLAG_NEAR_STILL = 8  # a foot-flat is the stillest sample of a stance that never rests
FLAG_FIRST_STEP = 16  # a first step from standing (first_steps=True), not a heel-strike stride
FLAG_REASONS: dict[int, str] = {
    FLAG_NO_FOOT_FLAT: "no foot-flat",
    FLAG_PAUSE: "pause",
    FLAG_OUT_OF_PLANE: "turn or roll (out of plane)",
    FLAG_NEAR_STILL: "foot never still",
    FLAG_FIRST_STEP: "first step from standing",
}
FLAG_UNTRUSTED = FLAG_NO_FOOT_FLAT | FLAG_PAUSE | FLAG_OUT_OF_PLANE


@dataclass(frozen=True)
class StrideMeasures:
    """One entry per stride (heel strike j to j + 1); NaN where it cannot be computed."""

    heel_strike_idx: np.ndarray  # (K,) the stride's opening heel strike
    stride_length_m: np.ndarray  # (K,)
    foot_clearance_m: np.ndarray  # (K,)
    stride_time_s: np.ndarray  # (K,)
    foot_flat_idx: np.ndarray  # (K, 2) anchor samples (-1: not found) the stride runs between
    # (K,) int FLAG_* bits (0: a plain stride); None: not known (built by an older reader)
    flag: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.flag is None:
            object.__setattr__(self, "flag", np.zeros(len(self.heel_strike_idx), dtype=np.int64))

    @property
    def flags(self) -> np.ndarray:
        """(K,) int FLAG_* bits of each stride."""
        assert self.flag is not None
        return self.flag

    @property
    def trusted(self) -> np.ndarray:
        """(K,) bool: a value that no flag puts in doubt (no turn, foot-flats found)."""
        return np.isfinite(self.stride_length_m) & (self.flags & FLAG_UNTRUSTED == 0)

    def reasons(self, k: int) -> list[str]:
        """Why stride k is flagged (empty: a plain stride)."""
        f = int(self.flags[k])
        return [text for bit, text in FLAG_REASONS.items() if f & bit]

    @property
    def speed_m_s(self) -> np.ndarray:
        return self.stride_length_m / self.stride_time_s

    def __len__(self) -> int:
        return len(self.heel_strike_idx)
