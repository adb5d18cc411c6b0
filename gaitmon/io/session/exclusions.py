"""User exclusions (e.g. a turn): part of a session's analysis state, kept in ``FILE.review.json``.

This module is their one owner: the review document changes them through :func:`write`, and
the document, ``gaitmon info``, ``gaitmon report`` and export all read them through :func:`read`
(:meth:`gaitmon.io.session.StoredSession.exclusions` calls it), so every report of one recording
leaves out the same strides. The recording itself is never modified. The side file holds row
ranges (and their times, for a human reader), plus the recording's ``created_utc`` and
``n_samples`` so that ranges written for another recording of the same name are not applied by
mistake. Written atomically (temporary file, then ``os.replace``).

When the recording's folder cannot be written (a read-only share, a write-protected card), the
same file goes to the user's gaitmon data folder instead (:func:`gaitmon.paths.user_data_dir`,
``exclusions`` in it: ``$XDG_DATA_HOME/gaitmon/exclusions``, by default
``~/.local/share/gaitmon/exclusions``, on Linux; under ``%LOCALAPPDATA%`` on Windows), named
after the recording and a hash of its full path; every reader looks there when there is no side
file, so the command line still sees what the review window kept.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from gaitmon import paths

if TYPE_CHECKING:
    import numpy as np

FORMAT = "gaitmon-review"
VERSION = 1


@dataclass(frozen=True)
class Exclusion:
    start_idx: int  # first row excluded
    stop_idx: int  # one past the last row excluded
    label: str = "excluded range"


class Keyed(Protocol):
    """What the exclusions of a recording (or of one leg of it) are kept by: an open session."""

    @property
    def exclusions_key(self) -> Path: ...  # FILE, or FILE.L / FILE.R for one leg
    @property
    def created_utc(self) -> str: ...
    @property
    def n_samples(self) -> int: ...


def read(rec: Keyed) -> tuple[list[Exclusion], str]:
    """(exclusions, problem) kept for ``rec``: the one reader of every caller (the review
    document, ``gaitmon info``, ``gaitmon report``, export)."""
    return load(rec.exclusions_key, rec.created_utc, rec.n_samples)


def write(
    rec: Keyed, ranges: Sequence[Exclusion], t_s: Sequence[float] | np.ndarray | None = None
) -> Path:
    """Keep ``ranges`` for ``rec`` (what :func:`read` gives back); returns the file written.
    Raises OSError when neither the recording's folder nor the user store can be written."""
    return save(rec.exclusions_key, ranges, rec.created_utc, rec.n_samples, t_s)


def side_path(path: str | os.PathLike[str]) -> Path:
    p = Path(path)
    return p.with_name(p.name + ".review.json")


def merge(ranges: list[Exclusion]) -> list[Exclusion]:
    """Sorted, with overlapping or touching ranges joined (labels of joined ranges kept once)."""
    out: list[Exclusion] = []
    for r in sorted(ranges, key=lambda r: (r.start_idx, r.stop_idx)):
        if out and r.start_idx <= out[-1].stop_idx:
            last = out[-1]
            label = last.label if r.label in last.label.split("; ") else f"{last.label}; {r.label}"
            out[-1] = Exclusion(last.start_idx, max(last.stop_idx, r.stop_idx), label)
        else:
            out.append(r)
    return out


def subtract(ranges: list[Exclusion], start: int, stop: int) -> list[Exclusion]:
    """The ranges with rows ``[start, stop)`` no longer excluded."""
    out: list[Exclusion] = []
    for r in ranges:
        if r.stop_idx <= start or r.start_idx >= stop:
            out.append(r)
            continue
        if r.start_idx < start:
            out.append(Exclusion(r.start_idx, start, r.label))
        if r.stop_idx > stop:
            out.append(Exclusion(stop, r.stop_idx, r.label))
    return out


