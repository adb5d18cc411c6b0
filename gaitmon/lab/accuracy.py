"""``gaitmon lab accuracy``: how close each tilt method gets to the truth, beside the goals.

Methods: every tilt method the app offers (the registry, gaitmon.dsp.methods), live, and
offline where it has an offline pass: "Kalman (paper, seed 000)" (the pipeline with
``tilt_method="paper"``), the gait-aware Kalman (live, the pipeline's default) and the
gait-aware RTS smoother (offline). Judges:

* the simulator with the realism options on (gaitmon.io.sim.sensors.realistic_sensors: soft
  tissue wobble, impacts along both axes, a faster gyro drift) over varied gait: normal, slow and
  fast cadence, stiff-knee, long-stance, and normal walking with turns. Every method gets the
  app's standing calibration (5 s upright, gyro bias and tilt offsets). Joint RMSE is taken after
  the walk's ramp-in, with the mean offset removed (as in the issue); the peak swing knee error is
  the mean over strides of (largest knee flexion in swing) minus the truth's, as the app shows it
  (standing zero only);
* BROAD (real IMU with optical reference, not walking): planar tilt RMS error per trial where the
  planar model holds (gaitmon's test convention, tests/test_broad.py), gyro bias from its first
  second at rest; the gait-aware filters use the foot's tuning;
* with ``data_dir``: every real dataset in it, trial by trial (gaitmon.lab.real: BROAD, foot
  tilt of real walks against a 3-D 6-axis reference, gdins stride length and speed with a
  leave-one-trial-out fitted gain, xio distance, gaitpdb FSR events);
* events: the foot-gyro heel strikes against the simulator's true contacts (median and 95th
  percentile of |error|), beside the FSR detector's; gaitpdb has no gyro, so it cannot judge them;
* FSR faults: a heel sensor that dies and a toe sensor that sticks loaded 30 s into a walk; the
  number of true strides from the failure until the pipeline's flag is known;
* stride length and gait speed (gaitmon.dsp.stride_length, the foot IMU with zero-velocity
  updates) against the simulator's true strides, on normal, slow (85 steps/min, 1.0 m strides)
  and stiff-knee (1.1 m) walking with the realistic sensors: offline on the whole record with
  the foot-gyro heel strikes, live with the streaming tracker fed block by block with the
  pipeline's own heel strikes (the FSRs). Median and 95th percentile of |error| over strides
  after the ramp-in, in %.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon.dsp.angles import joint_angles, wrap_angle
from gaitmon.dsp.calibration import Calibration, standing_calibration
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, FSR_IDX, GYRO_IDX, SEGMENTS
from gaitmon.lab.columns import Column as Column  # the table's columns, re-exported
from gaitmon.lab.columns import column as column
from gaitmon.lab.columns import columns as columns
from gaitmon.lab.columns import labels as labels
from gaitmon.lab.datasets import BROAD_TRIALS as BROAD_TRIALS
from gaitmon.lab.report import Report

if TYPE_CHECKING:
    from gaitmon.lab.real import RealAccuracy


# name -> (GaitConfig options, turns)
SCENARIOS: dict[str, tuple[dict[str, Any], bool]] = {
    "normal": ({}, False),
    "slow (85 steps/min)": ({"cadence_steps_min": 85.0}, False),
    "fast (130 steps/min)": ({"cadence_steps_min": 130.0}, False),
    "stiff-knee": ({"pattern": "stiff-knee"}, False),
    "long-stance": ({"pattern": "long-stance", "cadence_steps_min": 95.0}, False),
    "turns every 12 s": ({}, True),
}
# name -> GaitConfig options of the stride-length judges (each its own stride length)
STRIDE_SCENARIOS: dict[str, dict[str, Any]] = {
    "normal": {},
    "slow (85 steps/min, 1.0 m)": {"cadence_steps_min": 85.0, "stride_length_m": 1.0},
    "stiff-knee (1.1 m)": {"pattern": "stiff-knee", "stride_length_m": 1.1},
}
FS = 100.0
SKIP = 1000  # standing 5 s and the ramp-in stride


@dataclass
class Accuracy:
    """Every figure of the table (degrees, milliseconds, strides)."""

    joint_rmse_deg: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)  # scen, meth
    peak_knee_err_deg: dict[str, dict[str, float]] = field(default_factory=dict)  # stride mean
    peak_knee_strides_deg: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    broad_rmse_deg: dict[str, dict[str, float]] = field(default_factory=dict)  # trial, method
    hs_err_ms: dict[str, np.ndarray] = field(default_factory=dict)  # gyro | fsr -> |errors|
    fault_strides: dict[str, float] = field(default_factory=dict)  # case -> strides (inf = never)
    # scenario -> "length" | "speed" -> "live" | "offline" -> |error| per stride, %
    stride_err_pct: dict[str, dict[str, dict[str, np.ndarray]]] = field(default_factory=dict)
    real: RealAccuracy | None = None  # every real dataset, trial by trial (gaitmon.lab.real)
    realism: str = "default"  # the simulator's realism level (gaitmon.io.sim REALISM_LEVELS)

    def mean_joint(self, method: str, scenarios: list[str] | None = None) -> np.ndarray:
        names = scenarios or list(self.joint_rmse_deg)
        return np.mean([self.joint_rmse_deg[s][method] for s in names], axis=0)

    def mean_peak(self, method: str) -> float:
        return float(np.mean([v[method] for v in self.peak_knee_err_deg.values()]))

    def peak_range(self, method: str) -> tuple[float, float]:
        """The lowest and highest scenario mean of the peak swing knee error."""
        v = [p[method] for p in self.peak_knee_err_deg.values()]
        return float(np.min(v)), float(np.max(v))

    def peak_p95(self, method: str) -> float:
        """95th percentile of |peak swing knee error| over every stride of every scenario."""
        e = np.concatenate([p[method] for p in self.peak_knee_strides_deg.values()])
        return float(np.percentile(np.abs(e), 95))


def _simulate(name: str, n: int, seed: int, realism: str = "default") -> tuple[Any, Any]:
    """The scenario's gait and samples; ``realism`` "real": the harder simulator's level
    (gaitmon.io.sim.config.REALISM_LEVELS, docs/simulator.md) on top of the realistic sensors."""
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.config import realism_gait, realism_sensors
    from gaitmon.io.sim.sensors import realistic_sensors, simulate

    opts, turns = SCENARIOS.get(name) or (STRIDE_SCENARIOS[name], False)
    gait = GaitModel(realism_gait(GaitConfig(seed=seed, **opts), realism))
    return gait, simulate(n, gait, realism_sensors(realistic_sensors(seed, turns=turns), realism))


def _calibrate(counts: np.ndarray) -> Calibration:
    from gaitmon.dsp.pipeline import Pipeline

    first = Pipeline().process(counts[:450])
    return standing_calibration(first.acc_ms2[100:450], first.gyro_rad_s[100:450])


def tilts(counts: np.ndarray, cal: Calibration, method: str) -> np.ndarray:
    """(N, 4) zeroed tilts (rad) of a raw recording by the method of column ``method``
    (:func:`columns`): live, the pipeline with that method; offline, its offline pass."""
    from gaitmon.dsp.methods import get_method
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig

    col = column(method)
    if not col.offline:
        return Pipeline(PipelineConfig(tilt_method=col.method), cal).process(counts).tilt_kalman_rad
    m = get_method(col.method, offline=True)
    ph = DEFAULT_TABLE.to_physical(counts)
    gyro = cal.apply_gyro(ph[:, GYRO_IDX])
    cols = [
        m.offline(ph[:, ACC_X_IDX[j]], ph[:, ACC_Z_IDX[j]], gyro[:, j], FS, seg)
        for j, seg in enumerate(SEGMENTS)
    ]
    raw = np.stack(cols, axis=1)
    return cal.apply_tilt(raw)


def joint_rmse_deg(tilt: np.ndarray, truth_joint_rad: np.ndarray) -> np.ndarray:
    e = np.degrees(wrap_angle(joint_angles(tilt) - truth_joint_rad))[SKIP:]
    e = e - e.mean(axis=0)
    return np.sqrt(np.mean(e**2, axis=0))


def peak_knee_error_deg(tilt: np.ndarray, kin: Any) -> float:
    """Mean over strides of the peak swing knee flexion error (see peak_knee_errors_deg)."""
    return float(np.mean(peak_knee_errors_deg(tilt, kin)))


def peak_knee_errors_deg(tilt: np.ndarray, kin: Any) -> np.ndarray:
    """Per stride after the ramp-in: largest knee flexion in swing minus the truth's, deg."""
    knee = np.degrees(joint_angles(tilt)[:, 1])
    true = np.degrees(kin.joint_rad[:, 1])
    stride = np.floor(kin.phase).astype(int)
    swing = np.mod(kin.phase, 1.0) > 0.6
    errs = []
    for s in range(stride[SKIP] + 1, stride[-1]):
        m = (stride == s) & swing
        if m.sum() > 5:
            errs.append(knee[m].max() - true[m].max())
    return np.asarray(errs)


