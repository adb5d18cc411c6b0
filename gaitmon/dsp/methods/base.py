"""What a tilt method is: the base class every method of gaitmon.dsp.methods derives from.

A method is one frozen dataclass in one file (the shape of gaitmap's ``BaseOrientationMethod``
and of scikit-learn's estimators): its dataclass fields are its parameters (``get_params()``,
``clone(**changes)``), and its class attributes say how people and files name it:

* ``name``   -- the key: ``PipelineConfig.tilt_method``, ``gaitmon process --method``;
* ``label``  -- shown to users and stored in files ("gait-aware Kalman");
* ``live``   -- offered by the app (live menu, ``process --method``, the reprocess dialog,
  ``gaitmon lab accuracy``); lab-only methods are listed in the review's Filters view;
* ``lab_name`` -- its name in the Filters view and the paper experiments, where it has one.

What it computes:

* :meth:`TiltMethod.causal_stage` -- the streaming :class:`TiltStage` the pipeline runs over
  every segment at once (:class:`TiltInput` in, (N, S) continuous tilts out);
* :meth:`TiltMethod.estimate` -- one segment's whole record (``gaitmon.dsp.estimate_tilt``);
* :meth:`TiltMethod.offline` -- an optional zero-lag pass over a whole record (``offline_label``
  names it), e.g. the gait-aware RTS smoother;
* :meth:`TiltMethod.lab_filter` -- the method as a :class:`TiltFilter` on (accelerometer tilt,
  gyro), for the Filters view and the lab, where it has that form.

A new method is a subclass in a file of its own plus one line in gaitmon.dsp.methods' list.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar, Protocol, Self, runtime_checkable

import numpy as np

from gaitmon.dsp.base import Stage


@dataclass(frozen=True)
class TiltInput:
    """One block of every segment's signals as the pipeline hands them to a tilt stage.

    Arrays are (N, S), one column per segment (body, thigh, shank, foot in the pipeline):
    the raw accelerometer axes (m/s^2), the accelerometer tilt atan2(a_z, a_x) of the
    low-passed accelerometer (rad) and the bias-corrected gyro rate (rad/s)."""

    acc_x_ms2: np.ndarray
    acc_z_ms2: np.ndarray
    acc_tilt_rad: np.ndarray
    gyro_rad_s: np.ndarray


@runtime_checkable
class TiltStage(Stage[TiltInput, np.ndarray], Protocol):
    """A method's causal filter in the pipeline: blocks in, (N, S) continuous tilts out.

    ``restart()`` starts the angle again after a long gap (what was learnt of the gyro bias
    kept); ``shift_bias`` follows a new gyro bias subtracted upstream; ``bias_rad_s`` is the
    bias state (None before the first sample, or for a filter that has none)."""

    def restart(self) -> None: ...

    @property
    def bias_rad_s(self) -> np.ndarray | None: ...

    def shift_bias(self, delta_rad_s: np.ndarray | float) -> None: ...


@runtime_checkable
class TiltFilter(Protocol):
    """A tilt filter of the lab's form: ``process(acc_tilt_rad, gyro_rad_s) -> tilt_rad``,
    (N,) or (N, segments), same shape out; any chunking gives the same output."""

    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray: ...

    def reset(self) -> None: ...


class TiltSettings(Protocol):
    """The pipeline settings a method's stage may read (gaitmon.dsp.pipeline.PipelineConfig)."""

    @property
    def fs_hz(self) -> float: ...

    @property
    def q_angle(self) -> float: ...

    @property
    def q_gyro(self) -> float: ...

    @property
    def r(self) -> float: ...

    @property
    def kalman_form(self) -> str: ...


@dataclass(frozen=True)
class ParamSpec:
    """How a user may edit one parameter (the Filters view): its field, label and range."""

    key: str
    label: str
    default: float
    minimum: float
    maximum: float
    decimals: int = 4


class NoOfflinePass(ValueError):
    """The method has no offline (whole-record) pass."""


class NoStage(ValueError):
    """The method has no filter of the lab's form."""