def user_store_path(path: str | os.PathLike[str]) -> Path:
    """Where the exclusions go when the recording's folder cannot be written."""
    import hashlib  # only here (~3 ms): a reader of a recording without a user store needs none

    p = Path(path)
    key = hashlib.sha256(str(p.resolve()).encode("utf-8")).hexdigest()[:16]
    return _user_store() / f"{p.name}.{key}.review.json"


def _user_store() -> Path:
    return paths.user_data_dir() / "exclusions"


def stored_path(path: str | os.PathLike[str]) -> Path:
    """The file the recording's exclusions are read from: the user store when it holds them
    (it exists only while it is newer than the side file: writing the side file removes it),
    else the side file. Without a user store folder there is nothing to look up there."""
    if _user_store().is_dir():
        up = user_store_path(path)
        if up.exists():
            return up
    return side_path(path)


def load(
    path: str | os.PathLike[str], created_utc: str, n_samples: int
) -> tuple[list[Exclusion], str]:
    """(exclusions, problem): none stored is no exclusions and no problem."""
    sp = stored_path(path)
    try:
        text = sp.read_text(encoding="utf-8")
    except FileNotFoundError:
        return [], ""
    except (OSError, ValueError) as e:
        return [], f"{sp.name} is unreadable ({e}); exclusions not loaded"
    import json  # a side file to read (most recordings have none)

    try:
        doc = json.loads(text)
    except ValueError as e:
        return [], f"{sp.name} is unreadable ({e}); exclusions not loaded"
    try:
        if doc.get("format") != FORMAT:
            return [], f"{sp.name} is not a gaitmon review file; exclusions not loaded"
        rec = doc.get("recording", {})
        if rec.get("created_utc") != created_utc or int(rec.get("n_samples", -1)) != n_samples:
            return [], f"{sp.name} belongs to another recording; its exclusions were not applied"
        out = []
        for r in doc.get("excluded_ranges", []):
            a = max(0, int(r["start_idx"]))
            b = min(n_samples, int(r["stop_idx"]))
            if b > a:
                out.append(Exclusion(a, b, str(r.get("label", "excluded range"))))
        return merge(out), ""
    except (AttributeError, KeyError, TypeError, ValueError) as e:
        return [], f"{sp.name} is damaged ({e}); exclusions not loaded"


def save(
    path: str | os.PathLike[str],
    ranges: Sequence[Exclusion],
    created_utc: str,
    n_samples: int,
    t_s: Sequence[float] | np.ndarray | None = None,
) -> Path:
    """Keep the ranges (or forget them, when there are none); returns the file written.

    Beside the recording when its folder can be written, else in the user store. Raises
    OSError only when neither can be written."""
    items = []
    for r in ranges:
        item: dict[str, object] = {"start_idx": r.start_idx, "stop_idx": r.stop_idx,
                                   "label": r.label}  # fmt: skip
        if t_s is not None and r.stop_idx <= len(t_s):
            item["start_t_s"] = round(float(t_s[r.start_idx]), 3)
            item["stop_t_s"] = round(float(t_s[r.stop_idx - 1]), 3)
        items.append(item)
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "recording": {"file": Path(path).name, "created_utc": created_utc, "n_samples": n_samples},
        "excluded_ranges": items,
    }
    import json

    text = json.dumps(doc, indent=1) + "\n"
    sp, up = side_path(path), user_store_path(path)
    try:
        _write(sp, text if ranges else None)
    except OSError:
        # kept even when empty: "no ranges" must override a side file that cannot be changed
        up.parent.mkdir(parents=True, exist_ok=True)
        _write(up, text)
        return up
    with contextlib.suppress(OSError):  # the side file is the truth now
        up.unlink()
    return sp


def _write(target: Path, text: str | None) -> None:
    """Atomically replace ``target`` with ``text``; ``None`` removes it."""
    if text is None:
        with contextlib.suppress(FileNotFoundError):
            target.unlink()
        return
    tmp = target.with_name(target.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, target)
