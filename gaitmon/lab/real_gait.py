"""Strides, loops and events on real recordings, trial by trial.

* **gdins_footprints: stride length and gait speed** by the public entry points: heel strikes
  from the foot gyro (:func:`gaitmon.dsp.gyro_gait_events`, bias from the standing start), then
  :func:`gaitmon.dsp.stride_measures`. Each footprint's stance ends at its ``zv_end_idx``
  (IMU-derived, used only to say which stance is which); reference stride k runs from
  footprint k to k + 1 (``ref_stride_length``).
  Strides are matched to the reference by time (:func:`match_footprints`); the first step from
  standing (``first_steps=True``) is reference stride 0. Coverage: reference strides with a
  value, over all of them. Flagged: strides with a value that
  ``StrideMeasures.trusted`` puts in doubt (a turn, a foot that leaves the plane): their errors
  are also given without them. Event recall: footprints 1..K with a heel strike.
  Errors in % of the reference: median and p90 of |error|, mean signed. Speed: the reference
  length over the reference stride time (``stride_time``, ZV end to ZV end, IMU-derived)
  against gaitmon's speed, except where that time exceeds 1.5 times the trial's median (a ZV
  end that closes the final standing).
  Baseline beside it: the dataset README's plain 2-D ZUPT between the dataset's own ZV ends
  (``common_gait.sagittal_stride``: pitch from the accelerometer over the 5 samples before the
  first end, raw gyro integrated, velocity de-drifted linearly, g = 9.81): what the three
  channels give with perfect stance anchors.
* **gdins, a fitted parameter, leave-one-trial-out**: a stride-length gain (median of
  reference / gaitmon over the matched strides of the other trials) applied to the trial left
  out (gaitmon.lab.loto), beside the same gain fitted on all trials (in-sample).
* **xio_closed_loop_walks: distance**: the sum of gaitmon's stride lengths per walk, its stride
  count and the strides with a value, against the source README's approximate length and the
  data README's 3-D ZUPT path (22.7 / 56.8 m), beside the README's 2-D baseline between its
  stance intervals. Heading, and so loop closure, cannot be judged: one gyro axis does not see
  turns.
* **gaitpdb: the FSR events**: heel = sensor 1, toe = sensor 8, low-passed by the pipeline's
  Butterworth, scaled to counts with each sensor's 99th percentile as full scale (4095), the
  pipeline's contact detector and the registered ``fsr`` event source (back-dated by the
  low-pass delay). Reference: contact = total force > 5 % of its 95th percentile; heel strike =
  contact onset, toe off = contact end. Matched within 100 ms: recall, median / p95 |dt|, mean
  signed dt (ms), per foot.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.lab.datasets import ForceTrial, ImuTrial, gyro_bias_at_start

if TYPE_CHECKING:
    from gaitmon.dsp.stride_length import StrideMeasures



@dataclass(frozen=True)
class FootprintStrideRow:
    """One gdins trial."""

    trial: str
    n_ref: int  # reference strides
    hs_found: int  # footprints 1..n_ref with a heel strike
    hs_extra: int  # heel strikes no footprint took
    est: np.ndarray  # (n_ref,) gaitmon's stride length (NaN: none), m
    ref: np.ndarray  # (n_ref,) reference, m
    speed_est: np.ndarray  # (n_ref,) m/s
    speed_ref: np.ndarray
    base: np.ndarray  # (n_ref,) the README's 2-D ZUPT baseline, m
    flagged: np.ndarray  # (n_ref,) bool: a value that a flag puts in doubt (a turn, ...)

    @property
    def err_pct(self) -> np.ndarray:
        """Signed % error of the strides with a value."""
        ok = np.isfinite(self.est)
        return (self.est[ok] - self.ref[ok]) / self.ref[ok] * 100.0

    @property
    def unflagged_err_pct(self) -> np.ndarray:
        """Signed % error of the strides with a value that no flag puts in doubt."""
        ok = np.isfinite(self.est) & ~self.flagged
        return (self.est[ok] - self.ref[ok]) / self.ref[ok] * 100.0

    @property
    def speed_err_pct(self) -> np.ndarray:
        ok = np.isfinite(self.speed_est) & np.isfinite(self.speed_ref)
        return (self.speed_est[ok] - self.speed_ref[ok]) / self.speed_ref[ok] * 100.0

    @property
    def base_err_pct(self) -> np.ndarray:
        return (self.base - self.ref) / self.ref * 100.0

    @property
    def n_value(self) -> int:
        return int(np.isfinite(self.est).sum())


def sagittal_stride(
    ax_f: np.ndarray, az_f: np.ndarray, gy: np.ndarray, i0: int, i1: int, fs: float, nwin: int = 5
) -> float:
    """The data README's plain 2-D ZUPT (foot frame: ax_f forward, az_f up): forward
    displacement from i0 to i1."""
    dt = 1.0 / fs
    th0 = np.arctan2(
        ax_f[max(i0 - nwin, 0) : i0 + 1].mean(), az_f[max(i0 - nwin, 0) : i0 + 1].mean()
    )
    g = gy[i0 : i1 + 1]
    th = th0 + np.concatenate([[0], np.cumsum((g[1:] + g[:-1]) * 0.5 * dt)])
    a = ax_f[i0 : i1 + 1] * np.cos(th) - az_f[i0 : i1 + 1] * np.sin(th)
    v = np.concatenate([[0], np.cumsum((a[1:] + a[:-1]) * 0.5 * dt)])
    v -= np.linspace(0, 1, len(v)) * v[-1]
    return float(np.sum((v[1:] + v[:-1]) * 0.5 * dt))


def footprint_heel_strikes(hs: np.ndarray, zv_end: np.ndarray) -> np.ndarray:
    """(len(zv_end),) index into ``hs`` of each footprint's heel strike, -1 for none: the last
    heel strike in (zv_end[k - 1], zv_end[k]] (footprint 0: up to zv_end[0])."""
    out = np.full(len(zv_end), -1, dtype=np.int64)
    lo = -1
    for k, hi in enumerate(zv_end):
        j = int(np.searchsorted(hs, hi, side="right")) - 1
        if j >= 0 and hs[j] > lo:
            out[k] = j
        lo = int(hi)
    return out


def gaitmon_strides(trial: ImuTrial) -> tuple[np.ndarray, StrideMeasures]:
    """(heel strikes, StrideMeasures) of a foot trial by the public entry points, the first
    step from standing included (``first_steps=True``)."""
    from gaitmon.dsp import gyro_gait_events, stride_measures

    gy = trial.gyro_y - gyro_bias_at_start(trial)
    hs, _ = gyro_gait_events(gy, trial.fs_hz)
    return hs, stride_measures(trial.acc_x, trial.acc_z, gy, trial.fs_hz, hs, first_steps=True)


def match_footprints(m: StrideMeasures, zv_end: np.ndarray, fs_hz: float) -> np.ndarray:
    """(len(zv_end) - 1,) index of the computed stride matched to each reference stride (-1:
    none). A footprint's stance holds its heel strike and ends at its zero-velocity end, so
    computed stride j (opening heel strike a_j, closing b_j = a_j + its stride time) is
    reference stride k when a_j lies in footprint k's stance (the first zero-velocity end at or
    after a_j is k's) and b_j in footprint k + 1's; a first step from standing opens at the
    standing, so it is matched by its closing heel strike alone."""
    from gaitmon.dsp.stride_length import FLAG_FIRST_STEP

    a = m.heel_strike_idx.astype(np.int64)
    b = a + np.round(np.nan_to_num(m.stride_time_s) * fs_hz).astype(np.int64)
    ka = np.searchsorted(zv_end, a, side="left")
    kb = np.searchsorted(zv_end, b, side="left")
    first = (m.flags & FLAG_FIRST_STEP) != 0
    ka[first] = kb[first] - 1
    out = np.full(len(zv_end) - 1, -1, dtype=np.int64)
    for j in np.flatnonzero((kb == ka + 1) & (ka < len(zv_end) - 1) & (ka >= 0)):
        out[ka[j]] = j
    return out


def gdins_strides(trial: ImuTrial) -> FootprintStrideRow:
    hs, m = gaitmon_strides(trial)
    zv = trial.extra["zv_end_idx"].astype(np.int64)
    ref = trial.extra["ref_stride_length"].astype(np.float64)
    k_ref = len(ref)
    j = match_footprints(m, zv, trial.fs_hz)
    k = np.clip(j, 0, None)
    hit = j >= 0
    est = np.where(hit, m.stride_length_m[k], np.nan)
    sp = np.where(hit, m.speed_m_s[k], np.nan)
    flagged = hit & np.isfinite(est) & ~m.trusted[k]
    gy_raw = trial.gyro_y
    base = np.array(
        [
            abs(
                sagittal_stride(
                    trial.acc_z, trial.acc_x, gy_raw, int(zv[i]), int(zv[i + 1]), trial.fs_hz
                )
            )
            for i in range(k_ref)
        ]
    )
    fp = footprint_heel_strikes(hs, zv)
    found = int(np.sum(fp[1:] >= 0))
    st = trial.extra["stride_time"].astype(np.float64)
    # a ZV end that closes a standing (the last stride) makes no stride time
    speed_ref = np.where(st > 1.5 * np.median(st), np.nan, ref / st)
    return FootprintStrideRow(
        trial.name, k_ref, found, len(hs) - int(np.sum(fp >= 0)), est, ref, sp, speed_ref, base,
        flagged,
    )  # fmt: skip


def fit_gain(rows: Sequence[FootprintStrideRow]) -> float:
    """Stride-length gain: median of reference / gaitmon over the strides with a value."""
    r = np.concatenate([row.ref / row.est for row in rows])
    r = r[np.isfinite(r)]
    return float(np.median(r)) if len(r) else 1.0


def gain_median_abs_err_pct(row: FootprintStrideRow, gain: float) -> float:
    ok = np.isfinite(row.est)
    if not ok.any():
        return float("nan")
    return float(np.median(np.abs(gain * row.est[ok] - row.ref[ok]) / row.ref[ok] * 100.0))


@dataclass(frozen=True)
class LoopRow:
    """One xio walk."""

    walk: str
    n_hs: int
    n_value: int  # strides with a length
    distance_m: float  # sum of gaitmon's stride lengths
    base_distance_m: float  # the README's 2-D baseline between its stance intervals
    base_strides: int
    approx_m: float  # the source README's approximate path length
    path3d_m: float  # the data README's 3-D ZUPT path


def xio_loop(trial: ImuTrial) -> LoopRow:
    hs, m = gaitmon_strides(trial)
    length = m.stride_length_m
    st = trial.extra["stance_intervals"].astype(np.int64)
    anchors = [int(st[0][1])] + [int(s + e) // 2 for s, e in st[1:-1]] + [int(st[-1][0])]
    base = [
        abs(sagittal_stride(trial.acc_z, trial.acc_x, trial.gyro_y, a, b, trial.fs_hz))
        for a, b in itertools.pairwise(anchors)
    ]
    return LoopRow(
        trial.name,
        len(hs),
        int(np.isfinite(length).sum()),
        float(np.nansum(length)),
        float(np.sum(base)),
        len(base),
        float(trial.extra["approx_path_length_m"]),
        float(trial.extra["ref_3d_path_m"]),
    )


@dataclass(frozen=True)
class EventRow:
    """One gaitpdb foot: signed dt (ms) of the matched reference events, counts."""

    trial: str
    foot: str
    n_ref_hs: int
    hs_dt_ms: np.ndarray
    n_ref_to: int
    to_dt_ms: np.ndarray
    n_det_hs: int


def gaitpdb_events(rec: ForceTrial, tolerance_s: float = 0.1) -> list[EventRow]:
    from gaitmon.dsp.events import EventRecord, event_sources
    from gaitmon.dsp.filters import Butterworth
    from gaitmon.dsp.gait import GaitEventDetector
    from gaitmon.dsp.gyro_events import match_events
    from gaitmon.dsp.pipeline import PipelineConfig

    cfg = PipelineConfig()
    fsr = next(s for s in event_sources() if s.name == "fsr")
    tol = round(tolerance_s * rec.fs_hz)
    out = []
    for foot in ("left", "right"):
        raw = np.column_stack([rec.heel[foot], rec.toe[foot]])
        low = Butterworth(cfg.cutoff_hz, rec.fs_hz, cfg.filter_order).process(raw)
        counts = low / np.percentile(low, 99, axis=0) * 4095.0
        contacts = GaitEventDetector(
            cfg.fsr_threshold, cfg.fsr_hysteresis, cfg.min_contact_s, rec.fs_hz
        ).process(counts)
        ev = fsr.offline(EventRecord(contacts, np.zeros((len(counts), 4)), rec.fs_hz), cfg)
        total = rec.total[foot]
        contact = (total > 0.05 * np.percentile(total, 95)).astype(np.int8)
        edges = np.diff(contact)
        ref_hs, ref_to = np.flatnonzero(edges == 1) + 1, np.flatnonzero(edges == -1) + 1
        hs_dt, _ = match_events(ev.heel_strike_idx, ref_hs, tol)
        to_dt, _ = match_events(ev.toe_off_idx, ref_to, tol)
        ms = 1000.0 / rec.fs_hz
        out.append(
            EventRow(
                rec.name,
                foot,
                len(ref_hs),
                hs_dt * ms,
                len(ref_to),
                to_dt * ms,
                len(ev.heel_strike_idx),
            )
        )
    return out
