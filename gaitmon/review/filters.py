"""Filter comparison on a recording, Qt-free: request in, result out (the Filters view's engine).

Any of gaitmon's tilt filters (the method registry's, ``gaitmon.dsp.lab_filters.TILT_FILTERS``,
parameters editable where a filter has them) replayed over a range of a recording and, where the
session holds the simulator's ground truth (``/truth``),
scored against it (RMSE, mean and max error).

Inputs. The filters get exactly what the recording's own Kalman filter got: the accelerometer
tilt atan2(a_z, a_x) of the low-passed accelerometer ``/processed/acc_ms2`` and the
bias-corrected gyro rate ``/processed/gyro_rad_s`` (mode ``raw`` only; the unit's own tilt and
joint modes record no sensor signals). Each run starts ``WARMUP_S`` before the range shown, so
filters that learn (Kalman bias, adaptive cut-off) are not scored on their start-up transient.

Mounting offsets. A filter's tilt is in the sensor's frame: true tilt + the board's mounting
offset. The truth has no offset. The alignment choices:

* ``mounting offset (simulator)``: subtract the offsets the simulator used (``/truth``
  attribute ``mount_offset_deg``), exact, so the RMSE is the filter's error alone;
* ``standing mean``: subtract the mean accelerometer tilt over the first seconds of the session
  (what a standing calibration does) from every filter, and the truth's own mean over the same
  rows from the truth: what a clinician's zeroed angles would show;
* ``recorded calibration``: the session's ``/calibration`` offsets (when it was zeroed);
* ``none``: raw sensor-frame tilts (the offsets stay in the error).

One request covers at most ``MAX_RANGE_S`` of data, so an 8-hour recording stays responsive.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitmon.dsp.angles import accel_tilt, joint_angles, wrap_angle
from gaitmon.dsp.channels import SEGMENTS
from gaitmon.dsp.lab_filters import TiltFilter, make_tilt_filter
from gaitmon.dsp.methods import ParamSpec, by_lab_name
from gaitmon.finish import open_session
from gaitmon.io.session import SessionError

WARMUP_S = 10.0
MAX_RANGE_S = 600.0  # ten minutes per view: ~60 000 rows x filters, a second or two
DEFAULT_STANDING_S = 1.5
TARGETS: tuple[tuple[str, str, int], ...] = (  # (label, kind, column)
    *((f"{s} tilt (deg)", "tilt", k) for k, s in enumerate(SEGMENTS)),
    ("hip flexion (deg)", "joint", 0),
    ("knee flexion (deg)", "joint", 1),
    ("ankle dorsiflexion (deg)", "joint", 2),
)
ALIGN_MOUNT = "mounting offset (simulator)"
ALIGN_STANDING = "standing mean"
ALIGN_CALIBRATION = "recorded calibration"
ALIGN_NONE = "none (sensor frame)"
ALIGNMENTS = (ALIGN_MOUNT, ALIGN_STANDING, ALIGN_CALIBRATION, ALIGN_NONE)
DEFAULT_FILTERS = ("accelerometer", "gyro", "kalman (paper 000)")


# --------------------------------------------------------------------------------------------
# filter parameters (Qt-free)


# Parameters the view lets the user edit, with the methods' defaults (each method's
# ``param_specs``, gaitmon.dsp.methods). Filters without any run with their defaults.
Param = ParamSpec


def params_of(name: str) -> tuple[Param, ...]:
    m = by_lab_name().get(name)
    return () if m is None else m.param_specs


class _Params(Mapping[str, tuple[Param, ...]]):
    """The editable parameters by filter name, read from the method registry when asked."""

    def __getitem__(self, name: str) -> tuple[Param, ...]:
        specs = params_of(name)
        if not specs:
            raise KeyError(name)
        return specs

    def __iter__(self) -> Iterator[str]:
        return iter([n for n, m in by_lab_name().items() if m.param_specs])

    def __len__(self) -> int:
        return sum(1 for m in by_lab_name().values() if m.param_specs)


PARAMS: Mapping[str, tuple[Param, ...]] = _Params()


def default_params(name: str) -> dict[str, float]:
    return {p.key: p.default for p in params_of(name)}


def build_filter(name: str, dt_s: float, params: Mapping[str, float] | None = None) -> TiltFilter:
    """A fresh filter: the registry's own when the parameters are the defaults (or none), else
    the method cloned with them."""
    m = by_lab_name().get(name)
    if not params or m is None or not m.param_specs or dict(params) == default_params(name):
        return make_tilt_filter(name, dt_s)
    merged = {**default_params(name), **params}
    return m.clone(**merged).lab_filter(dt_s)


# --------------------------------------------------------------------------------------------
# the computation (Qt-free: request in, result out; runs in the worker)


@dataclass(frozen=True)
class FilterChoice:
    name: str
    params: tuple[tuple[str, float], ...] = ()


@dataclass(frozen=True)
class FiltersRequest:
    path: Path
    start_row: int
    stop_row: int
    target: int  # index into TARGETS
    filters: tuple[FilterChoice, ...]
    alignment: str = ALIGN_MOUNT
    standing_s: float = DEFAULT_STANDING_S
    warmup_s: float = WARMUP_S
    side: str | None = None  # the leg of a bilateral file ("L" | "R"); None for one unit


@dataclass(frozen=True, eq=False)
class FiltersResult:
    request: FiltersRequest
    t_s: np.ndarray  # (n,) true times of the rows shown
    curves_deg: dict[str, np.ndarray]  # filter name -> (n,)
    truth_deg: np.ndarray | None  # (n,) or None when the session has no ground truth
    rmse_deg: dict[str, float] = field(default_factory=dict)
    bias_deg: dict[str, float] = field(default_factory=dict)
    max_abs_deg: dict[str, float] = field(default_factory=dict)
    alignment_used: str = ""
    note: str = ""


def _wrapped_mean(x: np.ndarray) -> np.ndarray:
    """Column means of angles (rad) that may straddle +-pi."""
    ref = x[0]
    return wrap_angle(ref + np.mean(wrap_angle(x - ref), axis=0))


def compute_filters(req: FiltersRequest) -> FiltersResult:
    """Run the chosen filters over the request's rows (plus warm-up) and score them."""
    _, kind, col = TARGETS[req.target]
    with open_session(req.path, recover=False, side=req.side) as s:
        if (
            "processed/acc_ms2" not in s.dataset_names
            or "processed/gyro_rad_s" not in s.dataset_names
        ):
            raise SessionError(
                f"{s.path.name} is a mode '{s.mode}' recording: it holds the unit's own angles, "
                "not the sensor signals the filters need (record in mode raw)"
            )
        fs = s.sample_rate_hz
        n = s.n_samples
        start = max(0, min(req.start_row, n))
        stop = max(start, min(req.stop_row, n))
        if stop - start < 2:
            raise SessionError("the range is too short: choose at least two samples")
        warm = round(req.warmup_s * fs)
        a0 = max(0, start - warm)
        d = s.read_range(a0, stop, ["processed/acc_ms2", "processed/gyro_rad_s", "timeline/t_s"])
        acc = d["processed/acc_ms2"].astype(np.float64)
        gyro = d["processed/gyro_rad_s"].astype(np.float64)
        t_s = d["timeline/t_s"][start - a0 :]
        z = accel_tilt(acc[:, :, 0], acc[:, :, 1])
        truth_tilt, mount = s.truth(start, stop)
        alignment = req.alignment
        note = ""
        truth_offset = np.zeros(len(SEGMENTS))
        if alignment == ALIGN_MOUNT and mount is None:
            alignment = ALIGN_STANDING
            note = "no simulator mounting offsets in this file: aligned on the standing mean"
        if alignment == ALIGN_CALIBRATION and not np.any(s.calibration.tilt_offset_rad):
            alignment = ALIGN_STANDING
            note = "the session was not zeroed: aligned on the standing mean"
        if alignment == ALIGN_MOUNT:
            offset = mount
        elif alignment == ALIGN_CALIBRATION:
            offset = np.asarray(s.calibration.tilt_offset_rad, dtype=np.float64)
        elif alignment == ALIGN_STANDING:
            k = max(1, min(n, round(req.standing_s * fs)))
            st = s.read_range(0, k, ["processed/acc_ms2"])["processed/acc_ms2"].astype(np.float64)
            offset = _wrapped_mean(accel_tilt(st[:, :, 0], st[:, :, 1]))
            tt, _ = s.truth(0, k)
            if tt is not None:
                ok = np.all(np.isfinite(tt), axis=1)
                if ok.any():
                    truth_offset = _wrapped_mean(tt[ok])
        else:
            offset = np.zeros(len(SEGMENTS))
    dt_s = 1.0 / fs
    curves: dict[str, np.ndarray] = {}
    for choice in req.filters:
        flt = build_filter(choice.name, dt_s, dict(choice.params))
        tilt = wrap_angle(flt.process(z, gyro)[start - a0 :] - offset)
        curves[choice.name] = _target_deg(tilt, kind, col)
    truth = None
    if truth_tilt is not None:
        truth = _target_deg(wrap_angle(truth_tilt - truth_offset), kind, col)
    result = FiltersResult(req, t_s, curves, truth, alignment_used=alignment, note=note)
    if truth is not None:
        ok = np.isfinite(truth)
        for name, curve in curves.items():
            err = wrap_angle(np.radians(curve[ok] - truth[ok]))
            err_deg = np.degrees(err)
            result.rmse_deg[name] = float(np.sqrt(np.mean(err_deg**2))) if err_deg.size else np.nan
            result.bias_deg[name] = float(np.mean(err_deg)) if err_deg.size else np.nan
            result.max_abs_deg[name] = float(np.max(np.abs(err_deg))) if err_deg.size else np.nan
    return result


def _target_deg(tilt_rad: np.ndarray, kind: str, col: int) -> np.ndarray:
    if kind == "tilt":
        return np.degrees(tilt_rad[:, col])
    return np.degrees(joint_angles(tilt_rad)[:, col])
