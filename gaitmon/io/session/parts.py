"""Where a bilateral recording's parts live, whether a path is a bilateral session, and which
files make the session a path names (:func:`session_files`, :func:`sessions_in`).

While both legs are recorded, each unit writes an ordinary crash-safe recording of its own
beside the target: ``FILE.L.partial`` and ``FILE.R.partial`` (with their journals). At the stop
they are combined into ``FILE`` (:mod:`.combine`); a reader given ``FILE`` whose parts are still
beside it recovers and combines them first. No reader or writer here: the names only.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py

from gaitmon.errors import DAMAGE_ERRORS
from gaitmon.io.journal_files import JOURNAL_SUFFIX, journal_path
from gaitmon.io.session.header import SessionError
from gaitmon.io.session.series import attr_text
from gaitmon.io.session.trust import check_file

SIDES = ("L", "R")
# what h5py can raise reading a damaged file's root attributes (a zeroed object header gives
# KeyError, an attribute of a strange type TypeError) or the trust check refuses (SessionError):
# a probe answers "no", and the opening that follows says what is wrong in one line
PROBE_ERRORS: tuple[type[BaseException], ...] = (*DAMAGE_ERRORS, TypeError, SessionError)
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
    except PROBE_ERRORS:
        return False  # the reader that opens it next says why


def sides_of(path: str | os.PathLike[str]) -> tuple[str, ...]:
    """The legs a combined bilateral file holds, in file order (("L", "R") for both); () for a
    one-unit file, a missing one or one that cannot be read."""
    try:
        with h5py.File(path, "r") as f:
            check_file(Path(path), f)
            if not bool(f.attrs.get("bilateral", False)):
                return ()
            text = attr_text(f.attrs.get("sides", ""))
            return tuple(s for s in text.split() if s in SIDES and f"units/{s}" in f)
    except PROBE_ERRORS:
        return ()


SESSION_SUFFIXES = (".h5", ".hdf5")


def session_files(path: str | os.PathLike[str]) -> list[Path]:
    """The files that hold the session ``path``, as a reader opens it (recovering it first):
    the file itself, its journal (a recording interrupted, even one whose file was lost), the
    parts of an interrupted recording of both legs and their journals. Empty when no session
    has that name. The one rule for "does this session exist": ``info``, ``compare`` and
    ``batch`` all ask it."""
    p = Path(path)
    if p.is_dir():
        return []
    found = [q for q in (p, journal_path(p)) if q.is_file()]
    for part in parts_of(p).values():
        found += [q for q in (part, journal_path(part)) if q.is_file()]
    return found


def session_name(file: Path, suffixes: tuple[str, ...] = SESSION_SUFFIXES) -> Path | None:
    """The session a file of a folder belongs to (its own path, a journal's or a part's
    session), or None for a file of no session (an output being written, a part set aside as
    damaged, another program's file)."""
    name = file.name
    if name.endswith(JOURNAL_SUFFIX):
        name = name[: -len(JOURNAL_SUFFIX)]
    for side in SIDES:
        if name.endswith(f".{side}.partial"):
            name = name[: -len(f".{side}.partial")]
            break
    if not name.lower().endswith(suffixes):
        return None
    return file.with_name(name)


def sessions_in(
    folder: str | os.PathLike[str], *, recursive: bool = True,
    suffixes: tuple[str, ...] = SESSION_SUFFIXES,
) -> list[Path]:  # fmt: skip
    """Every session under ``folder`` (sorted, each once, by its file's path, which need not
    exist): a session file, a journal without its file, the parts of an interrupted recording
    of both legs; what :func:`session_files` calls a session."""
    root = Path(folder)
    found = set()
    for f in root.rglob("*") if recursive else root.iterdir():
        if f.is_file() and (s := session_name(f, suffixes)) is not None and not s.is_dir():
            found.add(s)
    return sorted(found)
