"""``complementary``: paper 003's complementary filter at its 3 Hz cut-off
(gaitmon.dsp.complementary)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from gaitmon.dsp.methods.base import ParamSpec, TiltFilter, TiltMethod


@dataclass(frozen=True)
class Complementary(TiltMethod):
    cutoff_hz: float = 3.0

    name: ClassVar[str] = "complementary"
    label: ClassVar[str] = "complementary filter (paper 003)"
    lab_name: ClassVar[str | None] = "complementary"
    param_specs: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("cutoff_hz", "cut-off (Hz)", 3.0, 0.01, 45.0, 3),
    )

    def lab_filter(self, dt_s: float) -> TiltFilter:
        from gaitmon.dsp.complementary import ComplementaryFilter

        return ComplementaryFilter(dt_s, cutoff_hz=self.cutoff_hz)
