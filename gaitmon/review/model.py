"""What the review window shows, computed without Qt (so workers and tests can run it).

* :func:`open_document` - open a session (recovering an interrupted one, with progress and
  cancel), read its timeline and build the whole-session overview of the knee angle; of a
  bilateral file (both legs), one leg: the :class:`Document` is that leg's unit, and knows the
  file's legs (:attr:`Document.sides`) so the window can offer the other;
* :class:`ReviewSource` - a set of per-sample series with their events: the recorded series, or a
  reprocessed set held in memory (the recording is never modified), each with the angles of
  one *angle source*: "smoothed" (the zero-lag offline estimate stored beside a raw-mode
  recording, the default, as ``gaitmon info``, the report and export read) or "live" (the causal
  filter's, as shown while recording). :meth:`Document.use_angles` switches every view at once;
* :class:`Replay` - a reprocessing's series and events. The smoothed angles depend on the raw
  counts and the calibration only, not on the settings a reprocessing changes, so a reprocessed
  source with smoothed angles keeps the session's smoothed angles, and its events, force
  sensors and phases come from the reprocessing;
* :class:`Document` emits change events (:mod:`gaitmon.review.events`): its exclusions (changed
  only through it, and kept through :mod:`gaitmon.io.session.exclusions`, which every reader of
  the session also reads), the angle source shown, and the settings of the series shown;
* :func:`analyse` - strides with exclusions, summary and cycle-normalised curves for a source
  (:func:`gaitmon.analysis.analyse_session`, as ``gaitmon info`` and the report use);
* :func:`reprocess` - the pipeline replayed over ``raw/adc`` with new settings
  (:func:`gaitmon.finish.replay_pipeline`, as ``gaitmon process`` does).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitmon.analysis import (
    StrideRow,
    analyse_session,
    cycle_stats,
    session_settling,
    summary,
)
from gaitmon.dsp.fsr_check import FsrFault
from gaitmon.dsp.gait import GaitSummary, cycle_mean_sd
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import Cancelled
from gaitmon.finish import Session, flags_kept, open_session, replay_pipeline
from gaitmon.io.overview import PeakPyramid, SessionOverview
from gaitmon.io.session import SessionError
from gaitmon.io.session import exclusions as excl
from gaitmon.io.session.layout import SMOOTHED
from gaitmon.io.session.parts import SIDE_NAMES, is_bilateral, sides_of
from gaitmon.io.session.rows import lost_before_from_gaps
from gaitmon.review.events import (
    AnglesChanged,
    DocumentEvents,
    ExclusionsChanged,
    SettingsChanged,
)
from gaitmon.review.settings import PIPELINE_SETTINGS
from gaitmon.text import num

Progress = Callable[[float], bool | None]

JOINT = "processed/joint_deg"
MAX_STRIDES_DRAWN = 300  # cycles drawn faintly behind the mean (evenly chosen among all)
OVERVIEW_SERIES = JOINT  # the knee (column 1) is drawn over the whole session
# series a reprocessing recomputes and the review window can draw
REPROCESSED_SERIES = (
    "processed/joint_deg",
    "processed/joint_acc_deg",
    "processed/joint_gyro_deg",
    "processed/tilt_deg",
    "processed/tilt_acc_deg",
    "processed/tilt_gyro_deg",
    "processed/fsr_counts",
    "processed/phase",
)
MAX_GAP_SHADE = 20_000  # gaps beyond this are too many to shade one by one (noisy link)


class ReviewSource:
    """Per-sample series plus their gait events, readable by row range from any thread."""

    def __init__(
        self,
        label: str,
        read: Callable[[str, int, int], np.ndarray],
        names: Sequence[str],
        n_rows: int,
        heel_strike_idx: np.ndarray,
        toe_off_idx: np.ndarray,
        config: PipelineConfig,
        gaps: tuple[np.ndarray, np.ndarray] | None = None,
        angles: str = "live",
        angle_method: str = "",
        stored: Callable[[str], PeakPyramid | None] | None = None,
    ) -> None:
        self.label = label  # recorded | reprocessed
        self.angles = angles  # the angles its tilt and joint series hold: smoothed | live
        self.angle_method = angle_method  # the method that made them, for people
        self.names = tuple(names)
        self.n_rows = n_rows
        # (first row after each gap, frames it lost): lines are broken there, never drawn
        # across lost data
        self.gaps = gaps or (np.empty(0, np.int64), np.empty(0, np.int64))
        self.overview = SessionOverview(
            read, n_rows, breaks=self.gaps[0], break_lost=self.gaps[1], stored=stored
        )
        self.heel_strike_idx = np.asarray(heel_strike_idx, dtype=np.int64)
        self.toe_off_idx = np.asarray(toe_off_idx, dtype=np.int64)
        self.config = config

    @property
    def key(self) -> str:
        """Unique among one document's sources: views and caches are keyed by it, so a view
        read for one angle source is never drawn as another's."""
        return f"{self.label}/{self.angles}"

    def has(self, name: str) -> bool:
        return name in self.names

    def read_rows(self, name: str, start: int, stop: int) -> np.ndarray:
        return self.overview.read_rows(name, start, stop)


