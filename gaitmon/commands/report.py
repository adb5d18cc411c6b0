"""``gaitmon report FILE -o report.pdf``: the one-page clinical PDF, headless. Of a file that
records both legs: the bilateral report (both legs' cycles on the same axes, the symmetry table;
``docs/bilateral.md``), or one leg's with ``--side L|R``.

The content is :mod:`gaitmon.report` (the same stride analysis as ``gaitmon info`` and the review
window); the page is drawn by ``gaitmon.ui.report_pdf`` with Qt's own PDF writer. No
window is opened: Qt runs on the offscreen platform when there is no display, with a
``QGuiApplication`` only (fonts need one). Qt is imported only when the command runs, so the
rest of the command line stays Qt-free.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gaitmon.commands import add_force, add_quiet, add_side, check_side, damaged_file_guard
from gaitmon.errors import UserError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="session file (.h5)")
    add_side(p)
    p.add_argument("-o", "--output", required=True, metavar="PDF", help="report to write (.pdf)")
    p.add_argument(
        "--normative",
        metavar="FILE",
        help="normal data to draw behind the curves, with each joint's sagittal GVS-like "
        "deviation: gaitmon's CSV or a lab's GCD file (docs/normative-format.md)",
    )
    p.add_argument(
        "--deidentify",
        action="store_true",
        help="leave out the patient identifier, operator and file name",
    )
    p.add_argument("--png", metavar="PNG", help="also write the page as a PNG image")
    add_force(p, "existing output files")
    add_quiet(p, "no summary line")
    p.epilog = (
        "example: gaitmon report walk.h5 -o walk.pdf --normative docs/normative-example.csv; "
        "a file of both legs gives the bilateral report (both legs, symmetry) unless --side "
        "picks one"
    )


def _check_output(path: Path, force: bool) -> None:
    if path.exists() and not force:
        raise UserError(f"{path} exists; use --force to replace it")
    if path.is_dir():
        raise UserError(f"{path} is a folder; give a file name")
    if not path.parent.is_dir():
        raise UserError(f"folder {path.parent} does not exist")


def pdf_outputs(args: argparse.Namespace, what: str) -> tuple[Path, Path | None]:
    """The ``-o`` PDF and the optional ``--png`` of a page command (report, compare),
    checked before any work: a .pdf name, not existing unless ``--force``, in a folder."""
    out = Path(args.output)
    png = Path(args.png) if args.png else None
    if out.suffix.lower() != ".pdf":
        raise UserError(f"{out.name}: the {what} is a PDF; name it .pdf")
    _check_output(out, args.force)
    if png is not None:
        _check_output(png, args.force)
    return out, png


def write_page(
    what: str, writers: Callable[[], tuple[Callable[[Any, Path], Any], Callable[[Any, Path], Any]]],
    data: Any, out: Path, png: Path | None,
) -> None:  # fmt: skip
    """Draw ``data`` with Qt (offscreen without a display): ``writers()`` imports the PDF and
    PNG writers; a Qt that cannot load or a file that cannot be written is one line."""
    _use_offscreen_if_headless()
    try:
        write_pdf, write_png = writers()
    except ImportError as exc:  # PySide6 missing, or a system library Qt needs
        raise UserError(f"the {what} needs Qt, which cannot load here: {exc}") from None
    try:
        write_pdf(data, out)
        if png is not None:
            write_png(data, png)
    except OSError as exc:
        if exc.errno:  # the drive's own words and what to do (one text for every output)
            from gaitmon.errors import output_error_text

            raise UserError(f"the {what}: {output_error_text(exc, exc.filename or out)}") from None
        raise UserError(f"cannot write the {what}: {exc}") from None


def _use_offscreen_if_headless() -> None:
    from gaitmon.ui import display_problem

    if display_problem() is not None:  # no display: Qt would abort trying to open one
        os.environ["QT_QPA_PLATFORM"] = "offscreen"


def run(args: argparse.Namespace) -> int:
    from gaitmon.io.session import SessionError
    from gaitmon.io.session.parts import is_bilateral
    from gaitmon.normative import NormativeError, load_normative
    from gaitmon.report import units_report_from_file

    both = args.side is None and is_bilateral(args.file)
    if not both:
        check_side(args.file, args.side)
    out, png = pdf_outputs(args, "report")
    normative = None
    if args.normative:
        try:
            normative = load_normative(args.normative)
        except NormativeError as exc:
            raise UserError(f"normative band: {exc}") from None
    try:
        with damaged_file_guard(args.file):  # one leg, or both legs of a two-leg file
            data = units_report_from_file(
                args.file, deidentify=args.deidentify, normative=normative, side=args.side
            )
    except SessionError as exc:
        raise UserError(str(exc)) from None

    def writers() -> tuple[Callable[..., Any], Callable[..., Any]]:
        if both:
            from gaitmon.ui.report_pdf.both_legs import write_bilateral_pdf, write_bilateral_png

            return write_bilateral_pdf, write_bilateral_png
        from gaitmon.ui.report_pdf import write_report_pdf, write_report_png

        return write_report_pdf, write_report_png

    write_page("report", writers, data, out, png)
    if not args.quiet:
        print(f"gaitmon report: wrote {out}" + (f" and {png}" if png else ""))
    return 0
