"""The one way to open a session by path: :func:`open_session` recovers an interrupted
recording first and gives a :class:`Session`, which computes what the file does not store.

The format (:mod:`gaitmon.io.session`) reads what a file stores; a raw session written before
``/smoothed`` existed (or whose stop could not store it) gets its smoothed angles computed here
on first read (:mod:`gaitmon.finish.smoothed`), and every reader gets the foot IMU's stride
measures here (:mod:`gaitmon.finish.strides`: stored in ``/strides`` when computed from exactly
these inputs, else computed).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import h5py
import numpy as np

from gaitmon.io.journal_files import journal_path
from gaitmon.io.session.h5file import _being_recorded, _short_error
from gaitmon.io.session.header import RecoveryNotSaved, SessionError
from gaitmon.io.session.opening import open_h5, read_stored, session_of, unit_session_of
from gaitmon.io.session.parts import BOTH_LEGS, SIDE_NAMES, parts_of
from gaitmon.io.session.reader import StoredSession

if TYPE_CHECKING:
    from collections.abc import Sequence

    from gaitmon.dsp.stride_length import StrideMeasures

Progress = Callable[[float], bool | None]


class Session(StoredSession):
    """A session file opened for reading (:class:`~gaitmon.io.session.reader.StoredSession`),
    with what the file does not store computed on demand: the smoothed angles of a raw
    session, and the stride measures of the foot IMU."""

    def __init__(
        self, path: Path, f: h5py.File | h5py.Group, problems: Sequence[str] = (), *,
        side: str = "",
    ) -> None:  # fmt: skip
        super().__init__(path, f, problems, side=side)
        # why the recovery of an interrupted recording could not be saved (a full disk): then
        # the journal's rows are read from memory, the journal is kept ("": nothing unsaved)
        self.recovery_not_saved = ""
        self._stride_cache: dict[bytes, StrideMeasures] = {}  # heel strikes -> their measures
        if not self._smoothed_method:
            from gaitmon.finish.smoothed import smoothed_method_label

            self._smoothed_method = smoothed_method_label()

    def _computed_smoothed(self) -> dict[str, np.ndarray]:
        from gaitmon.finish.smoothed import smoothed_from_file

        try:
            return smoothed_from_file(
                self._f, self.header.table, self.calibration, self.sample_rate_hz,
                self.raw_counts,
            )
        except (OSError, RuntimeError, ValueError, KeyError) as e:
            raise SessionError(
                f"{self.path.name} is damaged: cannot compute the smoothed angles "
                f"({_short_error(e)}); read the live ones (review: Angles > live)"
            ) from e

    def foot_stride_measures(
        self, heel_strike_idx: np.ndarray | None = None
    ) -> StrideMeasures | None:
        """Stride length and foot clearance (:class:`gaitmon.dsp.stride_length.StrideMeasures`)
        of the strides between ``heel_strike_idx`` (default: the recorded heel strikes), from
        the foot IMU: stored in ``/strides`` when computed from exactly these inputs, else
        computed (:mod:`gaitmon.finish.strides`); None without raw counts. The
        last two results are kept (review compares the recorded events with a reprocessing's),
        so analysing again with other exclusions costs nothing."""
        from gaitmon.finish.strides import StrideInputs, stride_measures_of

        if self.mode != "raw" or not self.n_samples:
            return None
        hs = np.asarray(self.heel_strike_idx if heel_strike_idx is None else heel_strike_idx,
                        dtype=np.int64)  # fmt: skip
        key = hs.tobytes()
        if key in self._stride_cache:
            return self._stride_cache[key]
        from gaitmon.io.session.rows import lost_before_from_gaps

        inputs = StrideInputs(self.n_samples, self.sample_rate_hz, self.header.table,
                              self.calibration, self.calibration_changes,
                              lost_before_from_gaps(self.gaps, self.n_samples))  # fmt: skip
        try:
            m = stride_measures_of(
                self._f, lambda a, b: self.read_range(a, b, ["raw/adc"])["raw/adc"], inputs, hs
            )
        except (OSError, RuntimeError, KeyError) as e:
            raise SessionError(
                f"{self.path.name} is damaged: cannot read the foot sensor's raw counts "
                f"({_short_error(e)})"
            ) from e
        # the newest before and this one (the recorded events and a reprocessing's), swapped
        # in whole, so that a reader on another thread never sees it change size
        self._stride_cache = {**dict(list(self._stride_cache.items())[-1:]), key: m}
        return m


def open_combined_h5(path: Path, progress: Progress | None = None) -> h5py.File:
    """A bilateral session's file, open for reading, after its parts (an interrupted
    recording's) are recovered and combined. Whether it is bilateral is the caller's check."""
    from gaitmon.finish.combine import finish_parts

    finish_parts(path, progress)
    if not path.exists():
        raise SessionError(f"{path.name} does not exist; check the file name and folder")
    return open_h5(path)


def open_session(
    path: str | os.PathLike[str],
    *,
    recover: bool = True,
    progress: Progress | None = None,
    side: str | None = None,
) -> Session:
    """Open a session for reading, first recovering it if a journal says it was interrupted.

    If the journal itself is unusable, the HDF5 file is opened as it is (flushed every 100 ms
    while recording) and :attr:`Session.problems` says so.

    A bilateral file (both legs, ``gaitmon.finish.bilateral``) is opened one unit at a
    time: ``side="L"`` or ``"R"`` gives that leg's session; without a side it is refused with
    a one-line message rather than silently giving one leg.
    """
    path = Path(path)
    if side is not None:
        return _open_unit(path, side, progress)
    jpath = journal_path(path)
    if jpath.exists() and recover:
        if _being_recorded(jpath):
            raise SessionError(
                f"{path.name} is being recorded right now; open it after the recording stops"
            )
        if path.exists():
            # a clean stop or a finished recovery only had the journal's deletion left to do
            done = False
            with contextlib.suppress(SessionError), read_stored(path) as s:
                done = s.complete or s.recovered
            if done:
                jpath.unlink()
        if jpath.exists():
            from gaitmon.finish.recovery import (  # only when needed
                recover_in_memory,
                recover_session,
            )

            try:
                recover_session(path, progress)
            except SessionError as e:
                # e.g. a full disk: read what the journal holds from memory, so a reader gets
                # every row the recorder said was saved, right away (the file's own rows can
                # stop short of them, in datasets of different lengths)
                why = e.why if isinstance(e, RecoveryNotSaved) else str(e)
                advice = "free some disk space and " if isinstance(e, RecoveryNotSaved) else ""
                with contextlib.suppress(SessionError):
                    f = recover_in_memory(path)
                    opened = session_of(path, f, Session, [
                        f"the recovery could not be saved ({why}): its rows are read from the "
                        f"journal in memory, and the journal is kept; {advice}open it again to "
                        "save it"])  # fmt: skip
                    opened.recovery_not_saved = why
                    return opened
                if not path.exists():
                    raise
                opened = _read(path, [f"not recovered: {e}"])  # the file's last flush, as is
                if isinstance(e, RecoveryNotSaved):
                    opened.recovery_not_saved = e.why
                return opened
    elif not path.exists():
        if parts_of(path):  # an interrupted bilateral recording
            raise SessionError(BOTH_LEGS.format(name=path.name))
        raise SessionError(f"{path.name} does not exist; check the file name and folder")
    return _read(path)


def _read(path: Path, problems: Sequence[str] = ()) -> Session:
    return session_of(path, open_h5(path), Session, problems)


def _open_unit(path: Path, side: str, progress: Progress | None) -> Session:
    """One leg of a bilateral session (its parts recovered and combined first if the recording
    was interrupted)."""
    if side not in SIDE_NAMES:
        raise SessionError(f"side must be L or R, got {side!r}")
    return unit_session_of(path, open_combined_h5(path, progress), side, Session)
