"""gaitmon's public Python API: a recorded session as numpy arrays, or pandas DataFrames.

``gaitmon.open(path)`` (this module's :func:`open`, offered at the package's top level without
making ``import gaitmon`` any slower) opens a session file and gives its angles, events,
strides, gaps and markers. Every number is gaitmon's own: the angles are what the reader
decodes (``docs/file-format.md``), the strides are :func:`gaitmon.analysis.analyse_session`'s
rows (what ``gaitmon info``, the report and ``gaitmon export --format strides`` show, with the
exclusions stored beside the file), so a notebook and the clinic's report agree.

The examples use ``path``, a recorded one-leg session (the tests run them on the kept fixture
``tests/data/golden/one_leg.h5``)::

    >>> import gaitmon
    >>> rec = gaitmon.open(path)
    >>> rec
    <gaitmon recording one_leg.h5: left leg, mode raw, 2088 samples at 100 Hz (21.0 s)>
    >>> rec.close()

pandas is not one of gaitmon's dependencies: ``to_data_frame`` imports it when called, and
says in one line how to install it when it is missing.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon.dsp.channel_table import JOINT_TABLE, SEGMENTS

if TYPE_CHECKING:
    from types import TracebackType

    from gaitmon.finish import Session

#: the joint angles' names, in the order of :attr:`Angles.joint_deg`'s columns
JOINTS: tuple[str, ...] = tuple(f"{j.name}_{j.motion}" for j in JOINT_TABLE)
#: the segments, in the order of :attr:`Angles.tilt_deg`'s columns
SEGMENT_NAMES: tuple[str, ...] = SEGMENTS
ANGLE_KINDS = ("smoothed", "live")
_TABLES = ("angles", "events", "strides", "gaps", "markers")
_SIDES = {"L": "left", "R": "right"}


@dataclass(frozen=True)
class Angles:
    """Joint and segment angles of a session, in degrees, one row per recorded sample.

    Clinical sign conventions (also the file's ``angle_convention`` attribute):

    * segment tilts (``tilt_deg``: body, thigh, shank, foot) are sagittal, positive
      counter-clockwise seen from the subject's right side, zero in the upright standing
      calibration pose;
    * hip flexion + = thigh − body; knee flexion + = thigh − shank; ankle dorsiflexion + =
      foot − shank; every difference wrapped to (−180, 180].

    ``t_s`` is the true sample time from the session start (lost frames leave no row, so it
    may jump: see :meth:`Recording.gaps`). Missing values are NaN.
    """

    kind: str  #: "smoothed" (zero-lag, what gaitmon analyses) or "live" (the causal filter)
    method: str  #: the method that made them, e.g. "gait-aware Kalman + RTS smoother"
    t_s: np.ndarray  #: (N,) float64 seconds
    joint_deg: np.ndarray  #: (N, 3) float32: hip flexion, knee flexion, ankle dorsiflexion
    tilt_deg: np.ndarray | None  #: (N, 4) float32 body, thigh, shank, foot; None in mode joint
    joint_names: tuple[str, ...] = JOINTS
    segment_names: tuple[str, ...] = SEGMENT_NAMES


@dataclass(frozen=True)
class Events:
    """Gait events as row indices into the per-sample series (0-based) and as times."""

    heel_strike_idx: np.ndarray  #: (k,) int64
    toe_off_idx: np.ndarray  #: (m,) int64
    heel_strike_s: np.ndarray  #: (k,) float64, the true time of each heel strike
    toe_off_s: np.ndarray  #: (m,) float64


class Recording:
    """One leg's recorded session, open for reading (use as a context manager, or
    :meth:`close`). Made by :func:`open`.

    >>> with gaitmon.open(path) as rec:
    ...     print(rec.side, rec.mode, rec.sample_rate_hz, rec.n_samples)
    L raw 100.0 2088

    :attr:`session` is the underlying :class:`gaitmon.finish.Session` (every series the file
    holds, by name: ``session.read("processed/acc_ms2")``).
    """

    def __init__(self, session: Session) -> None:
        self.session = session
        self.path: Path = session.path
        #: "L", "R" or "" (one leg of unknown side)
        self.side: str = session.unit_side or session.meta.side
        self.mode: str = session.mode  #: "raw", "tilt" or "joint" (docs/file-format.md)
        self.sample_rate_hz: float = session.sample_rate_hz
        self.n_samples: int = session.n_samples
        self.duration_s: float = session.duration_s
        self._t_s: np.ndarray | None = None

    def __repr__(self) -> str:
        leg = f"{_SIDES[self.side]} leg" if self.side in _SIDES else "side unknown"
        return (f"<gaitmon recording {self.path.name}: {leg}, mode {self.mode}, "
                f"{self.n_samples} samples at {self.sample_rate_hz:g} Hz "
                f"({self.duration_s:.1f} s)>")  # fmt: skip

    def __enter__(self) -> Recording:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:  # fmt: skip
        self.close()

    def close(self) -> None:
        self.session.close()

    # -- arrays -------------------------------------------------------------------------------

    @property
    def t_s(self) -> np.ndarray:
        """(N,) float64: the true time of each row, seconds from the session start."""
        if self._t_s is None:
            self._t_s = self.session.read("timeline/t_s").astype(np.float64)
        return self._t_s

    def angles(self, kind: str = "smoothed") -> Angles:
        """The joint and segment angles (see :class:`Angles` for the sign conventions).

        ``kind="smoothed"``: the zero-lag estimate every gaitmon report analyses (mode raw);
        ``kind="live"``: the causal filter's, as shown while recording (the only kind of modes
        tilt and joint, whose angles are the unit's own).

        >>> with gaitmon.open(path) as rec:
        ...     a = rec.angles()
        ...     print(a.kind, a.joint_deg.shape, a.tilt_deg.shape, a.joint_names)
        ...     knee = a.joint_deg[:, 1]
        ...     print(f"knee flexion {np.nanmin(knee):.1f} to {np.nanmax(knee):.1f} deg")
        smoothed (2088, 3) (2088, 4) ('hip_flexion', 'knee_flexion', 'ankle_dorsiflexion')
        knee flexion -0.9 to 63.7 deg
        """
        from gaitmon.io.session import SessionError

        if kind not in ANGLE_KINDS:
            raise ValueError(f"kind must be one of {', '.join(ANGLE_KINDS)}, not {kind!r}")
        s = self.session
        if kind not in s.angle_sources:
            raise SessionError(f"{self.path.name} has no {kind} angles (mode {self.mode} has "
                               f"{' and '.join(s.angle_sources)})")  # fmt: skip
        view = s.with_angles(kind)
        joint = view.read("processed/joint_deg")
        tilt = view.read("processed/tilt_deg") if "processed/tilt_deg" in s.dataset_names else None
        return Angles(kind, view.angle_method, self.t_s, joint, tilt)

    def events(self) -> Events:
        """Heel strikes and toe offs (mode raw: from the force sensors, back-dated by the
        filter's delay; docs/file-format.md, ``/events``).

        >>> with gaitmon.open(path) as rec:
        ...     ev = rec.events()
        ...     print(len(ev.heel_strike_idx), ev.heel_strike_s[:3].round(2).tolist())
        16 [3.8, 4.89, 5.99]
        """
        hs = np.asarray(self.session.heel_strike_idx, dtype=np.int64)
        to = np.asarray(self.session.toe_off_idx, dtype=np.int64)
        return Events(hs, to, self._time_of(hs), self._time_of(to))

    def strides(self) -> dict[str, np.ndarray]:
        """The stride table of ``gaitmon info``, the report and ``gaitmon export --format
        strides`` (the same analysis: the user's stored exclusions applied), one entry per
        column, one value per stride: ``stride`` (number), ``start_s``, ``stride_s``,
        ``stance_s``, ``swing_s``, ``stance_pct``, ``stride_length_m``, ``speed_m_s``,
        ``foot_clearance_cm``, ``knee_peak_swing_deg``, ``hip_rom_deg``, ``knee_rom_deg``,
        ``ankle_rom_deg``, ``status`` ("included" or why not), plus ``heel_strike_idx`` and
        ``included`` (bool). NaN where a figure cannot be computed.

        >>> with gaitmon.open(path) as rec:
        ...     st = rec.strides()
        ...     print(len(st["stride_s"]), int(st["included"].sum()))
        ...     print(st["status"][0], round(float(np.median(st["stride_s"])), 2))
        15 10
        excluded: first stride 1.09
        """
        from gaitmon.analysis import STRIDE_COLUMNS, analyse_session, stride_values

        s = self.session
        an = analyse_session(s)
        t = self.t_s
        rows = [stride_values(r, k + 1, float(t[min(r.stride.start_idx, len(t) - 1)]))
                for k, r in enumerate(an.rows)]  # fmt: skip
        out: dict[str, np.ndarray] = {}
        for j, col in enumerate(STRIDE_COLUMNS):
            values = [row[j] for row in rows]
            if col.decimals is None:
                out[col.key] = np.array(values, dtype=object)
            elif col.key == "stride":
                out[col.key] = np.array(values, dtype=np.int64)
            else:
                out[col.key] = np.array(values, dtype=np.float64)
        out["heel_strike_idx"] = np.array([r.stride.start_idx for r in an.rows], np.int64)
        out["included"] = np.array([r.included for r in an.rows], dtype=bool)
        return out

    def gaps(self) -> dict[str, np.ndarray]:
        """Frames lost on the link: ``sample_idx`` (the row where data resumed), ``t_s`` (its
        time), ``n_lost`` (frames), ``duration_s`` and ``reason``.

        >>> with gaitmon.open(path) as rec:
        ...     g = rec.gaps()
        ...     print(len(g["n_lost"]), int(g["n_lost"].sum()), g["reason"][0])
        12 12 frames lost
        """
        gaps = self.session.gaps
        idx = np.array([g.sample_idx for g in gaps], dtype=np.int64)
        return {
            "sample_idx": idx,
            "t_s": self._time_of(idx),
            "n_lost": np.array([g.n_lost for g in gaps], dtype=np.int64),
            "duration_s": np.array([g.duration_s for g in gaps], dtype=np.float64),
            "reason": np.array([g.reason for g in gaps], dtype=object),
        }

    def markers(self) -> dict[str, np.ndarray]:
        """Markers placed during the recording (clinician, LSL): ``sample_idx``, ``t_s``,
        ``label``, in the order they were placed.

        >>> with gaitmon.open(path) as rec:
        ...     print(len(rec.markers()["label"]))
        0
        """
        ms = self.session.markers
        return {
            "sample_idx": np.array([m.sample_idx for m in ms], dtype=np.int64),
            "t_s": np.array([m.t_s for m in ms], dtype=np.float64),
            "label": np.array([m.label for m in ms], dtype=object),
        }

    # -- pandas -------------------------------------------------------------------------------

    def to_data_frame(self, what: str = "angles", kind: str = "smoothed") -> Any:
        """A pandas DataFrame indexed by time (``time_s``, seconds from the session start):

        * ``"angles"`` (``kind`` as in :meth:`angles`): one row per sample, columns
          ``hip_flexion_deg``, ``knee_flexion_deg``, ``ankle_dorsiflexion_deg`` and (modes raw,
          tilt) ``body_tilt_deg`` … ``foot_tilt_deg``, plus ``sample_idx``;
        * ``"events"``: one row per event, columns ``event`` (heel_strike | toe_off) and
          ``sample_idx``, in time order;
        * ``"strides"``: :meth:`strides`, indexed by each stride's start;
        * ``"gaps"``, ``"markers"``: :meth:`gaps`, :meth:`markers`, indexed by ``t_s``.

        pandas is not installed with gaitmon (``pip install 'gaitmon[pandas]'``).

        >>> with gaitmon.open(path) as rec:
        ...     df = rec.to_data_frame("angles")
        ...     print(df.shape, df.index.name, list(df.columns[:2]))
        ...     st = rec.to_data_frame("strides")
        ...     print(len(st), st.index.name, round(float(st["stride_s"].median()), 2))
        (2088, 8) time_s ['sample_idx', 'hip_flexion_deg']
        15 time_s 1.09
        """
        pd = _pandas()
        if what not in _TABLES:
            raise ValueError(f"what must be one of {', '.join(_TABLES)}, not {what!r}")
        if what == "angles":
            a = self.angles(kind)
            cols: dict[str, np.ndarray] = {"sample_idx": np.arange(len(a.t_s), dtype=np.int64)}
            for k, name in enumerate(a.joint_names):
                cols[f"{name}_deg"] = a.joint_deg[:, k]
            if a.tilt_deg is not None:
                for k, name in enumerate(a.segment_names):
                    cols[f"{name}_tilt_deg"] = a.tilt_deg[:, k]
            return pd.DataFrame(cols, index=pd.Index(a.t_s, name="time_s"))
        if what == "events":
            ev = self.events()
            t = np.concatenate([ev.heel_strike_s, ev.toe_off_s])
            order = np.argsort(t, kind="stable")
            names = np.array(["heel_strike"] * len(ev.heel_strike_idx)
                             + ["toe_off"] * len(ev.toe_off_idx), dtype=object)  # fmt: skip
            idx = np.concatenate([ev.heel_strike_idx, ev.toe_off_idx])
            return pd.DataFrame({"event": names[order], "sample_idx": idx[order]},
                                index=pd.Index(t[order], name="time_s"))  # fmt: skip
        if what == "strides":
            st = self.strides()
            start = st.pop("start_s")
            return pd.DataFrame(st, index=pd.Index(start, name="time_s"))
        table = self.gaps() if what == "gaps" else self.markers()
        t = table.pop("t_s")
        return pd.DataFrame(table, index=pd.Index(t, name="time_s"))

    def _time_of(self, idx: np.ndarray) -> np.ndarray:
        """The true time of rows ``idx`` (a row past the last one: the last row's time plus
        the rows it is beyond it at the nominal rate)."""
        t = self.t_s
        idx = np.asarray(idx, dtype=np.int64)
        if not len(t):
            return idx / self.sample_rate_hz
        inside = np.clip(idx, 0, len(t) - 1)
        return t[inside] + (idx - inside) / self.sample_rate_hz


def _pandas() -> Any:
    try:
        import pandas  # type: ignore[import-untyped,import-not-found,unused-ignore]
    except ImportError:
        raise ModuleNotFoundError(
            "to_data_frame needs pandas, which gaitmon does not install: "
            "pip install 'gaitmon[pandas]'"
        ) from None
    return pandas


def open(path: str | os.PathLike[str], side: str | None = None) -> Recording:
    """Open a gaitmon session file (``.h5``) for reading.

    A session of both legs is opened one leg at a time: ``side="L"`` or ``"R"`` (times are
    then that unit's own; ``gaitmon.finish.open_bilateral`` maps them onto the common time
    line). An interrupted recording is recovered from its journal first, as every gaitmon
    command does. A file that cannot be read raises :class:`gaitmon.io.session.SessionError`
    with a one-line reason.

    >>> rec = gaitmon.open(path)
    >>> rec.angles("live").method
    'gait-aware Kalman'
    >>> rec.close()
    """
    from gaitmon.finish import open_session
    from gaitmon.io.session import SessionError

    p = Path(path)
    if side is not None and side not in _SIDES:
        raise ValueError(f"side must be 'L', 'R' or None, not {side!r}")
    try:
        session = open_session(p, side=side)
    except SessionError as e:
        if "records both legs" in str(e):
            raise SessionError(f"{p.name} records both legs; open one with "
                               "gaitmon.open(path, side='L') or side='R'") from None  # fmt: skip
        raise
    return Recording(session)


__all__ = ["ANGLE_KINDS", "JOINTS", "SEGMENT_NAMES", "Angles", "Events", "Recording", "open"]
