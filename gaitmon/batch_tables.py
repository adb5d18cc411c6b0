"""What ``gaitmon batch`` works on and gives: a session's task and outcome, and the tables
(``summary.csv``, ``strides.csv``) and key of a de-identified run that the outcomes become,
labels and scrubbed reasons included. :mod:`gaitmon.batch` runs the sessions."""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gaitmon.analysis import STRIDE_COLUMNS, SpatialSummary
from gaitmon.dsp.gait import GaitSummary
from gaitmon.io.deidentify import (
    create_private_file,
    make_private_dir,
    scrub_file_names,
    scrub_free_text,
)
from gaitmon.reprocessing import Reprocessing
from gaitmon.text import spreadsheet_cell

SUMMARY_CSV = "summary.csv"
STRIDES_CSV = "strides.csv"
PARTIAL = ".partial"
OK, DAMAGED, SKIPPED = "ok", "damaged", "skipped"  # the summary's status column

# the summary measures of GaitSummary then SpatialSummary (the review window's summary), in
# their order; GaitSummary.n_strides is the strides_included column
TEMPORAL_MEASURES: tuple[str, ...] = tuple(
    f.name for f in dataclasses.fields(GaitSummary) if f.name != "n_strides"
)
SPATIAL_MEASURES: tuple[str, ...] = tuple(
    f.name for f in dataclasses.fields(SpatialSummary)
    if f.name not in ("n_strides", "foot_clearance_n")
)
SUMMARY_MEASURES: tuple[str, ...] = (*TEMPORAL_MEASURES, "strides_with_length",
                                     *SPATIAL_MEASURES)  # fmt: skip
SUMMARY_COLUMNS: tuple[str, ...] = (
    "session", "patient", "date_utc", "duration_s", "strides", "strides_included",
    "strides_excluded", *SUMMARY_MEASURES, "angles_method", "status", "reason",
)  # fmt: skip
# the review window's stride table, cell for cell (gaitmon.analysis.stride_cells)
STRIDES_COLUMNS: tuple[str, ...] = ("session", *(c.key for c in STRIDE_COLUMNS))



@dataclass(frozen=True)
class Task:
    """One session to reprocess: ``src`` into ``dst`` (``rel``: its path under DIR, the key)."""

    rel: str
    src: str
    dst: str
    settings: Reprocessing | None = None  # None: each file's own settings
    # de-identified: where the reprocessed file is written before it is cleaned into dst
    # (in the key folder, so that a kill never leaves an identified file in OUT); "" = not
    work: str = ""


@dataclass(frozen=True)
class Outcome:
    """What one session gave: its summary and stride rows, or why it gave none."""

    rel: str
    status: str  # OK | DAMAGED | SKIPPED
    reason: str = ""  # one line; for OK, a note (e.g. unusable stored exclusions) or ""
    patient_id: str = ""
    created_utc: str = ""
    duration_s: float = math.nan
    n_strides: int = 0
    n_included: int = 0
    summary: dict[str, float] = field(default_factory=dict)  # SUMMARY_MEASURES
    angles_method: str = ""
    strides: tuple[tuple[str, ...], ...] = ()  # the stride table's cells (stride_cells)
    # wall seconds opening the source, rewriting it (copy + pipeline + write) and analysing the
    # result; cpu_s: this thread's CPU time for all three (without waiting for a busy machine)
    timing: dict[str, float] = field(default_factory=dict)

    @property
    def n_excluded(self) -> int:
        return self.n_strides - self.n_included

    def as_record(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["strides"] = [list(r) for r in self.strides]
        return d

    @classmethod
    def from_record(cls, d: dict[str, Any]) -> Outcome:
        d = dict(d)
        d["strides"] = tuple(tuple(r) for r in d.get("strides", ()))
        return cls(**d)


def write_atomic(path: Path, data: bytes, private: bool = False) -> None:
    """Write ``path`` as ``path.partial`` then move it into place: a kill leaves the old file
    or the new one, never half of one. ``private``: in the key folder (0700 folders, 0600
    files, so from their creation)."""
    tmp = path.with_name(path.name + PARTIAL)
    if private:
        make_private_dir(path.parent)
        fd = create_private_file(tmp)
    else:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_BINARY", 0),
                     0o666)  # fmt: skip
    with open(fd, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)





def _decimals(name: str) -> int:
    if name.endswith(("_m", "_m_s")):
        return 3  # lengths to the mm, speeds to the mm/s
    if name.endswith("_s") and name != "duration_s":
        return 4  # stride times to 0.1 ms
    return 2


