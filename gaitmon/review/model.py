"""What the review window shows, computed without Qt (so workers and tests can run it).

* :func:`open_document` - open a session (recovering an interrupted one, with progress and
  cancel), read its timeline and build the whole-session overview of the knee angle;
* :class:`Source` - a set of per-sample series with their events: the recorded series, or a
  reprocessed set held in memory (the recording is never modified);
* :func:`analyse` - strides with exclusions, summary and cycle-normalised curves for a source
  (:func:`gaitmon.analysis.analyse_session`, as ``gaitmon info`` and the report use);
* :func:`reprocess` - the pipeline replayed over ``raw/adc`` with new settings
  (:func:`gaitmon.io.session.replay_pipeline`, as ``gaitmon process`` does).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitmon.analysis import StrideRow, analyse_session, cycles, session_settling, summary
from gaitmon.dsp.gait import GaitSummary, cycle_mean_sd
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import Cancelled
from gaitmon.io.overview import SessionOverview
from gaitmon.io.session import Session, SessionError, open_session, replay_pipeline
from gaitmon.io.session import exclusions as excl
from gaitmon.io.session.rows import lost_before_from_gaps

Progress = Callable[[float], bool | None]

JOINT = "processed/joint_deg"
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


class Source:
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
    ) -> None:
        self.label = label
        self.names = tuple(names)
        self.n_rows = n_rows
        # (first row after each gap, frames it lost): lines are broken there, never drawn
        # across lost data
        self.gaps = gaps or (np.empty(0, np.int64), np.empty(0, np.int64))
        self.overview = SessionOverview(
            read, n_rows, breaks=self.gaps[0], break_lost=self.gaps[1]
        )
        self.heel_strike_idx = np.asarray(heel_strike_idx, dtype=np.int64)
        self.toe_off_idx = np.asarray(toe_off_idx, dtype=np.int64)
        self.config = config

    def has(self, name: str) -> bool:
        return name in self.names

    def read_rows(self, name: str, start: int, stop: int) -> np.ndarray:
        return self.overview.read_rows(name, start, stop)


@dataclass
class Document:
    """One opened recording (owns the open :class:`Session`; call :meth:`close`)."""

    path: Path
    session: Session
    t_s: np.ndarray  # (N,) true time of every row
    recorded: Source
    exclusions: list[excl.Exclusion]
    notes: list[str]  # problems worth a line in the window (recovery, side file, ...)
    reprocessed: Source | None = None
    gap_spans_s: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    # the filters settling after each long gap (their strides are excluded), in seconds
    settling_spans_s: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))

    @property
    def n_rows(self) -> int:
        return len(self.t_s)

    @property
    def fs_hz(self) -> float:
        return self.session.sample_rate_hz

    @property
    def current(self) -> Source:
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
        self.session.close()


def open_document(path: str | Path, progress: Progress | None = None) -> Document:
    """Open, recover if needed (``progress`` may cancel: the file is then shown as it is),
    read the timeline, and build the overview pyramid. Raises :class:`SessionError`."""
    path = Path(path)
    if path.is_dir():
        raise SessionError(f"{path.name} is a folder; pick a session file (.h5)")

    def part(lo: float, hi: float) -> Progress | None:
        if progress is None:
            return None
        return lambda f: progress(lo + (hi - lo) * f)

    s = open_session(path, progress=part(0.0, 0.7))
    try:
        notes = list(s.problems)
        if progress is not None and progress(0.72) is False:
            raise Cancelled
        t_s = np.asarray(s.read("timeline/t_s"), dtype=np.float64)
        n = len(t_s)

        def read(name: str, a: int, b: int) -> np.ndarray:
            return s.read_range(a, b, [name])[name]

        names = [p for p in s.dataset_names if not p.startswith("timeline/")]
        inner = [g for g in s.gaps if 0 < g.sample_idx < n]
        gaps = (
            np.array([g.sample_idx for g in inner], dtype=np.int64),
            np.array([g.n_lost for g in inner], dtype=np.int64),
        )
        recorded = Source(
            "recorded", read, names, n, s.heel_strike_idx, s.toe_off_idx, s.config, gaps
        )
        if n and recorded.has(OVERVIEW_SERIES):
            recorded.overview.pyramid(OVERVIEW_SERIES, progress=part(0.72, 1.0))
        ranges, problem = s.exclusions()
        if problem:
            notes.append(problem)
        spans = []
        for g in s.gaps[:MAX_GAP_SHADE]:
            if 0 < g.sample_idx < n:
                spans.append((t_s[g.sample_idx - 1], t_s[g.sample_idx]))
            elif g.sample_idx >= n and n:
                spans.append((t_s[-1], t_s[-1] + g.duration_s))
        doc = Document(path, s, t_s, recorded, ranges, notes)
        doc.gap_spans_s = np.asarray(spans, dtype=np.float64).reshape(-1, 2)
        settle = [(t_s[a], t_s[b - 1]) for a, b in session_settling(s) if 0 <= a < b <= n]
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


@dataclass(frozen=True)
class Analysis:
    """Strides, summary and cycle curves of one source with the exclusions in force."""

    source_label: str
    rows: list[StrideRow]
    summary: GaitSummary
    cycles_deg: np.ndarray  # (k, 101, 3) included strides, hip/knee/ankle
    mean_deg: np.ndarray  # (101, 3)
    sd_deg: np.ndarray  # (101, 3)

    @property
    def stance_pct_mean(self) -> float:
        return self.summary.stance_pct_mean

    @property
    def n_excluded(self) -> int:
        return sum(1 for r in self.rows if not r.included)


def analyse(
    doc: Document, source: Source, exclusions: Sequence[excl.Exclusion], n_points: int = 101
) -> Analysis:
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
        cyc = cycles(joint, rows, n_points)
    else:
        cyc = np.empty((0, n_points, 3))
    mean, sd = cycle_mean_sd(cyc)
    return Analysis(source.label, rows, summary(rows), cyc, mean, sd)


def reprocess(doc: Document, config: PipelineConfig, progress: Progress | None = None) -> Source:
    """Replay the pipeline over the recording's raw counts with ``config`` (the whole recording,
    standing calibrations replayed at their rows, like ``gaitmon process``); the result is kept
    in memory. Raises :class:`SessionError` (also when cancelled)."""
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
    for start, rows, hs_rows, to_rows, _faults in replay_pipeline(
        adc, config, s.calibration, list(s.calibration_changes), table=s.header.table,
        lost_before=lost_before_from_gaps(s.gaps, n),
    ):  # fmt: skip
        stop = start + len(rows[JOINT])
        for name in REPROCESSED_SERIES:
            data = rows[name]
            if name not in out:
                out[name] = np.empty((n, *data.shape[1:]), dtype=data.dtype)
            out[name][start:stop] = data
        hs.append(hs_rows)
        to.append(to_rows)
        if progress is not None and progress(stop / max(n, 1)) is False:
            raise SessionError("reprocessing cancelled; the recorded series are shown")

    def read(name: str, a: int, b: int) -> np.ndarray:
        return out[name][a:b]

    def cat(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts) if parts else np.empty(0, np.int64)

    return Source(
        "reprocessed", read, tuple(out), n, cat(hs), cat(to), config, doc.recorded.gaps
    )


def changed_settings(before: PipelineConfig, after: PipelineConfig) -> str:
    """``cutoff 4 → 6 Hz, R 0.3 → 0.1`` (the settings a reprocessing changed)."""
    names = {
        "cutoff_hz": ("cut-off", " Hz"),
        "q_angle": ("Q_angle", ""),
        "q_gyro": ("Q_gyro", ""),
        "r": ("R", ""),
        "fsr_threshold": ("FSR threshold", ""),
    }
    parts = []
    for key, (label, unit) in names.items():
        a, b = getattr(before, key), getattr(after, key)
        if not math.isclose(a, b):
            parts.append(f"{label} {a:g} → {b:g}{unit}")
    return ", ".join(parts) or "the recorded settings"
