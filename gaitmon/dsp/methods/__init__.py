"""Tilt methods as plugins: one class in one file each, one registry listing them.

:mod:`gaitmon.dsp.methods.base` says what a method is (:class:`TiltMethod`: parameters as
dataclass fields, ``name``, ``label``, a causal pipeline stage, optionally an offline pass);
:mod:`gaitmon.dsp.methods.registry` lists them. Every consumer reads the registry: the pipeline
(``PipelineConfig.tilt_method``), ``estimate_tilt``, ``gaitmon process --method``, the live
menu, the review's reprocess dialog and Filters view, the report, ``gaitmon lab accuracy``.

A new method: a file beside these with a :class:`TiltMethod` subclass, and one line below.
A method's file imports its filter where it builds it (``causal_stage``, ``lab_filter``...),
so that listing the methods (reading a file's settings, ``gaitmon info``, ``process --help``)
loads no filter.
"""

from __future__ import annotations

from gaitmon.dsp.methods.accelerometer import Accelerometer
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
from gaitmon.dsp.methods.complementary import Complementary
from gaitmon.dsp.methods.complementary_adaptive import ComplementaryAdaptive
from gaitmon.dsp.methods.constant_rate import ConstantRate
from gaitmon.dsp.methods.gait_aware import GaitAware
from gaitmon.dsp.methods.gyro import Gyro
from gaitmon.dsp.methods.paper import PaperKalman
from gaitmon.dsp.methods.registry import (
    DEFAULT_METHOD,
    REGISTRY,
    by_lab_name,
    feeds_smoother,
    get_method,
    live_names,
    method_label,
    methods,
    register,
    smoothing_method,
    unregister,
)

# the built-in methods, in the lab's order (the app lists its own with the default first)
for _method in (
    Accelerometer(),
    Gyro(),
    Complementary(),
    ComplementaryAdaptive(),
    PaperKalman(),
    ConstantRate(),
    GaitAware(),
):
    register(_method)

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
    "feeds_smoother",
    "get_method",
    "live_names",
    "method_label",
    "methods",
    "register",
    "smoothing_method",
    "unregister",
]
