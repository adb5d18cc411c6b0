"""The pipeline's settings (:class:`PipelineConfig`) and the low-pass's event delay
(:func:`butterworth_dc_delay_samples`), apart from the pipeline's stages
(:mod:`gaitmon.dsp.pipeline`, which re-exports both): a reader of a file's recorded settings
(``gaitmon info``, the session reader) checks and shows them without loading the pipeline."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon.dsp.gait import GaitEventDetector
from gaitmon.dsp.methods import (
    DEFAULT_METHOD,
    check_method,
    get_method,
    method_label,
    settings_read_by,
)
from gaitmon.dsp.setting_checks import check_lowpass, check_tilt_kalman

if TYPE_CHECKING:
    from gaitmon.dsp.methods import TiltMethod


def butterworth_dc_delay_samples(order: int, cutoff_hz: float, fs_hz: float) -> float:
    """The DC group delay (samples) of the Butterworth low-pass (``gaitmon.dsp.iir.butter_lowpass``,
    scipy.signal.butter's), from its poles alone: readers (the review window's first view,
    ``info``) need it without designing a filter. The digital Butterworth low-pass is the bilinear
    transform of the analog prototype (cut-off prewarped): n zeros at z = -1 and poles p_k.
    At DC a factor (1 - q / z) delays by -Re(q / (1 - q)) samples in the numerator and by
    +Re(p / (1 - p)) in the denominator: summed over the factors, which stays accurate where
    the polynomial's coefficient sums (scipy.signal.group_delay) lose every digit."""
    n = int(order)
    k = np.arange(n)
    wc = 2.0 * fs_hz * np.tan(np.pi * cutoff_hz / fs_hz)  # prewarped analog cut-off, rad/s
    poles = wc * np.exp(1j * np.pi * (2 * k + n + 1) / (2 * n))
    z_poles = (2.0 * fs_hz + poles) / (2.0 * fs_hz - poles)
    return float(0.5 * n + np.sum((z_poles / (1.0 - z_poles)).real))


@dataclass(frozen=True)
class PipelineConfig:
    """Every tunable of the pipeline, with the paper's values as defaults."""

    fs_hz: float = 100.0
    cutoff_hz: float = 4.0
    filter_order: int = 2
    q_angle: float = 0.001
    q_gyro: float = 0.003
    r: float = 0.3
    kalman_form: str = "paper"
    fsr_threshold: float = 1000.0
    fsr_hysteresis: float = 50.0
    min_contact_s: float = 0.03
    compensate_event_delay: bool = True
    tilt_method: str = DEFAULT_METHOD  # an app method of gaitmon.dsp.methods: gait-aware | paper
    fsr_check: bool = True  # cross-check the FSRs with the foot gyro, fall back to its events

    @classmethod
    def from_stored(cls, values: Mapping[str, Any]) -> PipelineConfig:
        """The configuration a session file (or journal) recorded; unknown keys are ignored.

        Files written before ``tilt_method`` existed were processed by the paper's filter and
        without the FSR check, so those are what a missing value means.
        """
        fields = cls.__dataclass_fields__
        d = {k: v for k, v in values.items() if k in fields}
        d.setdefault("tilt_method", "paper")
        d.setdefault("fsr_check", False)
        d["fsr_check"] = bool(d["fsr_check"])
        return cls(**d)

    @property
    def tilt_method_label(self) -> str:
        """The tilt filter's name for people: "Kalman (paper, seed 000)" or "gait-aware Kalman"
        (without building the method)."""
        return method_label(self.tilt_method)

    @property
    def settings_read(self) -> tuple[str, ...]:
        """The settings the tilt method reads beyond ``fs_hz`` (``TiltMethod.reads_settings``),
        without building it."""
        return settings_read_by(self.tilt_method)

    @property
    def method(self) -> TiltMethod:
        """The tilt method ``tilt_method`` names (gaitmon.dsp.methods)."""
        return get_method(self.tilt_method, live=True)

    def __post_init__(self) -> None:
        # Every value is checked with a message that names it, as the stages check them, but
        # without designing the filters: a file's recorded settings are read cheaply.
        check_lowpass(self.cutoff_hz, self.fs_hz, self.filter_order)
        check_tilt_kalman(1.0 / self.fs_hz, self.q_angle, self.q_gyro, self.r, self.kalman_form)
        GaitEventDetector(self.fsr_threshold, self.fsr_hysteresis, self.min_contact_s, self.fs_hz)
        check_method(self.tilt_method, live=True)

    @property
    def dt_s(self) -> float:
        return 1.0 / self.fs_hz

    @property
    def phase_lag_samples(self) -> int:
        """How far the per-sample contact and phase arrays lag the event time base.

        Events are dated at the threshold crossing moved back by the filter delay; the
        debounced contacts change ``min_contact`` - 1 samples after the crossing, at the causal
        (delayed) sample. Displays and readouts show the phase of row ``i + lag`` at row ``i``
        so that a heel-strike line and the loading band start at the same instant.
        """
        d = GaitEventDetector(
            self.fsr_threshold, self.fsr_hysteresis, self.min_contact_s, self.fs_hz
        ).min_duration_samples
        return self.event_delay_samples + d - 1

    @property
    def event_delay_samples(self) -> int:
        """Samples subtracted from event indices (the low-pass's DC group delay, rounded)."""
        if not self.compensate_event_delay:
            return 0
        return round(butterworth_dc_delay_samples(self.filter_order, self.cutoff_hz, self.fs_hz))

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    def replace(self, **changes: Any) -> PipelineConfig:
        return replace(self, **changes)

    def reads_fsrs_as(self, other: PipelineConfig) -> bool:
        """Whether ``other`` reads the force sensors the same way (threshold, hysteresis,
        low-pass, minimum contact), so that a sensor it flagged as faulty is faulty here too."""
        return all(getattr(self, k) == getattr(other, k) for k in _FSR_KEYS)


_FSR_KEYS = ("fs_hz", "cutoff_hz", "filter_order", "fsr_threshold", "fsr_hysteresis",
             "min_contact_s")  # fmt: skip
