"""Where a bilateral recording's parts live, and whether a path is a bilateral session.

While both legs are recorded, each unit writes an ordinary crash-safe recording of its own
beside the target: ``FILE.L.partial`` and ``FILE.R.partial`` (with their journals). At the stop
they are combined into ``FILE`` (:mod:`.combine`); a reader given ``FILE`` whose parts are still
beside it recovers and combines them first. No reader or writer here: the names only.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py

from gaitmon.io.journal import journal_path
from gaitmon.io.session.header import SessionError
from gaitmon.io.session.trust import check_file

SIDES = ("L", "R")
SIDE_NAMES = {"L": "left", "R": "right"}
# a bilateral file given where one unit is needed
BOTH_LEGS = (
    "{name} records both legs; pick one with --side L or --side R (gaitmon info shows both)"
)


def part_path(path: str | os.PathLike[str], side: str) -> Path:
    """Where one side's unit is recorded until the combine: ``FILE.<side>.partial``."""
    if side not in SIDES:
        raise ValueError(f"side must be L or R, got {side!r}")
    return Path(f"{os.fspath(path)}.{side}.partial")


def damaged_path(path: str | os.PathLike[str], side: str) -> Path:
    """Where a part that cannot be recovered is set aside, bytes untouched, for a specialist:
    ``FILE.<side>.partial.damaged`` (its journal beside it, ``….damaged.journal``)."""
    p = part_path(path, side)
    return p.with_name(p.name + ".damaged")


def parts_of(path: str | os.PathLike[str]) -> dict[str, Path]:
    """The parts left beside ``path`` (a part whose file or journal exists), by side."""
    out = {}
    for side in SIDES:
        p = part_path(path, side)
        if p.exists() or journal_path(p).exists():
            out[side] = p
    return out


def is_bilateral(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a bilateral session, or its parts beside it will make one."""
    p = Path(path)
    if not p.exists():
        return bool(parts_of(p))
    try:
        with h5py.File(p, "r") as f:
            check_file(p, f)  # a file from elsewhere: no attribute read before it is checked
            return bool(f.attrs.get("bilateral", False))
    except (OSError, RuntimeError, ValueError, SessionError):
        return False  # the reader that opens it next says why


def sides_of(path: str | os.PathLike[str]) -> tuple[str, ...]:
    """The legs a combined bilateral file holds, in file order (("L", "R") for both); () for a
    one-unit file, a missing one or one that cannot be read."""
    try:
        with h5py.File(path, "r") as f:
            check_file(Path(path), f)
            if not bool(f.attrs.get("bilateral", False)):
                return ()
            sides = f.attrs.get("sides", "")
            text = sides.decode() if isinstance(sides, bytes) else str(sides)
            return tuple(s for s in text.split() if s in SIDES and f"units/{s}" in f)
    except (OSError, RuntimeError, ValueError, SessionError):
        return ()
