"""``gaitmon info`` of a bilateral session: the file's header and the bilateral block (step time,
stance / swing, double and single support, symmetry ratio and index; ``docs/bilateral.md``)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.io.session.parts import SIDE_NAMES
from gaitmon.text import count

if TYPE_CHECKING:
    from gaitmon.analysis import BilateralAnalysis
    from gaitmon.finish.bilateral import Bilateral


def _f(v: float, digits: int, unit: str = "") -> str:
    return "-" if not np.isfinite(v) else f"{v:.{digits}f}{unit}"


def header_lines(b: Bilateral, interrupted: bool) -> list[str]:
    state = "complete" if b.complete else ("recovered" if b.recovered else "incomplete")
    if interrupted:
        state += " (the recording was interrupted; its parts recovered and combined now)"
    a = b.attrs
    legs = "both legs"
    if b.missing:
        legs = " and ".join(f"{SIDE_NAMES[s]} leg" for s in b.sides) + " only: " + " and ".join(
            f"the {SIDE_NAMES[s]} leg is missing" for s in b.missing)
    lines = [
        f"{b.path.name}: gaitmon bilateral session ({legs}), format "
        f"{a.get('format_version')}, {state}",
        f"  recorded     {a.get('created_utc') or 'date removed'}, "
        f"{float(a.get('duration_s', 0.0)):.1f} s on the common time line, units "
        + " and ".join(f"{s} serial {b.unit(s).device.get('serial') or '-'}" for s in b.sides),
    ]
    lines += [f"  missing      {SIDE_NAMES[s]} leg ({s}): {why}" for s, why in b.missing.items()]
    ppm = ", ".join(
        f"{s} {(b.host_s_per_common_s / b.sync[s].mean_slope - 1.0) * 1e6:+.1f}" for s in b.sides
    )
    delay = ", ".join(f"{s} {_f(b.sync[s].residual_p95_ms, 1)}" for s in b.sides)
    lines.append(
        f"  clocks       {ppm} ppm against the common time line "
        f"({count(len(b.sync[b.sides[0]].x0_s), 'segment')}); receive delay above the fit, "
        f"p95: {delay} ms"
    )
    return lines


def bilateral_lines(an: BilateralAnalysis, missing: Iterable[str] = ()) -> list[str]:
    g = an.gait
    lines = ["both legs (on the common time line; each side's excluded strides left out):"]
    gone = [f"the {SIDE_NAMES[s]} leg" for s in missing]
    if gone:
        lines.append(f"  gait         {' and '.join(gone)} is missing: no bilateral measures")
        return lines
    n = {s.side: int(np.isfinite(s.stride_s).sum()) for s in (g.left, g.right)}
    if not (n["L"] and n["R"]):
        lines.append("  gait         too few strides on both legs to compare")
        return lines
    lines.append(
        f"  cadence      {_f(g.cadence_steps_min, 0)} steps/min (measured: both legs' steps); "
        f"strides L {n['L']}, R {n['R']}"
    )
    sides = (("L", g.left), ("R", g.right))
    lines.append(
        "  step time    " + ", ".join(f"{s} {_f(sg.mean('step_s'), 3, ' s')}" for s, sg in sides)
    )

    def pct(measure: str) -> str:
        parts = []
        for s, sg in sides:
            parts.append(
                f"{s} {_f(sg.pct_mean(measure), 1, ' %')} ({_f(sg.mean(measure), 3, ' s')})"
            )
        return ", ".join(parts)

    lines.append(f"  stance       {pct('stance_s')} of the stride")
    lines.append(f"  swing        {pct('swing_s')}")
    lines.append(f"  double supp. initial {pct('initial_double_support_s')}")
    lines.append(f"               terminal {pct('terminal_double_support_s')}")
    lines.append(f"  single supp. {pct('single_support_s')}")
    from gaitmon.dsp.bilateral import MEASURE_LABELS

    lines.append("  symmetry     measure                   left      right     SR (L/R)  SI")
    for row in g.symmetry:
        lines.append(
            f"               {MEASURE_LABELS[row.measure]:<25s} {_f(row.left, 3, ' s'):<9s} "
            f"{_f(row.right, 3, ' s'):<9s} {_f(row.ratio, 3):<9s} {_f(row.index_pct, 1, ' %')}"
        )
    lines.append(
        "               SR = left / right of the means (1 symmetric); SI = 2 |L - R| / (L + R)"
        " (0 % symmetric)"
    )
    return lines
