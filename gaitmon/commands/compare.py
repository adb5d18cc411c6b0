"""``gaitmon compare A.h5 B.h5 [C.h5 …] -o compare.pdf``: progress across sessions, headless.

The content is :func:`gaitmon.compare.compare_sessions` (each session analysed as ``gaitmon
info``, the report and review do; ordered by date; patient ids checked; changes judged by the
one rule of ``docs/compare.md``); the page is drawn by ``gaitmon.ui.report_pdf.compare`` with
Qt's PDF writer, on the offscreen platform when there is no display. Qt is imported only here.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from gaitmon.commands import add_force, add_quiet
from gaitmon.commands.report import pdf_outputs, write_page

if TYPE_CHECKING:
    from gaitmon.compare import Comparison


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="two or more session files (.h5) of one patient, in any order")  # fmt: skip
    p.add_argument("-o", "--output", required=True, metavar="PDF",
                   help="comparison to write (.pdf)")  # fmt: skip
    p.add_argument("--deidentify", action="store_true",
                   help="leave out the patient identifier, file names and dates (sessions are "
                   "numbered, with days since the first)")  # fmt: skip
    p.add_argument("--png", metavar="PNG", help="also write the first page as a PNG image")
    add_force(p, "existing output files")
    add_quiet(p, "no summary (warnings are still printed)")
    p.epilog = "example: gaitmon compare visit1.h5 visit2.h5 -o progress.pdf"


def run(args: argparse.Namespace) -> int:
    from gaitmon.compare import CompareError, compare_sessions

    if len(args.files) < 2:  # before anything is checked or opened
        raise CompareError(f"compare needs two or more sessions, got {len(args.files)}; give "
                           "the files to compare (e.g. the first visit and the latest)")
    out, png = pdf_outputs(args, "comparison")
    c = compare_sessions(args.files, deidentify=args.deidentify)  # CompareError: a UserError
    for w in c.warnings:
        print(f"gaitmon compare: warning: {w}", file=sys.stderr)

    def writers() -> tuple[Callable[..., Any], Callable[..., Any]]:
        from gaitmon.ui.report_pdf.compare import write_comparison_pdf, write_comparison_png

        return write_comparison_pdf, write_comparison_png

    write_page("comparison", writers, c, out, png)
    if not args.quiet:
        print(f"gaitmon compare: wrote {out}" + (f" and {png}" if png else ""))
        print("\n".join(summary_lines(c)))
    return 0


def summary_lines(c: Comparison) -> list[str]:
    """What the terminal says of a comparison: each session with its gaps and excluded
    strides, then every change from the baseline beyond the MDC95 with its threshold."""
    from gaitmon.compare import MEASURE_BY_KEY, change_text
    from gaitmon.text import count

    lines = [f"  {c.who}, {count(len(c.sessions), 'session')} (oldest first):"]
    for k, s in enumerate(c.sessions):
        role = " (baseline)" if k == 0 else ""
        lines.append(f"  {k + 1}{role} {s.recorded_utc or 'date unknown'}  {s.file_name}: "
                     f"{s.n_included} of {s.n_strides_total} strides included; "
                     f"{s.quality.text()}")  # fmt: skip
    n = c.n_beyond()
    lines.append(f"  {count(n, 'change')} from the baseline beyond the minimal detectable "
                 "change (MDC95 = 1.96 x sqrt(2) x pooled stride-to-stride SD; docs/compare.md)"
                 + (":" if n else ""))  # fmt: skip
    for k in range(1, len(c.sessions)):
        for key in c.beyond(k):
            m = MEASURE_BY_KEY[key]
            ch = c.change(k, key)
            lines.append(f"    {k + 1} - 1  {m.label}: {change_text(ch, m, unit=True, minus='-')}")
    return lines
