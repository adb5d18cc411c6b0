"""Tilt on real recordings, trial by trial, for every method column of the lab's table.

* BROAD (optical reference, not walking): planar tilt RMS error where the planar model holds
  (``ImuTrial.ref_valid``), no offset removed, gyro bias from the trial's first second at rest:
  as ``gaitmon lab accuracy`` has always judged it, now per trial and per method.
* gdins_footprints and xio_closed_loop_walks (real walking, no optical reference): the foot's
  planar tilt against :func:`gaitmon.lab.reference.reference_foot_tilt`, the **3-D 6-axis
  reference, not optical**, over the walking (without the standing the trial starts and ends
  with: :func:`walking_span`) where the reference is defined, RMS error **after removing the
  constant offset** (reported beside it: the mean error). Gyro bias: the standing the trial
  starts with (the app's standing calibration, :func:`gaitmon.lab.datasets.gyro_bias_at_start`).

Every method gets the foot's tuning (``segment="foot"``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.angles import wrap_angle
from gaitmon.lab.datasets import ImuTrial, gyro_bias_at_start

STANDING_S = 1.0


@dataclass(frozen=True)
class TiltRow:
    """One trial's figures: RMS error and mean error (deg) by method key."""

    dataset: str
    trial: str
    rmse_deg: dict[str, float]
    offset_deg: dict[str, float]
    judged: float  # share of the trial's samples judged


def method_tilts(trial: ImuTrial) -> dict[str, np.ndarray]:
    """(N,) tilt (rad) of the trial's board by every method column (gaitmon.lab.columns)."""
    from gaitmon.dsp.estimate import estimate_tilt
    from gaitmon.lab.columns import columns

    gy = trial.gyro_y - gyro_bias_at_start(trial)
    return {
        c.key: estimate_tilt(
            trial.acc_x,
            trial.acc_z,
            gy,
            trial.fs_hz,
            segment="foot",
            method=c.method,
            offline=c.offline,
        )
        for c in columns()
    }


def _row(trial: ImuTrial, ref: np.ndarray, valid: np.ndarray, remove_offset: bool) -> TiltRow:
    rmse, offset = {}, {}
    for key, est in method_tilts(trial).items():
        e = np.degrees(wrap_angle(est - ref)[valid])
        m = float(np.mean(e)) if len(e) else float("nan")
        d = e - m if remove_offset else e
        rmse[key] = float(np.sqrt(np.mean(d**2))) if len(e) else float("nan")
        offset[key] = m
    return TiltRow(trial.dataset, trial.name, rmse, offset, float(np.mean(valid)))


def broad_tilt(trials: Sequence[ImuTrial]) -> list[TiltRow]:
    """BROAD against its optical reference (module doc)."""
    out = []
    for t in trials:
        assert t.ref_tilt_rad is not None and t.ref_valid is not None
        out.append(_row(t, t.ref_tilt_rad, t.ref_valid, remove_offset=False))
    return out


def walking_span(trial: ImuTrial) -> tuple[int, int]:
    """[start, stop) of the walking: without the standing (a still run of at least
    ``STANDING_S``, gaitmon.lab.reference.still_runs) the trial starts or ends with."""
    from gaitmon.lab.reference import still_runs

    assert trial.acc_xyz is not None and trial.gyr_xyz is not None
    runs = still_runs(trial.acc_xyz, trial.gyr_xyz)
    n, long = len(trial), STANDING_S * trial.fs_hz
    start = runs[0][1] if runs and runs[0][0] == 0 and runs[0][1] >= long else 0
    stop = runs[-1][0] if runs and runs[-1][1] == n and n - runs[-1][0] >= long else n
    return start, max(start, stop)


def foot_tilt(trials: Sequence[ImuTrial]) -> list[TiltRow]:
    """Real walks against the 3-D 6-axis reference (module doc)."""
    from gaitmon.lab.reference import reference_foot_tilt

    out = []
    for t in trials:
        ref = reference_foot_tilt(t)
        a, b = walking_span(t)
        judged = np.isfinite(ref)
        judged[:a] = False
        judged[b:] = False
        out.append(_row(t, ref, judged, remove_offset=True))
    return out
