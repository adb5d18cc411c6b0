"""``complementary-adaptive``: paper 003's complementary filter with the FFT-chosen cut-off
(gaitmon.dsp.complementary.AdaptiveCutoff), starting from 3 Hz."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from gaitmon.dsp.methods.base import ParamSpec, TiltFilter, TiltMethod


@dataclass(frozen=True)
class ComplementaryAdaptive(TiltMethod):
    cutoff_hz: float = 3.0

    name: ClassVar[str] = "complementary-adaptive"
    label: ClassVar[str] = "complementary filter, adaptive cut-off (paper 003)"
    lab_name: ClassVar[str | None] = "complementary (adaptive)"
    param_specs: ClassVar[tuple[ParamSpec, ...]] = (
        ParamSpec("cutoff_hz", "initial cut-off (Hz)", 3.0, 0.2, 10.0, 3),
    )

    def lab_filter(self, dt_s: float) -> TiltFilter:
        from gaitmon.dsp.complementary import AdaptiveCutoff, ComplementaryFilter

        return ComplementaryFilter(dt_s, cutoff_hz=self.cutoff_hz, adaptive=AdaptiveCutoff())
