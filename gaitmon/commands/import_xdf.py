"""``gaitmon import FILE.xdf [-o OUT.h5]``: a LabRecorder recording of gaitmon's LSL streams as
a session file (the work is :func:`gaitmon.lsl.xdf_import.import_xdf`; this module turns the
options into :class:`ImportOptions` and prints)."""

from __future__ import annotations

import argparse
import sys

from gaitmon.commands import add_force, add_quiet


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="a LabRecorder recording (.xdf, .xdfz)")
    p.add_argument("-o", "--output", metavar="OUT", default=None,
                   help="the session file to write (default: FILE with .h5)")  # fmt: skip
    p.add_argument(
        "--unit",
        metavar="SERIAL",
        default=None,
        help="the unit to import when the file holds several gaitmon units",
    )
    p.add_argument(
        "--markers-from",
        metavar="NAME",
        default=None,
        help="another stream of the file (e.g. a stimulator's triggers) whose "
        "samples become session markers, on the synchronised clock",
    )
    p.add_argument(
        "--partial",
        action="store_true",
        help="import what a cut-short file holds (LabRecorder stopped before finishing it)",
    )
    add_force(p, "OUT")
    add_quiet(p, "no progress or summary lines (notes are still shown)")
    p.epilog = "example: gaitmon import walk.xdf -o walk.h5 --markers-from Stimulator"


def run(args: argparse.Namespace) -> int:
    from gaitmon.commands.info import progress_printer
    from gaitmon.lsl.xdf_import import ImportOptions, import_xdf
    from gaitmon.text import count

    options = ImportOptions(unit=args.unit, markers_from=args.markers_from,
                            partial=bool(args.partial), overwrite=bool(args.force))  # fmt: skip
    result = import_xdf(
        args.file,
        args.output,
        options,
        progress=None if args.quiet else progress_printer("importing"),
    )
    for note in result.notes:
        print(f"gaitmon import: note: {note}", file=sys.stderr)
    if not args.quiet:
        print(
            f"gaitmon import: wrote {result.path} (unit {result.unit}, "
            f"{count(result.n_rows, 'frame')}, {result.duration_s:.1f} s, "
            f"{count(result.n_gaps, 'gap')} ({count(result.n_lost, 'frame')} lost), "
            f"{count(result.n_markers, 'marker')}, "
            f"{count(result.n_changes, 'settings change')})",
            file=sys.stderr,
        )
    return 0