@dataclass(frozen=True, eq=False)
class Replay:
    """A reprocessing (:func:`reprocess`): its live series and events, held in memory."""

    config: PipelineConfig
    series: dict[str, np.ndarray]  # REPROCESSED_SERIES, every row
    heel_strike_idx: np.ndarray
    toe_off_idx: np.ndarray
    fsr_faults: tuple[FsrFault, ...] = ()  # the force sensors its foot-gyro check flagged


@dataclass(eq=False)
class Document:
    """One opened recording (owns the open :class:`Session`; call :meth:`close`).

    Its sources are built on demand, one per (angle source, replay), and kept (with their
    overview pyramids): :attr:`recorded` and :attr:`reprocessed` are those of
    :attr:`angle_source`. Sources may be built on worker threads; the exclusions, the angle
    source and the replay are changed on one thread (the GUI's), through the methods that emit
    :attr:`events`."""

    path: Path
    session: Session
    t_s: np.ndarray  # (N,) true time of every row
    _exclusions: list[excl.Exclusion]  # read by exclusions; changed by set_exclusions
    notes: list[str]  # problems worth a line in the window (recovery, side file, ...)
    angle_source: str = "live"
    replay: Replay | None = None
    gap_spans_s: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    # the filters settling after each long gap (their strides are excluded), in seconds
    settling_spans_s: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    # (first row after each gap inside the data, frames it lost)
    gaps: tuple[np.ndarray, np.ndarray] = field(
        default_factory=lambda: (np.empty(0, np.int64), np.empty(0, np.int64))
    )
    # of a bilateral file: the leg shown ("L" | "R") and the file's legs; "" and () for one unit
    side: str = ""
    sides: tuple[str, ...] = ()
    _views: dict[str, Session] = field(default_factory=dict, repr=False)
    _sources: dict[tuple[str, Replay | None], ReviewSource] = field(default_factory=dict,
                                                                    repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    events: DocumentEvents = field(default_factory=DocumentEvents, repr=False)

    def __post_init__(self) -> None:
        s = self.session
        if self.angle_source not in s.angle_sources:
            self.angle_source = s.angle_source
        # one reader per angle source, so a worker reading one never sees the other's
        self._views = {a: (s if a == s.angle_source else s.with_angles(a))
                       for a in s.angle_sources}  # fmt: skip

    @property
    def n_rows(self) -> int:
        return len(self.t_s)

    # -- exclusions: changed here only, kept by gaitmon.io.session.exclusions -----------------

    @property
    def exclusions(self) -> list[excl.Exclusion]:
        """The user's excluded ranges in force (a copy: change them with the methods below)."""
        return list(self._exclusions)

    def set_exclusions(self, ranges: Sequence[excl.Exclusion]) -> ExclusionsChanged:
        """Put ``ranges`` in force, keep them (:func:`gaitmon.io.session.exclusions.write`,
        where ``gaitmon report`` and ``info`` read them), and emit ``events.exclusions`` once.
        When they cannot be kept they still apply until the file is closed (the event says
        why)."""
        self._exclusions = list(ranges)
        try:
            kept: Path | None = excl.write(self.session, self._exclusions, self.t_s)
            problem = ""
        except OSError as e:
            kept, problem = None, str(e.strerror or e)
        event = ExclusionsChanged(tuple(self._exclusions), kept, problem)
        self.events.exclusions.emit(event)
        return event

    def exclude(self, start: int, stop: int, label: str = "excluded range") -> ExclusionsChanged:
        """Leave rows ``[start, stop)`` out of the statistics (joined with touching ranges)."""
        return self.set_exclusions(
            excl.merge([*self._exclusions, excl.Exclusion(start, stop, label)])
        )

    def include(self, start: int, stop: int) -> ExclusionsChanged:
        """Rows ``[start, stop)`` count again."""
        return self.set_exclusions(excl.subtract(self._exclusions, start, stop))

    def clear_exclusions(self) -> ExclusionsChanged:
        return self.set_exclusions([])

    @property
    def bilateral(self) -> bool:
        """One leg of a file that records both: every per-file action takes :attr:`side`."""
        return bool(self.side)

    @property
    def leg_name(self) -> str:
        """"left leg" | "right leg" of a bilateral file; "" for a one-unit file."""
        return f"{SIDE_NAMES[self.side]} leg" if self.side else ""

    @property
    def exclusions_key(self) -> Path:
        """What the exclusions are kept for: the file, or one leg of it (``FILE.L`` keeps
        ``FILE.L.review.json``), as every reader of the session finds them."""
        return self.session.exclusions_key

    @property
    def fs_hz(self) -> float:
        return self.session.sample_rate_hz

    @property
    def angle_sources(self) -> tuple[str, ...]:
        """("smoothed", "live") for a raw-mode recording, ("live",) for the unit's own angles."""
        return self.session.angle_sources

    def angle_method_of(self, angles: str) -> str:
        """The method behind the angles of ``angles``, for people."""
        return self.session.angle_method_of(angles)

    @property
    def angle_method(self) -> str:
        """The method behind the angles shown now, e.g. "gait-aware Kalman + RTS smoother" (a
        reprocessing's live angles: its filter's)."""
        return self.current.angle_method

    def session_view(self, angles: str | None = None) -> Session:
        """The session reading ``angles`` (default: those shown), for ``gaitmon info``-like
        readers such as the report; owned by the document (never close it)."""
        return self._views[self.angle_source if angles is None else angles]

    def use_angles(self, angles: str) -> None:
        """Show ``angles`` (smoothed | live) from now on. Raises :class:`SessionError` for a
        source the recording does not have (tilt and joint modes have only the live one)."""
        if angles not in self._views:
            raise SessionError(
                f"{self.path.name} has no {angles!r} angles "
                f"(it has {' and '.join(self.angle_sources)})"
            )
        # emitted also when they were already shown: their overviews were just built
        self.angle_source = angles
        self.events.angles.emit(AnglesChanged(angles, self.angle_method))

    def shown_notes(self) -> list[str]:
        """The notes worth a line now: the recording's problems, and each force sensor the
        foot-gyro check flagged in the series shown (the recording's, or the reprocessing's)."""
        fs = self.fs_hz
        if self.replay is None:
            return [*self.notes, *fsr_fault_notes(self.session.fsr_faults, fs)]
        return [*self.notes,
                *(f"reprocessed: {n}" for n in fsr_fault_notes(self.replay.fsr_faults, fs))]

    def set_replay(self, replay: Replay | None) -> None:
        """The reprocessing to show (None: back to the recorded series); emits
        ``events.settings``."""
        self.replay = replay
        with self._lock:
            for key in [k for k in self._sources if k[1] not in (None, replay)]:
                del self._sources[key]
        config = self.session.config if replay is None else replay.config
        self.events.settings.emit(SettingsChanged(config, replay is not None))

    def source(self, angles: str, replay: Replay | None = None) -> ReviewSource:
        """The recorded series (``replay`` None) or ``replay`` 's, with the angles of
        ``angles``; built once, from any thread."""
        key = (angles, replay)
        with self._lock:
            src = self._sources.get(key)
            if src is None:
                src = self._build_source(angles, replay)
                self._sources[key] = src
        return src

    def _build_source(self, angles: str, replay: Replay | None) -> ReviewSource:
        view = self.session_view(angles)
        n = self.n_rows

        def read_session(name: str, a: int, b: int) -> np.ndarray:
            return view.read_range(a, b, [name])[name]

        if replay is None:  # (the file's /overview gives the knee pyramid, where it has one)
            s = self.session
            names = [p for p in s.dataset_names if not p.startswith("timeline/")]
            return ReviewSource("recorded", read_session, names, n, s.heel_strike_idx,
                          s.toe_off_idx, s.config, self.gaps, angles,
                          s.angle_method_of(angles),
                          stored=view.stored_pyramid)  # fmt: skip
        series = replay.series

        def read_replay(name: str, a: int, b: int) -> np.ndarray:
            # the smoothed angles do not depend on the reprocessing's settings
            if angles == "smoothed" and name in SMOOTHED:
                return read_session(name, a, b)
            return series[name][a:b]

        method = (self.angle_method_of(angles) if angles == "smoothed"
                  else replay.config.tilt_method_label)  # fmt: skip
        return ReviewSource("reprocessed", read_replay, tuple(series), n, replay.heel_strike_idx,
                      replay.toe_off_idx, replay.config, self.gaps, angles, method,
                      stored=view.stored_pyramid if angles == "smoothed" else None)  # fmt: skip

    @property
    def recorded(self) -> ReviewSource:
        return self.source(self.angle_source)

    @property
    def reprocessed(self) -> ReviewSource | None:
        replay = self.replay
        return None if replay is None else self.source(self.angle_source, replay)

    @property
    def current(self) -> ReviewSource:
        return self.reprocessed or self.recorded

    def row_at(self, t_s: float) -> int:
        """The row nearest in time to ``t_s``."""
        n = self.n_rows
        if n == 0:
            return 0
        i = int(np.searchsorted(self.t_s, t_s))
        if i <= 0:
            return 0
        if i >= n:
            return n - 1
        return i if self.t_s[i] - t_s < t_s - self.t_s[i - 1] else i - 1

    def rows_between(self, t0_s: float, t1_s: float) -> tuple[int, int]:
        """Rows ``[a, b)`` whose times lie in ``[t0_s, t1_s]``, widened by one row each side."""
        a = int(np.searchsorted(self.t_s, t0_s, side="left")) - 1
        b = int(np.searchsorted(self.t_s, t1_s, side="right")) + 1
        return max(0, a), min(self.n_rows, b)

    def close(self) -> None:
        self.events.disconnect_all()
        self.session.close()


def angles_caption(doc: Document) -> tuple[str, str]:
    """(method, explanation) of the angles shown, for the status bar and its tooltip."""
    if len(doc.angle_sources) < 2:
        tip = (f"A {doc.session.mode}-mode recording holds the unit's own angles only: there "
               "is nothing to smooth.")  # fmt: skip
    elif doc.angle_source == "smoothed":
        tip = ("Zero-lag offline estimate, as gaitmon info, the report and export use; the "
               f"live view showed {doc.angle_method_of('live')} (View ▸ Angles ▸ Live)."
               + (" A reprocessing changes the events, foot sensors and phases; these "
                  "angles do not depend on its settings." if doc.replay else ""))  # fmt: skip
    else:
        tip = ("The causal filter's angles, as shown while recording"
               + (" (here: the reprocessing's)" if doc.replay else "")
               + f"; View ▸ Angles ▸ Smoothed shows {doc.angle_method_of('smoothed')}.")
    reprocessed_live = doc.replay is not None and doc.angle_source == "live"
    method = doc.angle_method + (" (reprocessed)" if reprocessed_live else "")
    return f"{method} · zero: {doc.session.zero_source}", tip


def build_overview(
    doc: Document, angles: str, replay: Replay | None = None, progress: Progress | None = None
) -> ReviewSource:
    """``doc.source(angles, replay)`` with its whole-session knee pyramid built (slow for a long
    recording, and for one whose smoothed angles are not stored: run it on a worker)."""
    src = doc.source(angles, replay)
    if doc.n_rows and src.has(OVERVIEW_SERIES):
        src.overview.pyramid(OVERVIEW_SERIES, progress=progress)
    return src


def open_document(
    path: str | Path, progress: Progress | None = None, side: str | None = None
) -> Document:
    """Open, recover if needed (``progress`` may cancel: the file is then shown as it is),
    read the timeline, and build the overview pyramid of the default angles (the smoothed ones
    where the recording has them). Of a bilateral file, the leg ``side`` ("L" | "R"; None: its
    first leg); ``side`` with a one-unit file is refused. Raises :class:`SessionError`."""
    path = Path(path)
    if path.is_dir():
        raise SessionError(f"{path.name} is a folder; pick a session file (.h5)")
    if is_bilateral(path):
        side = side or (sides_of(path) or ("L",))[0]
    elif side is not None and path.exists():
        raise SessionError(f"{path.name} records one unit; it has no {side} leg to show")

    def part(lo: float, hi: float) -> Progress | None:
        if progress is None:
            return None
        return lambda f: progress(lo + (hi - lo) * f)

    s = open_session(path, progress=part(0.0, 0.7), side=side)
    try:
        notes = list(s.problems)
        if progress is not None and progress(0.72) is False:
            raise Cancelled
        t_s = np.asarray(s.read("timeline/t_s"), dtype=np.float64)
        n = len(t_s)
        inner = [g for g in s.gaps if 0 < g.sample_idx < n]
        gaps = (
            np.array([g.sample_idx for g in inner], dtype=np.int64),
            np.array([g.n_lost for g in inner], dtype=np.int64),
        )
        ranges, problem = excl.read(s)  # as gaitmon report and info read them
        if problem:
            notes.append(problem)
        spans = []
        for g in s.gaps[:MAX_GAP_SHADE]:
            if 0 < g.sample_idx < n:
                spans.append((t_s[g.sample_idx - 1], t_s[g.sample_idx]))
            elif g.sample_idx >= n and n:
                spans.append((t_s[-1], t_s[-1] + g.duration_s))
        doc = Document(path, s, t_s, ranges, notes, s.angle_source, gaps=gaps,
                       side=s.unit_side, sides=sides_of(path) if s.unit_side else ())
        build_overview(doc, doc.angle_source, progress=part(0.72, 1.0))
        doc.gap_spans_s = np.asarray(spans, dtype=np.float64).reshape(-1, 2)
        # rows [a, b) settle: shaded from row a to the first row after them (to the last row
        # at the file's end), as the live view's step band draws them; a stride that starts
        # on the last settling row (excluded: it overlaps it) starts inside the shade
        settle = [(t_s[a], t_s[min(b, n - 1)]) for a, b in session_settling(s)
                  if 0 <= a < b <= n]  # fmt: skip
        doc.settling_spans_s = np.asarray(settle, dtype=np.float64).reshape(-1, 2)
        return doc
    except Cancelled:
        s.close()
        raise SessionError(f"opening {path.name} cancelled") from None
    except SessionError:
        s.close()
        raise
    except Exception as e:  # a damaged file can fail in numpy/h5py in many ways
        s.close()
        raise SessionError(f"{path.name} is damaged ({e})") from e


def fsr_fault_notes(faults: Sequence[FsrFault], fs_hz: float) -> list[str]:
    """One line per force sensor the foot-gyro cross-check flagged, saying from when (s) the
    gait events come from the foot gyro."""
    return [f"{f.message()} from {num(f.decided_idx / fs_hz, 1)} s"
            for f in sorted(faults, key=lambda f: f.decided_idx)]  # fmt: skip


@dataclass(frozen=True)
class Analysis:
    """Strides, summary and cycle curves of one source with the exclusions in force."""

    source_label: str
    rows: list[StrideRow]
    summary: GaitSummary
    # (k, 101, 3) the included strides drawn, hip/knee/ankle: at most MAX_STRIDES_DRAWN of
    # them, evenly chosen (the mean and SD are over all of them)
    cycles_deg: np.ndarray
    mean_deg: np.ndarray  # (101, 3)
    sd_deg: np.ndarray  # (101, 3)
    angles: str = "live"  # the angles analysed: smoothed | live
    angle_method: str = ""  # their method, for people

    @property
    def stance_pct_mean(self) -> float:
        return self.summary.stance_pct_mean

    @property
    def n_excluded(self) -> int:
        return sum(1 for r in self.rows if not r.included)


def analyse(
    doc: Document, source: ReviewSource, exclusions: Sequence[excl.Exclusion], n_points: int = 101
) -> Analysis:
    # as read (float32), as gaitmon info and the report take them: the same figures to the last
    # digit (the stride figures and cycles are computed in float64 from these samples)
    joint = source.read_rows(JOINT, 0, source.n_rows) if source.has(JOINT) else None
    # the same analysis as gaitmon info and the report, on this source's series and events
    rows = analyse_session(
        doc.session,
        exclusions=list(exclusions),
        joints=joint,
        events=(source.heel_strike_idx, source.toe_off_idx),
        t_s=doc.t_s,
    ).rows
    if joint is not None:
        # the mean and SD of every included stride's cycle (as the report's, to the bit), and
        # only the cycles drawn kept: not all 26 000 of 8 hours (63 MB a source)
        mean, sd, cyc = cycle_stats(joint, rows, n_points, keep=MAX_STRIDES_DRAWN)
    else:
        cyc = np.empty((0, n_points, 3))
        mean, sd = cycle_mean_sd(cyc)
    return Analysis(source.label, rows, summary(rows), cyc, mean, sd, source.angles,
                    source.angle_method)


def reprocess(doc: Document, config: PipelineConfig, progress: Progress | None = None) -> Replay:
    """Replay the pipeline over the recording's raw counts with ``config`` (the whole recording,
    standing calibrations replayed at their rows, like ``gaitmon process``); the result is kept
    in memory (show it with :meth:`Document.set_replay`). Raises :class:`SessionError` (also
    when cancelled)."""
    s = doc.session
    if s.mode != "raw":
        raise SessionError(
            f"{doc.path.name} holds the unit's own {s.mode} angles, not raw counts; only "
            "raw-mode sessions can be reprocessed"
        )
    n = doc.n_rows
    adc = s.read("raw/adc")
    out: dict[str, np.ndarray] = {}
    hs: list[np.ndarray] = []
    to: list[np.ndarray] = []
    faults: list[FsrFault] = []
    for start, rows, hs_rows, to_rows, fault_rows, _ in replay_pipeline(
        adc, config, s.calibration, list(s.calibration_changes), table=s.header.table,
        lost_before=lost_before_from_gaps(s.gaps, n),
        flagged_at_start=flags_kept(s.fsr_faults, s.config, config),
    ):  # fmt: skip
        stop = start + len(rows[JOINT])
        for name in REPROCESSED_SERIES:
            data = rows[name]
            if name not in out:
                out[name] = np.empty((n, *data.shape[1:]), dtype=data.dtype)
            out[name][start:stop] = data
        hs.append(hs_rows)
        to.append(to_rows)
        faults.extend(FsrFault(sensor, reason, first, decided)
                      for decided, first, sensor, reason in fault_rows)  # fmt: skip
        if progress is not None and progress(stop / max(n, 1)) is False:
            raise SessionError("reprocessing cancelled; the recorded series are shown")

    def cat(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts) if parts else np.empty(0, np.int64)

    return Replay(config, out, cat(hs), cat(to), tuple(faults))


def changed_settings(before: PipelineConfig, after: PipelineConfig) -> str:
    """``cutoff 4 → 6 Hz, R 0.3 → 0.1`` (the settings a reprocessing changed)."""
    parts = []
    for setting in PIPELINE_SETTINGS:
        a, b = getattr(before, setting.name), getattr(after, setting.name)
        if not math.isclose(a, b):
            parts.append(f"{setting.short} {a:g} → {b:g}{setting.unit}")
    return ", ".join(parts) or "the recorded settings"
