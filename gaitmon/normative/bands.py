"""The normative band itself: mean and SD per joint over the 101-point gait cycle, and the one
error every reader raises. The readers (CSV in the package, GCD in ``gcd``) build it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitmon.dsp.channel_table import JOINTS

N_POINTS = 101  # 0, 1, ..., 100 % of the gait cycle
JOINT_KEYS: tuple[str, ...] = JOINTS  # hip, knee, ankle: column order of every (101, 3) array


class NormativeError(ValueError):
    """A normative file that cannot be used; the message is one line naming the problem."""


@dataclass(frozen=True, eq=False)
class NormativeBands:
    """Mean and SD per joint over the cycle; NaN columns for joints the file does not give."""

    cycle_pct: np.ndarray  # (101,) 0..100
    mean_deg: np.ndarray  # (101, 3) hip flexion, knee flexion, ankle dorsiflexion (clinical signs)
    sd_deg: np.ndarray  # (101, 3)
    metadata: Mapping[str, str] = field(default_factory=dict)  # from the '# key: value' lines
    path: Path | None = None

    def __post_init__(self) -> None:
        for name in ("cycle_pct", "mean_deg", "sd_deg"):
            a = np.array(getattr(self, name), dtype=np.float64)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        if self.cycle_pct.shape != (N_POINTS,):
            raise NormativeError(f"cycle_pct must have {N_POINTS} values")
        for name in ("mean_deg", "sd_deg"):
            if getattr(self, name).shape != (N_POINTS, len(JOINT_KEYS)):
                raise NormativeError(f"{name} must have shape ({N_POINTS}, {len(JOINT_KEYS)})")
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def joints(self) -> tuple[str, ...]:
        """The joints this file gives (in ``JOINT_KEYS`` order)."""
        return tuple(
            j for k, j in enumerate(JOINT_KEYS) if np.all(np.isfinite(self.mean_deg[:, k]))
        )

    def has(self, joint: str) -> bool:
        return joint in self.joints

    @property
    def source(self) -> str:
        return self.metadata.get("source", "")

    @property
    def licence(self) -> str:
        return self.metadata.get("licence", "")

    @property
    def label(self) -> str:
        """A short caption for plots and the report: the name (or file name) and source."""
        name = self.metadata.get("name") or (self.path.name if self.path else "normative band")
        return name
