"""``gaitmon lab accuracy --data DIR``: every real dataset in DIR, trial by trial.

The judges are in gaitmon.lab.real_tilt (tilt: BROAD against its optical reference, gdins and
xio against the 3-D 6-axis reference of gaitmon.lab.reference) and gaitmon.lab.real_gait
(gdins stride length, speed and heel-strike recall with a leave-one-trial-out fitted gain; xio
distance; gaitpdb FSR events). A dataset missing from DIR is skipped with a one-line note.
``quick``: three gdins trials and the short xio walk.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitmon.lab import datasets as D
from gaitmon.lab.real_gait import EventRow, FootprintStrideRow, LoopRow
from gaitmon.lab.real_tilt import TiltRow

WORSE_TOLERANCE_DEG = 1.0  # "worse than the paper's": by more than this


@dataclass
class RealAccuracy:
    """Every real-data figure (module doc)."""

    notes: list[str] = field(default_factory=list)  # datasets skipped, and why
    broad: list[TiltRow] = field(default_factory=list)
    foot_tilt: list[TiltRow] = field(default_factory=list)
    strides: list[FootprintStrideRow] = field(default_factory=list)
    gain_loto: list[tuple[float, float]] = field(
        default_factory=list
    )  # (gain, median abs. error %)
    gain_in_sample: list[tuple[float, float]] = field(default_factory=list)
    loops: list[LoopRow] = field(default_factory=list)
    events: list[EventRow] = field(default_factory=list)


def evaluate_real(
    root: Path | None, quick: bool = False, progress: Callable[[str], None] = lambda _m: None
) -> RealAccuracy:
    from gaitmon.lab import loto, real_gait, real_tilt

    out = RealAccuracy()
    have = D.available(root)
    for name, ok in have.items():
        if not ok:
            out.notes.append(f"{name}: not in {root}, skipped")
    if root is None:
        return out
    if have["broad"]:
        progress("real: BROAD")
        out.broad = real_tilt.broad_tilt(D.read_broad(root))
    walks: list[D.ImuTrial] = []
    if have["gdins_footprints"]:
        progress("real: gdins_footprints")
        gdins = D.read_gdins(root)[: 3 if quick else None]
        walks += gdins
        out.strides = [real_gait.gdins_strides(t) for t in gdins]
        fit, judge = real_gait.fit_gain, real_gait.gain_median_abs_err_pct
        if len(out.strides) >= 2:
            out.gain_loto = loto.loto(out.strides, fit, lambda r, g: (g, judge(r, g)))
            out.gain_in_sample = loto.in_sample(out.strides, fit, lambda r, g: (g, judge(r, g)))
    if have["xio_closed_loop_walks"]:
        progress("real: xio_closed_loop_walks")
        xio = D.read_xio(root)
        xio = [t for t in xio if t.name == "short_walk"] if quick else xio
        walks += xio
        out.loops = [real_gait.xio_loop(t) for t in xio]
    if walks:
        progress("real: foot tilt against the 3-D reference")
        out.foot_tilt = real_tilt.foot_tilt(walks)
    if have["gaitpdb"]:
        progress("real: gaitpdb")
        out.events = [r for rec in D.read_gaitpdb(root) for r in real_gait.gaitpdb_events(rec)]
    return out


def aligned(head: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """A Markdown table whose columns line up in plain text too."""
    width = [max(len(str(r[i])) for r in [head, *rows]) for i in range(len(head))]

    def line(r: Sequence[str]) -> str:
        return "| " + " | ".join(str(c).ljust(w) for c, w in zip(r, width, strict=True)) + " |"

    return [line(head), "|" + "|".join("-" * (w + 2) for w in width) + "|", *map(line, rows)]


def _f(x: float, d: int = 1, sign: bool = False) -> str:
    if not np.isfinite(x):
        return "–"
    return f"{x:+.{d}f}" if sign else f"{x:.{d}f}"


def _stats(e: np.ndarray) -> str:
    """median / p90 of |e|, mean signed e (%)."""
    if len(e) == 0:
        return "–"
    a = np.abs(e)
    return f"{np.median(a):.1f} / {np.percentile(a, 90):.1f}, {np.mean(e):+.1f}"


def _tilt_table(rows: list[TiltRow], offset: bool) -> list[str]:
    from gaitmon.lab.columns import columns

    cols = columns()
    head = [
        "trial",
        "judged %",
        *(c.label for c in cols),
        f"live worse than paper (> {WORSE_TOLERANCE_DEG:.0f}°)",
    ]
    body = []
    for r in rows:
        cells = [
            _f(r.rmse_deg[c.key]) + (f" ({_f(r.offset_deg[c.key], sign=True)})" if offset else "")
            for c in cols
        ]
        worse = r.rmse_deg["live"] - r.rmse_deg["paper"] > WORSE_TOLERANCE_DEG
        name = r.trial if r.dataset in ("broad", "gdins_footprints") else f"{r.dataset}/{r.trial}"
        body.append([name, f"{100 * r.judged:.0f}", *cells, "yes" if worse else ""])
    for label, agg in (("median of trials", np.median), ("worst trial", np.max)):
        body.append(
            [label, "", *(_f(float(agg([r.rmse_deg[c.key] for r in rows]))) for c in cols), ""]
        )
    n_worse = sum(r.rmse_deg["live"] - r.rmse_deg["paper"] > WORSE_TOLERANCE_DEG for r in rows)
    body.append(
        [f"live worse than paper in {n_worse} of {len(rows)} trials", "", *("" for _ in cols), ""]
    )
    return aligned(head, body)


def _stride_table(real: RealAccuracy) -> list[str]:
    head = [
        "trial",
        "ref strides",
        "heel strikes found (extra)",
        "with a value",
        "length: abs. error median / p90, mean signed, %",
        "flagged",
        "unflagged: the same",
        "speed: abs. error median / p90, mean signed, %",
        "2-D ZUPT at the dataset's ZV ends: the same",
        "gain fitted LOTO: ×gain, median abs. error % (in-sample)",
    ]
    body = []
    for i, r in enumerate(real.strides):
        lo = real.gain_loto[i] if real.gain_loto else (np.nan, np.nan)
        ins = real.gain_in_sample[i] if real.gain_in_sample else (np.nan, np.nan)
        body.append(
            [
                r.trial,
                str(r.n_ref),
                f"{r.hs_found} ({r.hs_extra})",
                f"{r.n_value} ({100 * r.n_value / r.n_ref:.0f} %)",
                _stats(r.err_pct),
                str(int(r.flagged.sum())),
                _stats(r.unflagged_err_pct),
                _stats(r.speed_err_pct),
                _stats(r.base_err_pct),
                f"×{lo[0]:.3f}: {_f(lo[1])} ({_f(ins[1])})",
            ]
        )
    rs = real.strides
    n_ref, n_val = sum(r.n_ref for r in rs), sum(r.n_value for r in rs)

    def cat(f: Callable[[FootprintStrideRow], np.ndarray]) -> np.ndarray:
        return np.concatenate([f(r) for r in rs])

    found, extra = sum(r.hs_found for r in rs), sum(r.hs_extra for r in rs)
    body.append(
        [
            "all",
            str(n_ref),
            f"{found} ({extra})",
            f"{n_val} ({100 * n_val / n_ref:.0f} %)",
            _stats(cat(lambda r: r.err_pct)),
            str(sum(int(r.flagged.sum()) for r in rs)),
            _stats(cat(lambda r: r.unflagged_err_pct)),
            _stats(cat(lambda r: r.speed_err_pct)),
            _stats(cat(lambda r: r.base_err_pct)),
            f"×{real.gain_in_sample[0][0]:.3f} in-sample" if real.gain_in_sample else "",
        ]
    )
    worst = min(100 * r.n_value / r.n_ref for r in rs)
    body.append([f"worst trial's coverage: {worst:.0f} %"] + [""] * (len(head) - 1))
    return aligned(head, body)


def _loop_table(loops: list[LoopRow]) -> list[str]:
    head = [
        "walk",
        "heel strikes",
        "strides with a length (the first step from standing included)",
        "gaitmon distance, m",
        "vs 3-D ZUPT path",
        "2-D ZUPT at dataset stances, m (strides)",
        "3-D ZUPT path (data README), m",
        "source's length, m",
    ]
    body = [
        [
            r.walk,
            str(r.n_hs),
            str(r.n_value),
            f"{r.distance_m:.2f}",
            f"{100 * (r.distance_m - r.path3d_m) / r.path3d_m:+.1f} %",
            f"{r.base_distance_m:.2f} ({r.base_strides})",
            f"{r.path3d_m:.1f}",
            f"~{r.approx_m:.0f}",
        ]
        for r in loops
    ]
    return aligned(head, body)


def _event_table(events: list[EventRow]) -> list[str]:
    head = [
        "record / foot",
        "ref heel strikes",
        "recall",
        "abs. dt median / p95, ms",
        "mean dt, ms",
        "detected",
        "ref toe offs",
        "recall",
        "abs. dt median / p95, ms",
        "mean dt, ms",
    ]

    def dt(e: np.ndarray) -> tuple[str, str]:
        if len(e) == 0:
            return "–", "–"
        a = np.abs(e)
        return f"{np.median(a):.0f} / {np.percentile(a, 95):.0f}", f"{np.mean(e):+.0f}"

    body = []
    for r in events:
        body.append(
            [
                f"{r.trial} {r.foot}",
                str(r.n_ref_hs),
                f"{100 * len(r.hs_dt_ms) / r.n_ref_hs:.0f} %",
                *dt(r.hs_dt_ms),
                str(r.n_det_hs),
                str(r.n_ref_to),
                f"{100 * len(r.to_dt_ms) / r.n_ref_to:.0f} %",
                *dt(r.to_dt_ms),
            ]
        )
    return aligned(head, body)


def format_real(real: RealAccuracy) -> str:
    """The per-dataset tables, plain text that is Markdown too."""
    lines: list[str] = ["## Real data, trial by trial", ""]
    lines += [f"- {n}" for n in real.notes]
    if real.notes:
        lines.append("")
    sections: list[tuple[bool, str, Callable[[], list[str]]]] = [
        (bool(real.broad), "BROAD (real IMU, optical reference, not walking): planar tilt RMS "
         "error, deg (where |u_y| < 0.5; no offset removed)",
         lambda: _tilt_table(real.broad, offset=False)),
        (bool(real.foot_tilt), "Real walks, foot tilt against the 3-D 6-axis reference (NOT "
         "optical; gaitmon.lab.reference): RMS error after removing the constant offset, deg "
         "(the offset in brackets)", lambda: _tilt_table(real.foot_tilt, offset=True)),
        (bool(real.strides), "gdins_footprints: stride length and gait speed vs the measured "
         "footprints (foot-gyro heel strikes + stride_measures), % of the reference; a "
         "stride-length gain fitted leave-one-trial-out", lambda: _stride_table(real)),
        (bool(real.loops), "xio_closed_loop_walks: distance walked (loop closure needs "
         "heading, which one gyro axis cannot see: not judged)",
         lambda: _loop_table(real.loops)),
        (bool(real.events), "gaitpdb: FSR events (heel = sensor 1, toe = sensor 8; the "
         "registered 'fsr' source) vs contact = total force > 5 % of its p95, matched within "
         "100 ms", lambda: _event_table(real.events)),
    ]  # fmt: skip
    for present, title, table in sections:
        if present:
            lines += [f"### {title}", "", *table(), ""]
    return "\n".join(lines).rstrip() + "\n"