def _events(gait: Any, counts: np.ndarray, cal: Calibration, n: int, acc: Accuracy) -> None:
    """Every registered event source's heel strikes (gaitmon.dsp.events) against the truth."""
    from gaitmon.dsp.events import EventRecord, event_sources
    from gaitmon.dsp.filters import Butterworth
    from gaitmon.dsp.gait import GaitEventDetector
    from gaitmon.dsp.gyro_events import match_events
    from gaitmon.dsp.pipeline import PipelineConfig

    true_hs, _ = gait.events(0, n)
    cfg = PipelineConfig()
    ph = DEFAULT_TABLE.to_physical(counts)
    fsr = Butterworth(cfg.cutoff_hz, cfg.fs_hz, cfg.filter_order).process(ph[:, FSR_IDX])
    contacts = GaitEventDetector(cfg.fsr_threshold, cfg.fsr_hysteresis, cfg.min_contact_s,
                                 cfg.fs_hz).process(fsr)  # fmt: skip
    record = EventRecord(contacts, cal.apply_gyro(ph[:, GYRO_IDX]), FS)
    for source in event_sources():
        key, det = source.lab_key, source.offline(record, cfg).heel_strike_idx
        err, _ = match_events(det, true_hs[true_hs > SKIP], tolerance=int(0.2 * FS))
        acc.hs_err_ms[key] = np.concatenate([acc.hs_err_ms.get(key, np.empty(0)),
                                             np.abs(err) * 1000.0 / FS])  # fmt: skip


