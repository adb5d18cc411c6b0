"""``gaitmon process FILE -o NEW``: re-run the pipeline offline from the raw counts.

The original file is never modified: NEW is a copy whose ``/processed`` series, ``/events`` and
``/config`` come from the new settings. The settings given apply to the whole recording;
standing calibrations logged during it are replayed at their rows. The work itself is
:func:`gaitmon.io.session.reprocess.rewrite_processed`; this module only turns the command line
into a :class:`PipelineConfig` and prints.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.commands import add_force, add_quiet, refuse_both_legs
from gaitmon.errors import UserError
from gaitmon.reprocessing import (
    FSR_MAX_COUNTS,
    METHODS,
    PAPER_ONLY,
    SETTINGS,
    Reprocessing,
    check_settings,
    option,
)

if TYPE_CHECKING:
    from gaitmon.io.session import Session

# the settings and their checks are gaitmon.reprocessing's, shared with ``gaitmon batch``
__all__ = ["FSR_MAX_COUNTS", "PAPER_ONLY", "SETTINGS", "add_settings_arguments", "check_settings",
           "reprocessing_from_args"]  # fmt: skip


def add_settings_arguments(p: argparse.ArgumentParser, default: str = "as recorded") -> None:
    """The settings options (``--cutoff-hz`` ... ``--method``), as ``process`` and ``batch``
    take them."""
    for name, help_text in SETTINGS.items():
        p.add_argument(
            option(name),
            type=float,
            default=None,
            help=f"{help_text}; default: {default}",
        )
    p.add_argument(
        "--method",
        choices=METHODS,
        default=None,
        help="tilt filter: gait-aware (default for new recordings) or paper ('Kalman (paper, "
        f"seed 000)'); default: {default}",
    )


def reprocessing_from_args(
    args: argparse.Namespace, base: Reprocessing | None = None
) -> Reprocessing:
    """The settings options as a checked :class:`Reprocessing`; each option given overrides
    ``base`` (``batch --settings``)."""
    changes = dict(base.changes) if base is not None else {}
    changes.update({k: getattr(args, k) for k in SETTINGS if getattr(args, k) is not None})
    method = args.method if args.method is not None else (base.method if base else None)
    return Reprocessing.of(changes, method)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="a raw-mode session file (.h5)")
    p.add_argument("-o", "--output", required=True, metavar="NEW", help="the new session file")
    add_settings_arguments(p)
    add_force(p, "NEW")
    add_quiet(p, "no progress or summary lines (warnings are still shown)")


def run(args: argparse.Namespace) -> int:
    from gaitmon.commands.info import progress_printer
    from gaitmon.io.session import SessionError, open_session
    from gaitmon.io.session.reprocess import recorded_config, rewrite_processed

    src, dst = Path(args.file), Path(args.output)
    refuse_both_legs(src, "process")
    if dst.exists() and dst.resolve() == src.resolve():
        raise UserError("NEW must be a different file: the original recording is never modified")
    if dst.exists() and not args.force:
        raise UserError(f"{dst} already exists; choose another name or pass --force")
    if not dst.parent.is_dir():
        raise UserError(f"folder {dst.parent} does not exist")
    settings = reprocessing_from_args(args)
    changes = dict(settings.changes)
    quiet = bool(args.quiet)
    try:
        recorded = recorded_config(src, progress=None if quiet else progress_printer("recovering"))
        config = settings.apply(recorded)
        result = rewrite_processed(
            src, dst, config, progress=None if quiet else progress_printer("reprocessing"),
            overwrite=args.force,
        )
        with open_session(src, recover=False) as before, open_session(dst) as after:
            n_before, n_after = len(before.heel_strike_idx), len(after.heel_strike_idx)
            after_method = after.angle_method
            stuck = [name for name in ("heel", "toe") if _switches(before, name)
                     and not _switches(after, name)]  # fmt: skip
    except SessionError as exc:
        raise UserError(str(exc)) from None
    settings_text = ", ".join(f"{k}={v:g}" for k, v in changes.items()) or (
        "the recorded settings")
    if not quiet:
        print(f"gaitmon process: wrote {dst} ({result.n_frames} frames, {n_after} heel "
              f"strikes) with {settings_text}; angles: {after_method} "
              f"(live: {config.tilt_method_label})",
              file=sys.stderr)
    if stuck:  # the FSR check then takes the events from the foot gyro
        print(
            f"gaitmon process: warning: with {settings_text} the {' and '.join(stuck)} "
            f"sensor{'s' if len(stuck) > 1 else ''} never switch between loaded and unloaded "
            f"in {dst.name}, so the gait events come from the foot gyro; check --fsr-threshold "
            "and --cutoff-hz",
            file=sys.stderr,
        )
    elif n_after < 2 <= n_before:  # settings that run but find no strides are almost always wrong
        print(
            f"gaitmon process: warning: {dst.name} has {n_after} heel strikes with {settings_text} "
            f"(the recording has {n_before}), so no strides; check --fsr-threshold and "
            "--cutoff-hz",
            file=sys.stderr,
        )
    return 0


def _switches(session: Session, sensor: str) -> bool:
    """Whether the heel or toe sensor switches between loaded and unloaded in a session's
    processed contacts as a walking foot does (a sensor stuck either way, or switching only
    once as the filters start, gives no gait events)."""
    path = f"processed/{sensor}_loaded"
    if path not in session.dataset_names:
        return False
    loaded = session.read(path).astype(np.int8)
    return int(np.count_nonzero(np.diff(loaded))) >= 4  # two steps' worth of contacts
