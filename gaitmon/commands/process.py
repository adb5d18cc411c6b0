"""``gaitmon process FILE -o NEW``: re-run the pipeline offline from the raw counts.

The original file is never modified: NEW is a copy whose ``/processed`` series, ``/events`` and
``/config`` come from the new settings. The settings given apply to the whole recording;
standing calibrations logged during it are replayed at their rows. The work itself is
:func:`gaitmon.io.session.reprocess.rewrite_processed`; this module only turns the command line
into a :class:`PipelineConfig` and prints.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.commands import add_force, add_quiet
from gaitmon.errors import UserError

if TYPE_CHECKING:
    from gaitmon.io.session import Session

# command-line option -> PipelineConfig field
SETTINGS = {
    "cutoff_hz": "low-pass cut-off (Hz)",
    "q_angle": "Kalman Q_angle",
    "q_gyro": "Kalman Q_gyro",
    "r": "Kalman R (accelerometer tilt variance)",
    "fsr_threshold": "FSR contact threshold (ADC counts)",
}
# settings that only the paper's filter reads: given with the gait-aware filter they would
# silently change nothing
PAPER_ONLY = ("q_angle", "q_gyro", "r")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="a raw-mode session file (.h5)")
    p.add_argument("-o", "--output", required=True, metavar="NEW", help="the new session file")
    for name, help_text in SETTINGS.items():
        p.add_argument(
            f"--{name.replace('_', '-')}",
            type=float,
            default=None,
            help=f"{help_text}; default: as recorded",
        )
    p.add_argument(
        "--method",
        choices=("gait-aware", "paper"),
        default=None,
        help="tilt filter: gait-aware (default for new recordings) or paper ('Kalman (paper, "
        "seed 000)'); default: as recorded",
    )
    add_force(p, "NEW")
    add_quiet(p, "no progress or summary lines (warnings are still shown)")


# The FSR channels are 12-bit ADC counts: a threshold at or above the top is never crossed.
FSR_MAX_COUNTS = 4095


def check_settings(changes: dict[str, float]) -> None:
    """Reject settings that cannot work, one line naming the option (the pipeline's own checks
    follow, for the combinations only it knows, such as a cut-off above Nyquist)."""
    for name, value in changes.items():
        opt = f"--{name.replace('_', '-')}"
        if not math.isfinite(value):
            raise UserError(f"{opt} must be a number, got {value:g}")
        if value <= 0:
            raise UserError(f"{opt} must be above 0, got {value:g}")
    t = changes.get("fsr_threshold")
    if t is not None and t >= FSR_MAX_COUNTS:
        raise UserError(
            f"--fsr-threshold must be above 0 and below {FSR_MAX_COUNTS} counts (the 12-bit "
            f"ADC's top, never crossed), got {t:g}"
        )


def run(args: argparse.Namespace) -> int:
    from gaitmon.commands.info import progress_printer
    from gaitmon.io.session import SessionError, open_session
    from gaitmon.io.session.reprocess import recorded_config, rewrite_processed

    src, dst = Path(args.file), Path(args.output)
    if dst.exists() and dst.resolve() == src.resolve():
        raise UserError("NEW must be a different file: the original recording is never modified")
    if dst.exists() and not args.force:
        raise UserError(f"{dst} already exists; choose another name or pass --force")
    if not dst.parent.is_dir():
        raise UserError(f"folder {dst.parent} does not exist")
    changes = {k: getattr(args, k) for k in SETTINGS if getattr(args, k) is not None}
    check_settings(changes)
    quiet = bool(args.quiet)
    choices: dict[str, object] = {}
    if args.method is not None:
        choices["tilt_method"] = args.method
    try:
        recorded = recorded_config(src, progress=None if quiet else progress_printer("recovering"))
        try:
            config = recorded.replace(**changes, **choices)
            paper_only = [f"--{k.replace('_', '-')}" for k in PAPER_ONLY if k in changes]
            if paper_only and config.tilt_method != "paper":
                raise UserError(
                    f"{', '.join(paper_only)} tune the paper's Kalman filter, which this "
                    f"reprocessing does not use ({config.tilt_method_label}); add --method paper"
                )
        except ValueError as exc:
            raise UserError(f"bad setting: {exc}") from None
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
    settings = ", ".join(f"{k}={v:g}" for k, v in changes.items()) or "the recorded settings"
    if not quiet:
        print(f"gaitmon process: wrote {dst} ({result.n_frames} frames, {n_after} heel "
              f"strikes) with {settings}; angles: {after_method} "
              f"(live: {config.tilt_method_label})",
              file=sys.stderr)
    if stuck:  # the FSR check then takes the events from the foot gyro
        print(
            f"gaitmon process: warning: with {settings} the {' and '.join(stuck)} "
            f"sensor{'s' if len(stuck) > 1 else ''} never switch between loaded and unloaded "
            f"in {dst.name}, so the gait events come from the foot gyro; check --fsr-threshold "
            "and --cutoff-hz",
            file=sys.stderr,
        )
    elif n_after < 2 <= n_before:  # settings that run but find no strides are almost always wrong
        print(
            f"gaitmon process: warning: {dst.name} has {n_after} heel strikes with {settings} "
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
