"""``gaitmon export``: write a recorded session as CSV, MATLAB .mat, C3D or a BIDS dataset."""

from __future__ import annotations

import argparse
import sys
import time

from gaitmon.commands import (
    Progress,
    add_force,
    add_quiet,
    add_side,
    check_side,
    damaged_file_guard,
)
from gaitmon.errors import UserError
from gaitmon.export.registry import FORMATS

DESCRIPTION = """\
Export a recorded session (.h5) to CSV (+ a .meta.json side file), a MATLAB v5 .mat file
(struct `session`, 1-based indices), C3D (angles as POINTs, raw channels as ANALOGs in
physical units, Foot Strike / Foot Off events) or a Motion-BIDS dataset folder (-o DIR; one
export adds one recording). A session of both legs without --side: both legs and the
bilateral measures (docs/bilateral.md, "Exports"). Layouts: docs/file-format.md, "Export
formats".
"""

EPILOG = """\
examples:
  gaitmon export walk.h5 --format csv              # walk.csv + walk.meta.json
  gaitmon export walk.h5 --format mat -o out/walk.mat
  gaitmon export walk.h5 --format c3d --deidentify # walk.c3d (walk_part001.c3d ... if > 10 min)
  gaitmon export walk.h5 --format bids -o study --subject 01 --session pre
  gaitmon export walk.h5 --format bids -o study --subject-map subjects.tsv
  gaitmon export both.h5 --format csv              # both legs: both_L.csv, both_R.csv,
                                                   # both_bilateral.csv, both_symmetry.csv
"""

# --format bids only: option -> its name in export_session(options=...)
BIDS_OPTIONS = ("subject", "subject_map", "subject_from_patient_id", "session", "task",
                "authors", "license")

# Progress is shown only for sessions long enough for the wait to be noticeable.
PROGRESS_MIN_SAMPLES = 100_000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.description = DESCRIPTION
    parser.epilog = EPILOG
    parser.add_argument("file", metavar="FILE", help="session file (.h5)")
    add_side(parser)
    parser.add_argument("--format", required=True, choices=tuple(FORMATS),
                        help="output format: " + "; ".join(
                            f"{f.name}: {f.description}" for f in FORMATS.values()))
    parser.add_argument("-o", "--output", metavar="OUT",
                        help="output file, or folder for bids (default: FILE with the format's "
                        "extension; bids: FILE-bids)")
    parser.add_argument("--deidentify", action=argparse.BooleanOptionalAction, default=None,
                        help="leave out patient id, operator, notes, serial and recording date "
                        "(the data are kept); default: on for bids, off for the others")
    parser.add_argument("--angles", choices=("smoothed", "live"), default="smoothed",
                        help="tilt and joint angles: smoothed (zero-lag offline estimate, the "
                        "default) or live (the causal filter's, as shown while recording)")
    bids = parser.add_argument_group("BIDS (--format bids)")
    who = bids.add_mutually_exclusive_group()
    who.add_argument("--subject", metavar="LABEL",
                     help="subject label, letters and digits (default 01)")
    who.add_argument("--subject-map", metavar="MAP.tsv",
                     help="file of patient id <TAB> subject label rows: the label of this "
                     "session's patient is looked up in it")
    who.add_argument("--subject-from-patient-id", action="store_true", default=None,
                     help="use the patient id itself as the subject label (identifies the "
                     "patient; never done otherwise)")
    bids.add_argument("--session", metavar="LABEL", help="session label (ses-LABEL level)")
    bids.add_argument("--task", metavar="LABEL", help="task label (default walk)")
    bids.add_argument("--bids-authors", dest="authors", metavar="'A. Author; B. Author'",
                      help="the dataset's authors, ';' between them (dataset_description.json "
                      "of a new dataset; left out if not given)")
    bids.add_argument("--bids-license", dest="license", metavar="LICENSE",
                      help="the dataset's licence, e.g. CC0 or CC-BY-4.0 (as --bids-authors)")
    add_force(parser, "existing output files")
    add_quiet(parser)


def run(args: argparse.Namespace) -> int:
    from gaitmon.export import ExportError, export_session, session_length
    from gaitmon.io.session.parts import is_bilateral

    both = args.side is None and is_bilateral(args.file)  # both legs are exported
    if not both:
        check_side(args.file, args.side)
    t0 = time.perf_counter()
    progress = None
    options = {k: getattr(args, k) for k in BIDS_OPTIONS if getattr(args, k) is not None}
    if options and args.format != "bids":
        given = ", ".join("--" + k.replace("_", "-") for k in options)
        raise UserError(f"{given}: only for --format bids")
    try:
        with damaged_file_guard(args.file):
            rows = session_length(args.file, "L" if both else args.side)
            if not args.quiet and rows >= PROGRESS_MIN_SAMPLES:
                progress = Progress(f"exporting {args.format}")
            # a bilateral file without --side: both legs and the bilateral measures
            result = export_session(
                args.file, args.format, args.output,
                deidentify=args.deidentify, force=args.force, progress=progress,
                angles=args.angles, options=options or None, side=args.side,
            )
    except (ExportError, UserError) as exc:
        if progress is not None and progress.shown and progress.tty:
            sys.stderr.write("\n")
        raise UserError(str(exc)) from None
    for problem in result.problems:
        print(f"gaitmon export: warning: {args.file}: {problem}", file=sys.stderr)
    if args.format == "bids" and not args.quiet:
        from gaitmon.export.writers.bids_dataset import description_hint

        root = [p.parent for p in result.paths if p.name == "participants.tsv"]
        hint = description_hint(root[0]) if root else None
        if hint:
            print(f"gaitmon export: note: {hint}", file=sys.stderr)
    if not args.quiet:
        names = ", ".join(str(p) for p in result.paths[:3])
        more = f" (+{len(result.paths) - 3} more)" if len(result.paths) > 3 else ""
        print(
            f"exported {result.amount} ({result.mode or 'unknown'} mode) to "
            f"{names}{more} in {time.perf_counter() - t0:.1f} s"
        )
    return 0