def _cell(name: str, value: Any) -> str:
    """Fixed decimals by unit (:func:`_decimals`), empty for NaN, so the same values always
    give the same text."""
    if isinstance(value, bool) or value is None:
        return "" if value is None else str(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return ""
        text = f"{value:.{_decimals(name)}f}"
        return text.lstrip("-") if float(text) == 0.0 else text
    return spreadsheet_cell(" ".join(str(value).split()))  # a formula stays text


def session_labels(n: int) -> list[str]:
    """The de-identified labels of n sessions in path order: S0001, S0002, ..."""
    return [f"S{k + 1:04d}" for k in range(n)]


def labels(outcomes: Iterable[Outcome], deidentify: bool) -> tuple[list[str], list[str]]:
    """(session label, patient label) per outcome: the relative path and patient id, or, de-
    identified, S0001... and P001... numbered in the order of the sorted paths (the same
    patient keeps one label within a run's tables)."""
    sessions, patients = [], []
    numbers: dict[str, str] = {}
    outcomes = list(outcomes)
    for o, label in zip(outcomes, session_labels(len(outcomes)), strict=True):
        if not deidentify:
            sessions.append(o.rel)
            patients.append(o.patient_id)
            continue
        sessions.append(label)
        pid = o.patient_id.strip()
        if pid and pid not in numbers:
            numbers[pid] = f"P{len(numbers) + 1:03d}"
        patients.append(numbers.get(pid, ""))
    return sessions, patients


REMOVED = "[removed]"


def scrub_reason(o: Outcome, label: str, root: str | os.PathLike[str] | None = None) -> str:
    """The reason without the file's name or path (often a patient code) or the patient id:
    the file's path and name, as the message quotes them, become the session's label, and
    what is left of the name or the patient id is removed from the paths it quotes. The
    reason is gaitmon's own message: its words are never rewritten (a file "both.h5" must not
    turn "a session of both legs" into "a session of S0003 legs")."""
    name = Path(o.rel).name
    paths = {o.rel, name}
    if root is not None:  # the source's path as a message may quote it
        src = Path(root) / o.rel
        paths |= {str(src), os.path.abspath(src), str(src.resolve())}
    whole = [(p, label) for p in sorted(paths, key=len, reverse=True) if p]
    reason = scrub_free_text(o.reason, whole)
    rest = [(s, by) for s, by in ((Path(name).stem, label), (o.patient_id.strip(), REMOVED))
            if s]  # fmt: skip
    return scrub_file_names(reason, sorted(rest, key=lambda x: -len(x[0])))


def write_tables(
    outcomes: Sequence[Outcome],
    out: Path,
    *,
    deidentify: bool = False,
    strides_of: Callable[[Outcome], Iterable[Sequence[Any]]] = lambda o: o.strides,
    root: Path | None = None,
) -> tuple[Path, Path]:
    """Write ``out/summary.csv`` and ``out/strides.csv`` (each as ``.partial``, then moved into
    place), one session's strides at a time (``strides_of``). De-identified: no patient id, no
    date, no file name (a file name is often a patient code), which are also removed from the
    reasons (the file's name becomes its label)."""
    sessions, patients = labels(outcomes, deidentify)
    paths = out / SUMMARY_CSV, out / STRIDES_CSV
    tmps = [p.with_name(p.name + PARTIAL) for p in paths]
    with (open(tmps[0], "w", encoding="utf-8", newline="") as fs,
          open(tmps[1], "w", encoding="utf-8", newline="") as fr):  # fmt: skip
        ws = csv.writer(fs, lineterminator="\n")
        wr = csv.writer(fr, lineterminator="\n")
        ws.writerow(SUMMARY_COLUMNS)
        wr.writerow(STRIDES_COLUMNS)
        for o, session, patient in zip(outcomes, sessions, patients, strict=True):
            reason = scrub_reason(o, session, root) if deidentify else o.reason
            ok = o.status == OK
            values: list[Any] = [
                session, patient, "" if deidentify else o.created_utc, o.duration_s,
                o.n_strides if ok else None, o.n_included if ok else None,
                o.n_excluded if ok else None, *(o.summary.get(k) for k in SUMMARY_MEASURES),
                o.angles_method, o.status, reason,
            ]  # fmt: skip
            ws.writerow([_cell(n, v) for n, v in zip(SUMMARY_COLUMNS, values, strict=True)])
            for row in strides_of(o):
                wr.writerow([spreadsheet_cell(str(session)), *row])
        for f in (fs, fr):
            f.flush()
            os.fsync(f.fileno())
    for tmp, path in zip(tmps, paths, strict=True):
        os.replace(tmp, path)
    return paths


KEY_COLUMNS = ("session", "file", "source", "patient", "patient_id")


def write_key(outcomes: Sequence[Outcome], tasks: Sequence[Task], path: Path) -> Path:
    """The key of a de-identified run (in the key folder, never in OUT): each session's label,
    its file in OUT, its source under DIR, its patient label and patient id."""
    sessions, patients = labels(outcomes, deidentify=True)
    dst = {t.rel: Path(t.dst).name for t in tasks}
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(KEY_COLUMNS)
    for o, session, patient in zip(outcomes, sessions, patients, strict=True):
        w.writerow([spreadsheet_cell(str(c)) for c in (
            session, dst[o.rel] if o.status == OK else "", o.rel, patient, o.patient_id)])
    write_atomic(path, buf.getvalue().encode("utf-8"), private=True)
    return path
