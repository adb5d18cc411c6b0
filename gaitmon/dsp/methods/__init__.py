"""Tilt methods as plugins: one class in one file each, one registry listing them.

:mod:`gaitmon.dsp.methods.base` says what a method is (:class:`TiltMethod`: parameters as
dataclass fields, ``name``, ``label``, a causal pipeline stage, optionally an offline pass);
:mod:`gaitmon.dsp.methods.registry` lists them. Every consumer reads the registry: the pipeline
(``PipelineConfig.tilt_method``), ``estimate_tilt``, ``gaitmon process --method``, the live
menu, the review's reprocess dialog and Filters view, the report, ``gaitmon lab accuracy``.

A new method: a file beside these with a :class:`TiltMethod` subclass, and its builder below.
The built-in methods are registered by name, each module imported when its method is first
asked for (``get_method``), and a method's file imports its filter where it builds it
(``causal_stage``, ``lab_filter``...): reading a file's settings (``gaitmon info``) loads the
one method it names and no filter; listing the methods (``methods()``, menus) builds them all.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gaitmon.dsp.methods.registry import (
    DEFAULT_METHOD,
    REGISTRY,
    by_lab_name,
    check_method,
    feeds_smoother,
    get_method,
    live_names,
    method_label,
    methods,
    register,
    register_lazy,
    settings_read_by,
    smoothing_method,
    unregister,
)
from gaitmon.lazy import keep

if TYPE_CHECKING:
    from gaitmon.dsp.methods.base import (
        NoOfflinePass,
        NoStage,
        ParamSpec,
        TiltFilter,
        TiltInput,
        TiltMethod,
        TiltSettings,
        TiltStage,
    )


def _accelerometer() -> TiltMethod:
    from gaitmon.dsp.methods.accelerometer import Accelerometer

    return Accelerometer()


def _gyro() -> TiltMethod:
    from gaitmon.dsp.methods.gyro import Gyro

    return Gyro()


def _complementary() -> TiltMethod:
    from gaitmon.dsp.methods.complementary import Complementary

    return Complementary()


def _complementary_adaptive() -> TiltMethod:
    from gaitmon.dsp.methods.complementary_adaptive import ComplementaryAdaptive

    return ComplementaryAdaptive()


def _paper() -> TiltMethod:
    from gaitmon.dsp.methods.paper import PaperKalman

    return PaperKalman()


def _constant_rate() -> TiltMethod:
    from gaitmon.dsp.methods.constant_rate import ConstantRate

    return ConstantRate()


def _gait_aware() -> TiltMethod:
    from gaitmon.dsp.methods.gait_aware import GaitAware

    return GaitAware()


# the built-in methods, in the lab's order (the app lists its own with the default first):
# name, builder, and what its class says of it (offered by the app, label, the pipeline
# settings it reads), which building it checks
register_lazy("accelerometer", _accelerometer, False, "accelerometer tilt")
register_lazy("gyro", _gyro, False, "gyro integration")
register_lazy("complementary", _complementary, False, "complementary filter (paper 003)")
register_lazy("complementary-adaptive", _complementary_adaptive, False,
              "complementary filter, adaptive cut-off (paper 003)")  # fmt: skip
register_lazy("paper", _paper, True, "Kalman (paper, seed 000)", ("q_angle", "q_gyro", "r"))
register_lazy("constant-rate", _constant_rate, False, "Kalman, constant-rate model (paper 001)")
register_lazy("gait-aware", _gait_aware, True, "gait-aware Kalman")


def __getattr__(name: str) -> object:
    """The base's names (:mod:`gaitmon.dsp.methods.base`), imported on first use (PEP 562)."""
    if name in _BASE_NAMES:
        from gaitmon.dsp.methods import base

        return keep(globals(), name, base)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_BASE_NAMES = ("NoOfflinePass", "NoStage", "ParamSpec", "TiltFilter", "TiltInput",
               "TiltMethod", "TiltSettings", "TiltStage")  # fmt: skip

__all__ = [
    "DEFAULT_METHOD",
    "REGISTRY",
    "NoOfflinePass",
    "NoStage",
    "ParamSpec",
    "TiltFilter",
    "TiltInput",
    "TiltMethod",
    "TiltSettings",
    "TiltStage",
    "by_lab_name",
    "check_method",
    "feeds_smoother",
    "get_method",
    "live_names",
    "method_label",
    "methods",
    "register",
    "register_lazy",
    "settings_read_by",
    "smoothing_method",
    "unregister",
]