def _faults(gait: Any, counts: np.ndarray, cal: Calibration, n: int, acc: Accuracy) -> None:
    from gaitmon.dsp.pipeline import Pipeline

    onset = n // 2
    true_hs, _ = gait.events(0, n)
    for case, col, value in (("heel sensor dead", 0, 15), ("toe sensor stuck loaded", 1, 4095)):
        c = counts.copy()
        c[onset:, FSR_IDX[col]] = value
        faults = Pipeline(calibration=cal).process(c).fsr_faults
        if not faults:
            acc.fault_strides[case] = float("inf")
            continue
        known = faults[0].decided_idx
        acc.fault_strides[case] = float(np.sum((true_hs > onset) & (true_hs <= known)))


def match_strides(
    start_idx: np.ndarray, length_m: np.ndarray, speed_m_s: np.ndarray, truth: Any,
    after: int = SKIP, tolerance: int = 5,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """|error| in % of stride length and speed of the estimated strides whose opening and closing
    heel strikes both lie within ``tolerance`` samples of a true stride's (``truth``: a
    gaitmon.io.sim.kinematics.StrideTruth), after sample ``after``."""
    t_hs = truth.heel_strike_idx
    if len(t_hs) == 0 or len(start_idx) == 0:
        return np.empty(0), np.empty(0)
    j = np.clip(np.searchsorted(t_hs, start_idx - tolerance), 0, len(t_hs) - 1)
    ok = (np.abs(t_hs[j] - start_idx) <= tolerance) & (start_idx > after)
    # the same stride: its time agrees too (a missed heel strike would double it)
    est_time = length_m / speed_m_s
    ok &= np.abs(est_time - truth.stride_time_s[j]) * FS <= 2 * tolerance
    t_len, t_speed = truth.stride_length_m[j[ok]], truth.speed_m_s[j[ok]]
    return (np.abs(length_m[ok] - t_len) / t_len * 100.0,
            np.abs(speed_m_s[ok] - t_speed) / t_speed * 100.0)  # fmt: skip


def _strides(n: int, seed: int, acc: Accuracy, realism: str = "default") -> None:
    from gaitmon.dsp.gyro_events import gyro_gait_events
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.dsp.stride_length import StrideLengthTracker, stride_measures

    for i, name in enumerate(STRIDE_SCENARIOS):
        gait, sb = _simulate(name, n, seed + i, realism)
        cal = _calibrate(sb.counts)
        ph = DEFAULT_TABLE.to_physical(sb.counts)
        ax, az = ph[:, ACC_X_IDX[3]], ph[:, ACC_Z_IDX[3]]
        gyro = cal.apply_gyro(ph[:, GYRO_IDX])[:, 3]
        truth = gait.strides(0, n)
        out: dict[str, dict[str, np.ndarray]] = {"length": {}, "speed": {}}
        # offline: the whole record, the foot-gyro heel strikes
        hs, _ = gyro_gait_events(gyro, FS)
        m = stride_measures(ax, az, gyro, FS, hs)
        out["length"]["offline"], out["speed"]["offline"] = match_strides(
            m.heel_strike_idx, m.stride_length_m, m.speed_m_s, truth
        )
        # live: 10-sample blocks, each heel strike handed over when the pipeline confirmed it
        live_hs = Pipeline(calibration=cal).process(sb.counts).heel_strike_idx
        tracker = StrideLengthTracker(FS)
        parts = []
        for a in range(0, n, 10):
            b = min(a + 10, n)
            parts.append(tracker.push(ax[a:b], az[a:b], gyro[a:b], live_hs[live_hs + 8 < b]))
        starts = np.concatenate([p.heel_strike_idx for p in parts])
        length = np.concatenate([p.stride_length_m for p in parts])
        speed = np.concatenate([p.speed_m_s for p in parts])
        out["length"]["live"], out["speed"]["live"] = match_strides(starts, length, speed, truth)
        acc.stride_err_pct[name] = out


def evaluate(
    quick: bool = False, data_dir: Path | None = None,
    progress: Callable[[str], None] = lambda _m: None, seed: int = 100,
    realism: str = "default",
) -> Accuracy:  # fmt: skip
    """Run every judge (module doc). ``quick``: two scenarios of 40 s (for tests). Scenario i
    is simulated with seed ``seed + i`` (100: the table's; others are held out). ``realism``
    "real": the simulator judges at the harder level (docs/simulator.md)."""
    acc = Accuracy(realism=realism)
    n = 4000 if quick else 9000  # 5 s standing, then 35 / 85 s of walking
    names = ["normal", "turns every 12 s"] if quick else list(SCENARIOS)
    for i, name in enumerate(names):
        progress(f"simulator: {name}")
        gait, sb = _simulate(name, n, seed=seed + i, realism=realism)
        cal = _calibrate(sb.counts)
        acc.joint_rmse_deg[name] = {}
        acc.peak_knee_err_deg[name] = {}
        acc.peak_knee_strides_deg[name] = {}
        for method in (c.key for c in columns()):
            t = tilts(sb.counts, cal, method)
            acc.joint_rmse_deg[name][method] = joint_rmse_deg(t, sb.kinematics.joint_rad)
            strides = peak_knee_errors_deg(t, sb.kinematics)
            acc.peak_knee_strides_deg[name][method] = strides
            acc.peak_knee_err_deg[name][method] = float(np.mean(strides))
        _events(gait, sb.counts, cal, n, acc)
        if name == "normal":
            _faults(gait, sb.counts, cal, n, acc)
    progress("stride length and speed")
    _strides(n + 2000, seed, acc, realism)
    if data_dir is not None:
        from gaitmon.lab.real import evaluate_real

        acc.real = evaluate_real(data_dir, quick=quick, progress=progress)
        for row in acc.real.broad:
            acc.broad_rmse_deg[row.trial] = row.rmse_deg
    return acc


def _f(x: float, d: int = 1) -> str:
    return "–" if not np.isfinite(x) else f"{x:.{d}f}"


def _row(measure: str, cells: dict[str, str], goal: str) -> tuple[str, ...]:
    """(measure, one cell per method column, goal); columns without a figure stay empty."""
    return (measure, *(cells.get(c.key, "") for c in columns()), goal)


def table_rows(acc: Accuracy) -> list[tuple[str, ...]]:
    """(measure, one cell per method column (:func:`columns`), goal) rows of the headline
    table."""
    straight = [s for s in acc.joint_rmse_deg if "turn" not in s]
    keys = [c.key for c in columns()]
    rows = []

    def joints(method: str, names: list[str] | None = None) -> str:
        return " / ".join(_f(v) for v in acc.mean_joint(method, names))

    rows.append(_row(
        "simulator joint RMSE hip / knee / ankle, deg (mean of scenarios)",
        {k: joints(k) for k in keys}, "≤ 3 each live, ≤ 1.5 offline",
    ))  # fmt: skip
    if len(straight) < len(acc.joint_rmse_deg):
        rows.append(_row("  the same, without the turning scenario" + (
                         " (at this realism every scenario turns)" if acc.realism != "default"
                         else ""),
                         {k: joints(k, straight) for k in keys}, ""))  # fmt: skip

    def peak(method: str) -> str:
        lo, hi = acc.peak_range(method)
        mean, p95 = acc.mean_peak(method), acc.peak_p95(method)
        return f"{mean:+.1f} ({lo:+.1f} … {hi:+.1f}); p95 {p95:.1f}"

    rows.append(_row(
        "simulator peak swing knee flexion error, deg: mean of scenarios (range of scenario "
        "means); p95 of the absolute error over all strides",
        {k: peak(k) for k in keys}, "±3 live, ±1.5 offline",
    ))  # fmt: skip
    for trial, r in acc.broad_rmse_deg.items():
        rows.append(_row(f"BROAD {trial} (real, not walking): planar tilt RMS, deg",
                         {k: _f(r[k]) for k in keys}, "(walking goal ≤ 5 / ≤ 2.5)"))  # fmt: skip
    from gaitmon.dsp.events import event_sources

    for source in event_sources():
        e = acc.hs_err_ms.get(source.lab_key, np.empty(0))
        if len(e):
            fig = f"{np.median(e):.0f} / {np.percentile(e, 95):.0f}"
            rows.append(_row(
                f"{source.lab_label} heel strike vs simulator truth |error| median / p95, ms",
                {"live": fig}, source.lab_goal,
            ))  # fmt: skip
    for case, strides in acc.fault_strides.items():
        rows.append(_row(f"FSR fault ({case}): strides until flagged",
                         {"live": _f(strides, 0)}, "≤ 5"))  # fmt: skip
    if acc.stride_err_pct:
        names = " / ".join(acc.stride_err_pct)
        for kind, label in (("length", "stride length"), ("speed", "gait speed")):

            def cell(mode: str, kind: str = kind) -> str:
                return " / ".join(_median_p95(v[kind][mode]) for v in acc.stride_err_pct.values())

            rows.append(_row(
                f"simulator {label} |error| median (p95) over strides, % ({names}); "
                "live: streamed, the pipeline's heel strikes; offline: whole record, foot gyro",
                {"live": cell("live"), "offline": cell("offline")}, "≤ 3 median",
            ))  # fmt: skip
    return rows


def _median_p95(e: np.ndarray) -> str:
    e = e[np.isfinite(e)]
    return "–" if len(e) == 0 else f"{np.median(e):.1f} ({np.percentile(e, 95):.1f})"


def format_table(acc: Accuracy) -> str:
    cols = columns()
    head = ("measure", *(c.label for c in cols), "goal")
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in table_rows(acc)]
    lines.append("")
    lines.append("Per scenario, joint RMSE hip / knee / ankle (deg) and peak knee error (deg):")
    lines.append("")
    lines.append("| scenario | " + " | ".join(c.label for c in cols) + " |")
    lines.append("|---|" + "---|" * len(cols))
    for name, per in acc.joint_rmse_deg.items():
        cells = [
            " / ".join(_f(v) for v in per[m]) + f" (peak {acc.peak_knee_err_deg[name][m]:+.1f})"
            for m in (c.key for c in cols)
        ]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    if acc.stride_err_pct:
        lines += ["", "Per scenario, stride length and gait speed |error|, % of the truth: median "
                  "(p95); strides with a value / strides matched to a true one:", "",
                  "| scenario | length, live | length, offline | speed, live | speed, offline |",
                  "|---|---|---|---|---|"]  # fmt: skip
        for name, stride in acc.stride_err_pct.items():
            cells = []
            for kind in ("length", "speed"):
                for mode in ("live", "offline"):
                    e = stride[kind][mode]
                    n_ok = int(np.isfinite(e).sum())
                    cells.append(f"{_median_p95(e)}; {n_ok}/{len(e)}")
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    if acc.real is not None:
        from gaitmon.lab.real import format_real

        lines += ["", format_real(acc.real).rstrip()]
    return "\n".join(lines)


def run(out_dir: Path, quick: bool = False, data_dir: Path | None = None) -> Report:
    """The lab framework's entry: the table as a Markdown report (accuracy.md)."""
    acc = evaluate(quick=quick, data_dir=data_dir if data_dir is not None else default_data_dir())
    report = Report("Tilt accuracy: the paper's Kalman, the gait-aware Kalman, the smoother",
                    out_dir, "accuracy")  # fmt: skip
    report.para(__doc__ or "")
    report.lines.append(format_table(acc))
    report.numbers["accuracy"] = acc
    return report


def default_data_dir() -> Path | None:
    """../shared/data beside the source checkout, when it is there."""
    here = Path(__file__).resolve().parents[2].parent / "shared" / "data"
    return here if here.is_dir() else None
