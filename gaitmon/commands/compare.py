"""``gaitmon compare A.h5 B.h5 [C.h5 …] -o compare.pdf``: progress across sessions, headless.

The content is :func:`gaitmon.compare.compare_sessions` (each session analysed as ``gaitmon
info``, the report and review do; ordered by date; patient ids checked; changes judged by the
one rule of ``docs/compare.md``); the page is drawn by ``gaitmon.ui.report_pdf.compare`` with
Qt's PDF writer, on the offscreen platform when there is no display. Qt is imported only here.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gaitmon.commands import add_force, add_quiet
from gaitmon.commands.report import _check_output, _use_offscreen_if_headless
from gaitmon.errors import UserError


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
    add_quiet(p, "no summary line (warnings are still printed)")
    p.epilog = "example: gaitmon compare visit1.h5 visit2.h5 -o progress.pdf"


def run(args: argparse.Namespace) -> int:
    from gaitmon.compare import CompareError, compare_sessions

    if len(args.files) < 2:  # before anything is checked or opened
        raise CompareError(f"compare needs two or more sessions, got {len(args.files)}; give "
                           "the files to compare (e.g. the first visit and the latest)")
    out = Path(args.output)
    png = Path(args.png) if args.png else None
    if out.suffix.lower() != ".pdf":
        raise UserError(f"{out.name}: the comparison is a PDF; name it .pdf")
    _check_output(out, args.force)
    if png is not None:
        _check_output(png, args.force)
    c = compare_sessions(args.files, deidentify=args.deidentify)  # CompareError: a UserError
    for w in c.warnings:
        print(f"gaitmon compare: warning: {w}", file=sys.stderr)
    _use_offscreen_if_headless()
    try:
        from gaitmon.ui.report_pdf.compare import write_comparison_pdf, write_comparison_png
    except ImportError as exc:  # PySide6 missing, or a system library Qt needs
        raise UserError(f"the comparison needs Qt, which cannot load here: {exc}") from None
    try:
        write_comparison_pdf(c, out)
        if png is not None:
            write_comparison_png(c, png)
    except OSError as exc:
        raise UserError(f"cannot write the comparison: {exc}") from None
    if not args.quiet:
        n = sum(len(c.beyond(k)) for k in range(1, len(c.sessions)))
        who = c.who
        print(f"gaitmon compare: wrote {out}" + (f" and {png}" if png else "")
              + f" ({len(c.sessions)} sessions, {who}; {n} change{'s' if n != 1 else ''} from "
              "the baseline beyond the between-stride variability)")  # fmt: skip
    return 0
