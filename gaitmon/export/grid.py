"""The common frame grid of a session of both legs, and each leg's rows resampled onto it
(the C3D and BIDS exports of both legs share it).

Frame k of the grid is at common time k / fs (the units' sample rate), from 0 (the first
sample of the unit that started first) to the last sample of the unit that stopped last. Each
unit's row r is at ``common_s(side, t_s[r])`` (its clock fit, ``Bilateral.common_s``), a
fraction of a sample off the grid and drifting by the unit's ppm, so a frame's value is the
linear interpolation between the two rows of that unit around it. A frame with no row of the
unit on each side within 1.5 samples (before it started, after it stopped, inside a gap of
lost frames) is missing (NaN): nothing is made up across a gap.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.export.writers.errors import ExportError

if TYPE_CHECKING:
    from gaitmon.export.writers.source import Source
    from gaitmon.finish.bilateral import Bilateral

MAX_ROW_SPACING = 1.5  # samples between two rows that a frame may be interpolated across


@dataclass(frozen=True)
class LegOnGrid:
    """One unit's rows on the common time line (``common_s``: each row's time, increasing)."""

    side: str
    common_s: np.ndarray
    fs_hz: float

    def rows_for(self, f0: int, f1: int) -> tuple[int, int]:
        """The rows [r0, r1) that frames [f0, f1) are interpolated from."""
        c = self.common_s
        r0 = max(0, int(np.searchsorted(c, f0 / self.fs_hz, "right")) - 1)
        r1 = min(len(c), int(np.searchsorted(c, (f1 - 1) / self.fs_hz, "right")) + 1)
        return r0, max(r0, r1)

    def resample(self, rows: np.ndarray, r0: int, f0: int, f1: int) -> np.ndarray:
        """(f1 - f0, k) values on frames [f0, f1) from ``rows`` (rows r0.. of the unit)."""
        rows = np.asarray(rows, np.float64).reshape(len(rows), -1)
        c = self.common_s[r0 : r0 + len(rows)]
        g = np.arange(f0, f1) / self.fs_hz
        out = np.full((f1 - f0, rows.shape[1]), np.nan)
        if len(c) < 2:
            return out
        i = np.searchsorted(c, g, "right") - 1
        ok = (i >= 0) & (i < len(c) - 1)
        i = np.clip(i, 0, len(c) - 2)
        span = c[i + 1] - c[i]
        ok &= span <= MAX_ROW_SPACING / self.fs_hz
        w = ((g - c[i]) / np.where(ok, span, 1.0))[:, None]
        v = rows[i] * (1.0 - w) + rows[i + 1] * w
        out[ok] = v[ok]
        return out


@dataclass(frozen=True)
class CommonGrid:
    fs_hz: float
    n_frames: int
    legs: dict[str, LegOnGrid]

    def frame_of(self, common_s: np.ndarray | float) -> np.ndarray:
        """The nearest frame of each time, within the grid: a time in the last half frame
        (an event on a leg's last row) is on the last frame, not one past it."""
        k = np.rint(np.asarray(common_s, np.float64) * self.fs_hz).astype(np.int64)
        return np.clip(k, 0, max(self.n_frames - 1, 0))


def common_grid(name: str, fs_hz: dict[str, float], common_s: dict[str, np.ndarray]) -> CommonGrid:
    """The grid of a session (``name`` for messages) from each unit's rate and rows' times."""
    rates = set(fs_hz.values())
    if len(rates) != 1:
        raise ExportError(f"{name}: the units sample at different rates ({rates} Hz); "
                          "export each leg with --side")  # fmt: skip
    fs = rates.pop()
    legs = {}
    for side, c in common_s.items():
        c = np.asarray(c, np.float64)
        if not np.all(np.isfinite(c)) or np.any(np.diff(c) <= 0):
            raise ExportError(f"{name} is damaged: the {side} unit's sample times are not "
                              "increasing on the common time line")  # fmt: skip
        legs[side] = LegOnGrid(side, c, fs)
    end = max((float(c[-1]) for c in common_s.values() if len(c)), default=-1.0)
    n_frames = int(np.floor(end * fs + 1e-9)) + 1 if end >= 0 else 0
    return CommonGrid(fs, n_frames, legs)


def grid_of(b: Bilateral, srcs: dict[str, Source]) -> CommonGrid:
    """The grid of an open bilateral session, its legs read as the exporters read them."""
    common = {}
    for side, src in srcs.items():
        t = src.read("timeline/t_s").astype(np.float64) if src.n else np.zeros(0)
        common[side] = np.asarray(b.common_s(side, t), np.float64)
    return common_grid(b.path.name, {s: src.fs_hz for s, src in srcs.items()}, common)


def on_grid(leg: LegOnGrid, src: Source, f0: int, f1: int) -> Callable[[str], np.ndarray]:
    """``read(path)``: one of the unit's series on frames [f0, f1) of the grid."""
    r0, r1 = leg.rows_for(f0, f1)

    def read(path: str) -> np.ndarray:
        return leg.resample(src.read(path, r0, r1), r0, f0, f1)

    return read
