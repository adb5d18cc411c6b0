"""``gaitmon process FILE -o NEW``: re-run the pipeline offline from the raw counts.

The original file is never modified: NEW is a copy whose ``/processed`` series, ``/events`` and
``/config`` come from the new settings. A session of both legs is reprocessed unit by unit
(:mod:`gaitmon.finish.reprocess_both`): into a file of both legs, or with ``--side`` one
leg into a one-unit file. The settings given apply to the whole recording;
standing calibrations logged during it are replayed at their rows. The work itself is
:func:`gaitmon.finish.reprocess.rewrite_processed`; this module only turns the command line
into a :class:`PipelineConfig` and prints.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gaitmon.commands import add_force, add_quiet
from gaitmon.errors import UserError
from gaitmon.reprocessing import (
    FSR_MAX_COUNTS,
    PAPER_ONLY,
    SETTINGS,
    Reprocessing,
    check_settings,
    option,
)

if TYPE_CHECKING:
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.finish import Session

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
    from gaitmon.dsp.methods import DEFAULT_METHOD, live_names, method_label

    offered = live_names()  # (the registry's declarations: no method's module is imported)
    p.add_argument(
        "--method",
        choices=offered,
        default=None,
        help="tilt filter: " + " or ".join(
            f"{name} (default for new recordings)" if name == DEFAULT_METHOD
            else f"{name} ('{method_label(name)}')" for name in offered
        ) + f"; default: {default}",
    )  # fmt: skip


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
    p.add_argument(
        "--side",
        choices=("L", "R"),
        default="",
        help="of a session of both legs: reprocess this leg only, into a one-unit file "
        "(default: both legs, into a file of both legs)",
    )
    add_settings_arguments(p)
    add_force(p, "NEW")
    add_quiet(p, "no progress or summary lines (warnings are still shown)")


def run(args: argparse.Namespace) -> int:
    from gaitmon.commands.info import progress_printer
    from gaitmon.finish import open_session
    from gaitmon.finish.reprocess import UnitInputs, rewrite_processed
    from gaitmon.io.session import SessionError
    from gaitmon.io.session.parts import is_bilateral

    src, dst = Path(args.file), Path(args.output)
    both = is_bilateral(src)
    if args.side and not both:
        raise UserError(f"{src.name} records one unit; leave --side out")
    if dst.exists() and dst.resolve() == src.resolve():
        raise UserError("NEW must be a different file: the original recording is never modified")
    if dst.exists() and not args.force:
        raise UserError(f"{dst} already exists; choose another name or pass --force")
    if not dst.parent.is_dir():
        raise UserError(f"folder {dst.parent} does not exist")
    settings = reprocessing_from_args(args)
    changes = dict(settings.changes)
    quiet = bool(args.quiet)
    settings_text = ", ".join(f"{k}={v:g}" for k, v in changes.items()) or (
        "the recorded settings")
    done: list[str] = []
    warnings: list[str] = []
    try:
        if both:
            from gaitmon.finish.reprocess_both import rewrite_bilateral

            results = rewrite_bilateral(
                src, dst, settings.apply, side=args.side or None, overwrite=args.force,
                progress=None if quiet else progress_printer("reprocessing"),
            )  # fmt: skip
            for side, result in results.items():
                with open_session(src, side=side) as before, open_session(
                    dst, side=None if args.side else side
                ) as after:
                    label = f"{dst.name} ({side})"
                    done.append(_done(side + ": ", result.n_frames, after, result.config))
                    warnings += _warnings(_Contacts.of(before), _Contacts.of(after), label,
                                          settings_text)  # fmt: skip
        else:
            # (an interrupted recording is recovered first; the settings it was recorded with)
            with open_session(src, progress=None if quiet else progress_printer("recovering")
                              ) as s:  # fmt: skip
                unit, contacts = UnitInputs.of(s), _Contacts.of(s)  # (checks the raw counts)
            config = settings.apply(unit.config)
            result = rewrite_processed(
                src, dst, config, progress=None if quiet else progress_printer("reprocessing"),
                overwrite=args.force, unit=unit,
            )
            with open_session(dst) as after:
                done.append(_done("", result.n_frames, after, config))
                warnings += _warnings(contacts, _Contacts.of(after), dst.name, settings_text)
    except SessionError as exc:
        raise UserError(str(exc)) from None
    if not quiet:
        what = f"the {args.side} leg of {src.name}, as one unit" if args.side else (
            ("both legs" if len(done) == 2 else "the one leg the file holds") if both else "")
        print(f"gaitmon process: wrote {dst}{f' ({what})' if what else ''} with {settings_text}; "
              + "; ".join(done), file=sys.stderr)  # fmt: skip
    for line in warnings:
        print(f"gaitmon process: warning: {line}", file=sys.stderr)
    return 0


def _done(label: str, n_frames: int, after: Session, config: PipelineConfig) -> str:
    return (f"{label}{n_frames} frames, {len(after.heel_strike_idx)} heel strikes, angles: "
            f"{after.angle_method} (live: {config.tilt_method_label})")  # fmt: skip


@dataclass(frozen=True)
class _Contacts:
    """What :func:`_warnings` compares of a session before and after: its heel strikes, and
    which force sensors switch between loaded and unloaded as a walking foot's do."""

    heel_strikes: int
    switching: frozenset[str]

    @classmethod
    def of(cls, session: Session) -> _Contacts:
        return cls(len(session.heel_strike_idx),
                   frozenset(s for s in ("heel", "toe") if _switches(session, s)))  # fmt: skip


def _warnings(before: _Contacts, after: _Contacts, name: str, settings_text: str) -> list[str]:
    """Settings that run but leave the events to the foot gyro, or find no strides."""
    n_before, n_after = before.heel_strikes, after.heel_strikes
    stuck = [sensor for sensor in ("heel", "toe") if sensor in before.switching
             and sensor not in after.switching]  # fmt: skip
    if stuck:  # the FSR check then takes the events from the foot gyro
        return [
            f"with {settings_text} the {' and '.join(stuck)} "
            f"sensor{'s' if len(stuck) > 1 else ''} never switch between loaded and unloaded "
            f"in {name}, so the gait events come from the foot gyro; check --fsr-threshold "
            "and --cutoff-hz"
        ]
    if n_after < 2 <= n_before:  # settings that run but find no strides are almost always wrong
        return [
            f"{name} has {n_after} heel strikes with {settings_text} (the recording has "
            f"{n_before}), so no strides; check --fsr-threshold and --cutoff-hz"
        ]
    return []


def _switches(session: Session, sensor: str) -> bool:
    """Whether the heel or toe sensor switches between loaded and unloaded in a session's
    processed contacts as a walking foot does (a sensor stuck either way, or switching only
    once as the filters start, gives no gait events)."""
    path = f"processed/{sensor}_loaded"
    if path not in session.dataset_names:
        return False
    loaded = session.read(path).astype(np.int8)
    return int(np.count_nonzero(np.diff(loaded))) >= 4  # two steps' worth of contacts