@dataclass(frozen=True)
class TiltMethod:
    """The base of every tilt method (module doc). Subclasses are frozen dataclasses whose
    fields are the parameters, each with a default (``cls()`` is the method as offered)."""

    name: ClassVar[str]
    label: ClassVar[str]
    offline_label: ClassVar[str | None] = None
    live: ClassVar[bool] = False
    lab_name: ClassVar[str | None] = None
    # the live menu's tooltip
    tip: ClassVar[str] = ""
    # the method in a sentence ("--q-angle tunes <noun>"); the label when empty
    noun: ClassVar[str] = ""
    # PipelineConfig fields the causal stage reads beyond fs_hz (``process`` refuses them for
    # a method that does not read them: they would silently change nothing)
    reads_settings: ClassVar[tuple[str, ...]] = ()
    # the parameters the Filters view lets the user edit
    param_specs: ClassVar[tuple[ParamSpec, ...]] = ()

    # -- parameters (scikit-learn's shape) ----------------------------------------------------

    def get_params(self) -> dict[str, float | str | bool | int]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def clone(self, **changes: float | str | bool | int) -> Self:
        """A copy with ``changes`` (unknown names raise TypeError)."""
        return dataclasses.replace(self, **changes)

    @property
    def noun_phrase(self) -> str:
        return self.noun or f"the {self.label}"

    @property
    def has_offline(self) -> bool:
        return self.offline_label is not None

    # -- what it computes ---------------------------------------------------------------------

    def causal_stage(self, settings: TiltSettings) -> TiltStage:
        """The streaming stage the pipeline runs over every segment's columns. By default
        :meth:`lab_filter` fed the low-passed accelerometer tilt (:class:`LabFilterStage`)."""
        return LabFilterStage(self.lab_filter(1.0 / settings.fs_hz))

    def estimate(
        self, acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
        fs_hz: float, segment: str,
    ) -> np.ndarray:  # fmt: skip
        """One segment's causal tilt over a whole record ((N,) arrays in, rad out). By default
        the accelerometer tilt of the raw axes through :meth:`lab_filter`."""
        z = np.arctan2(acc_z_ms2, acc_x_ms2)
        return np.asarray(self.lab_filter(1.0 / fs_hz).process(z, gyro_rad_s))

    def offline(
        self, acc_x_ms2: np.ndarray, acc_z_ms2: np.ndarray, gyro_rad_s: np.ndarray,
        fs_hz: float, segment: str,
    ) -> np.ndarray:  # fmt: skip
        """One segment's zero-lag tilt over a whole record (methods with ``offline_label``)."""
        raise NoOfflinePass(f"tilt method {self.name!r} has no offline smoother")

    def lab_filter(self, dt_s: float) -> TiltFilter:
        """A fresh filter of the lab's form (methods with ``lab_name``)."""
        raise NoStage(f"tilt method {self.name!r} has no filter of the lab's form")

    def describe(self, settings: TiltSettings) -> str:
        """The report's text after the label: what the method reads, with its settings."""
        return self.tip


class BiasTracking(Protocol):
    """A tilt filter that tracks the gyro bias (TiltKalman, GaitAwareKalman)."""

    def reset(self) -> None: ...

    def restart(self) -> None: ...

    @property
    def bias_rad_s(self) -> np.ndarray | None: ...

    def shift_bias(self, delta_rad_s: np.ndarray | float) -> None: ...


class KalmanStage:
    """The shared half of a stage around a bias-tracking filter ``kf``: a subclass says how a
    :class:`TiltInput` feeds it (``process``); reset, restart and the bias are the filter's."""

    def __init__(self, kf: BiasTracking) -> None:
        self.kf = kf

    def reset(self) -> None:
        self.kf.reset()

    def restart(self) -> None:
        self.kf.restart()

    @property
    def bias_rad_s(self) -> np.ndarray | None:
        return self.kf.bias_rad_s

    def shift_bias(self, delta_rad_s: np.ndarray | float) -> None:
        self.kf.shift_bias(delta_rad_s)


class LabFilterStage:
    """A :class:`TiltFilter` as a pipeline stage: fed the low-passed accelerometer tilt (as
    paper 000 feeds its Kalman filter). Filters without a bias state report none."""

    def __init__(self, filt: TiltFilter) -> None:
        self.filter = filt

    def process(self, block: TiltInput, /) -> np.ndarray:
        return self.filter.process(block.acc_tilt_rad, block.gyro_rad_s)

    def reset(self) -> None:
        self.filter.reset()

    def restart(self) -> None:
        self.filter.reset()

    @property
    def bias_rad_s(self) -> np.ndarray | None:
        return None

    def shift_bias(self, delta_rad_s: np.ndarray | float) -> None:
        pass
