"""``gaitmon batch DIR -o OUT``: reprocess every session of a study, on a process pool or Dask.

The work is :func:`gaitmon.batch.run_batch`; this module turns the command line into its
arguments (the settings exactly as ``gaitmon process`` takes them) and prints.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.commands import Progress, add_quiet
from gaitmon.commands.process import add_settings_arguments, reprocessing_from_args
from gaitmon.errors import UserError

if TYPE_CHECKING:
    from gaitmon.reprocessing import Reprocessing

DESCRIPTION = """\
Reprocess every session (*.h5, recursively) under DIR with the given settings, or each file's
own, into OUT with the same layout, and write OUT/summary.csv (one row per session: patient,
date, duration, strides, every summary measure, the angles method, ok/damaged/skipped and why)
and OUT/strides.csv (one row per stride, as the review window's stride table). A damaged file
is a row in the summary, never the end of the batch. A rerun skips the sessions already done
with the same settings (delete an output to have it done again).
"""

EPILOG = """\
examples:
  gaitmon batch study/ -o study-4hz/ --cutoff-hz 4           # a local process pool
  gaitmon batch study/ -o study-paper/ --settings '{"method": "paper", "r": 0.1}'
  gaitmon batch study/ -o shared/ --deidentify --jobs 2     # key in shared.gaitmon-key/
  gaitmon batch study/ -o out/ --dask tcp://scheduler:8786  # on a Dask distributed cluster
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.description = DESCRIPTION
    p.epilog = EPILOG
    p.add_argument("dir", metavar="DIR", help="folder of session files (searched recursively)")
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="folder for the new files and the two CSVs")
    p.add_argument("--settings", metavar="JSON",
                   help='settings as a JSON object ({"cutoff_hz": 4, "method": "paper"}) or a '
                   "file holding one; options given beside it win")
    add_settings_arguments(p, default="each file's own")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="worker processes (default: the number of cores)")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="run on an existing Dask distributed cluster (its scheduler's address, "
                   "e.g. tcp://host:8786); needs pip install 'gaitmon[dask]'")
    p.add_argument("--deidentify", action="store_true",
                   help="nothing in OUT names a patient or dates a recording: the CSVs carry "
                   "numbered labels (S0001, P001) instead of file names and patient ids, the "
                   "sessions are written as OUT/S0001.h5 ... without patient id, operator, "
                   "notes, serial or date, and the key (labels to files and patients, and the "
                   "resume records) goes to OUT.gaitmon-key beside OUT: keep it, share OUT")
    add_quiet(p)


def _base_settings(text: str | None) -> Reprocessing | None:
    from gaitmon.reprocessing import from_json

    if text is None:
        return None
    if not text.lstrip().startswith(("{", "[")):  # else a file that holds the JSON
        path = Path(text)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise UserError(
                f"--settings {path}: cannot read it ({exc.strerror or exc}); give a JSON "
                'file or an object such as \'{"cutoff_hz": 4}\''
            ) from None
    return from_json(text)


def run(args: argparse.Namespace) -> int:
    from gaitmon.batch import run_batch
    from gaitmon.batch_tables import DAMAGED, OK, SKIPPED, labels, scrub_reason

    base = _base_settings(args.settings)
    settings = reprocessing_from_args(args, base)
    given = settings.changes or settings.method is not None
    jobs = args.jobs if args.jobs is not None else (os.cpu_count() or 1)
    if jobs < 1:
        raise UserError(f"--jobs must be 1 or more, got {jobs}")
    progress = None if args.quiet else Progress("reprocessing")
    result = run_batch(
        args.dir, args.output, settings if given else None, jobs=jobs, dask=args.dask,
        deidentify=args.deidentify, progress=progress,
    )  # fmt: skip
    if progress is not None and progress.shown and progress.tty and progress.last < 100:
        sys.stderr.write("\n")
    # de-identified, a log of the run names sessions by their labels too (the key has the rest)
    names, _ = labels(result.outcomes, args.deidentify)
    for o, name in zip(result.outcomes, names, strict=True):
        if o.status != OK:
            reason = scrub_reason(o, name, args.dir) if args.deidentify else o.reason
            print(f"gaitmon batch: {o.status}: {name}: {reason}", file=sys.stderr)
    if not args.quiet:
        n = len(result.outcomes)
        how = settings.describe() if given else "each file's own settings"
        print(
            f"gaitmon batch: {n} sessions ({result.count(OK)} ok, {result.count(DAMAGED)} "
            f"damaged, {result.count(SKIPPED)} skipped; {result.n_resumed} already done) with "
            f"{how} in "
            f"{result.elapsed_s:.1f} s; wrote {result.summary_csv} and {result.strides_csv}"
            + (f"; the key (keep it, do not share it) is in {result.key}" if result.key else ""),
            file=sys.stderr,
        )
    return 0
