"""Opening a session file as it is: the HDF5 file with the reader's chunk cache, and a session
reader over it (or over one leg's group of a file of both legs), every failure one
:class:`~gaitmon.io.session.header.SessionError` line.

No recovery here and nothing computed: :func:`gaitmon.finish.open_session` recovers an
interrupted recording first and gives a session that computes what the file does not store.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TypeVar

import h5py

from gaitmon.io.session.h5file import _short_error
from gaitmon.io.session.header import SessionError
from gaitmon.io.session.layout import READER_CHUNK_CACHE_BYTES
from gaitmon.io.session.parts import SIDE_NAMES
from gaitmon.io.session.reader import StoredSession
from gaitmon.io.session.series import attr_text
from gaitmon.io.session.trust import check_file

S = TypeVar("S", bound=StoredSession)


def open_h5(path: Path) -> h5py.File:
    """``path`` open read-only with the reader's chunk cache; a file that is no session (a
    folder, an empty file, not HDF5) or a damaged one is said in one line, and so is one that
    would read from outside itself or declares more data than it holds
    (:func:`gaitmon.io.session.trust.check_file`: every session is opened here)."""
    try:
        f = h5py.File(path, "r", rdcc_nbytes=READER_CHUNK_CACHE_BYTES, rdcc_nslots=1021)
    except (OSError, RuntimeError, ValueError) as e:
        why = _short_error(e)
        if path.is_dir():
            why = "a folder"
        elif path.exists() and path.stat().st_size == 0:
            why = "an empty file"
        elif why == "not an HDF5 file":
            pass
        else:
            raise SessionError(
                f"{path.name} is damaged and cannot be opened ({why}); "
                "pick another session file recorded by gaitmon"
            ) from e
        raise SessionError(
            f"{path.name} is not a gaitmon session ({why}); pick a session file recorded by gaitmon"
        ) from e
    try:
        check_file(path, f)
    except SessionError:
        f.close()
        raise
    except Exception as e:  # damaged metadata can fail in many ways inside h5py
        with contextlib.suppress(Exception):
            f.close()
        raise SessionError(f"{path.name} is damaged ({_short_error(e)})") from e
    return f


def read_stored(path: Path, problems: Sequence[str] = ()) -> StoredSession:
    """The session in ``path`` as it is stored (no recovery, nothing computed)."""
    return session_of(path, open_h5(path), StoredSession, problems)


def session_of(path: Path, f: h5py.File, cls: type[S], problems: Sequence[str] = ()) -> S:
    """A ``cls`` session over the open ``f`` (see :func:`built`)."""
    return built(path, f, lambda: cls(path, f, problems))


def built(path: Path, f: h5py.File, make: Callable[[], S]) -> S:
    """``make()``, a session over the open ``f``; on failure ``f`` is closed and the failure is
    one SessionError line."""
    try:
        return make()
    except SessionError:
        f.close()
        raise
    except Exception as e:  # damaged metadata can fail in many ways inside h5py/numpy
        with contextlib.suppress(Exception):
            f.close()
        raise SessionError(f"{path.name} is damaged ({_short_error(e)})") from e


def unit_session_of(path: Path, f: h5py.File, side: str, cls: type[S]) -> S:
    """One leg (``side``: L or R) of the file of both legs open in ``f``, as a ``cls`` session
    rooted at its group ``/units/<side>`` (closing it closes ``f``)."""

    def make() -> S:
        if not bool(f.attrs.get("bilateral", False)):
            raise SessionError(f"{path.name} holds one unit, not both legs; open it without a side")
        if f"units/{side}" not in f:
            sides = [s for s in str(attr_text(f.attrs.get("sides", ""))).split() if s in SIDE_NAMES]
            raise SessionError(
                f"{path.name} has no {SIDE_NAMES[side]} leg (it has "
                f"{' and '.join(SIDE_NAMES[s] for s in sides) or 'none'})"
            )
        return cls(path, f[f"units/{side}"], side=side)

    return built(path, f, make)


def stored_duration_s(path: str | Path) -> float | None:
    """A finished file's duration as ``gaitmon info`` reads it (its ``duration_s``), or None
    when the file cannot say (still being written, damaged, gone): the live window's "saved"
    line gives this, not the wall clock's time between Record and Stop."""
    try:
        with h5py.File(path, "r") as f:
            value = f.attrs.get("duration_s")
            return None if value is None else float(value)
    except (OSError, RuntimeError, ValueError, TypeError):
        return None
