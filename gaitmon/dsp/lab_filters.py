"""Every sagittal tilt filter of the lab's form, read from the method registry
(gaitmon.dsp.methods), for the lab and for the review's Filters view to list.

A tilt filter is a streaming stage with

    process(acc_tilt_rad, gyro_rad_s) -> tilt_rad      # (N,) or (N, segments), same shape out
    reset()

Inputs: the accelerometer tilt atan2(a_z, a_x) and the (bias-corrected) gyro rate about the
hinge axis, whose sign makes d(tilt)/dt = +gyro (see gaitmon.dsp.channels). Outputs are
continuous angles (not wrapped); wrap them with gaitmon.dsp.angles.wrap_angle for display.
Any chunking of the input gives the same output as one call on the whole record.

``TILT_FILTERS`` maps a method's lab name to a factory ``(dt_s) -> filter`` with the method's
default parameters (each in its own file of gaitmon.dsp.methods):

* "accelerometer"             -- the accelerometer tilt itself (paper 000's red curve);
* "gyro"                      -- integration of the rate from the first accelerometer tilt
                                 (paper 000's blue curve, without its display low-pass);
* "complementary"             -- paper 003 at its 3 Hz cut-off;
* "complementary (adaptive)"  -- paper 003 with the FFT-chosen cut-off (gaitmon.dsp.complementary);
* "kalman (paper 000)"        -- the app's "paper" method, gaitmon.dsp.kalman.TiltKalman with the
                                 paper's parameters;
* "kalman constant-rate (paper 001)" -- paper 001's per-axis [angle, rate] model used on the
                                 accelerometer tilt as its angle measurement (q = 1, R = 0.3 rad^2,
                                 paper 000's R, because paper 001's R recipe needs a whole record).

The app's default, the gait-aware filter, reads the raw accelerometer axes rather than their
tilt, so it has no filter of this form (``gaitmon.dsp.estimate_tilt`` runs it).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping

from gaitmon.dsp.methods import TiltFilter, by_lab_name
from gaitmon.dsp.methods.accelerometer import AccelerometerTilt
from gaitmon.dsp.methods.constant_rate import ConstantRateTilt
from gaitmon.dsp.methods.gyro import GyroTilt

__all__ = ["TILT_FILTERS", "AccelerometerTilt", "ConstantRateTilt", "GyroTilt", "TiltFilter",
           "make_tilt_filter"]  # fmt: skip


class _LabFilters(Mapping[str, Callable[[float], TiltFilter]]):
    """The lab's filters by name, read from the method registry when asked (so a method
    registered later is listed too)."""

    def __getitem__(self, name: str) -> Callable[[float], TiltFilter]:
        return by_lab_name()[name].lab_filter

    def __iter__(self) -> Iterator[str]:
        return iter(by_lab_name())

    def __len__(self) -> int:
        return len(by_lab_name())


TILT_FILTERS: Mapping[str, Callable[[float], TiltFilter]] = _LabFilters()


def make_tilt_filter(name: str, dt_s: float = 0.01) -> TiltFilter:
    """A fresh filter by its registry name (clear error for an unknown one)."""
    try:
        factory = TILT_FILTERS[name]
    except KeyError:
        known = ", ".join(TILT_FILTERS)
        raise ValueError(f"unknown tilt filter {name!r}; known: {known}") from None
    return factory(dt_s)
