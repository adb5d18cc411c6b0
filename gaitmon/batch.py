"""Reprocessing a study: every session under a folder, on a process pool or a Dask cluster.

``gaitmon batch DIR -o OUT`` is :func:`run_batch`. Each session is one :class:`Task` (plain
paths and a frozen :class:`~gaitmon.reprocessing.Reprocessing`: picklable, so a local process or
a Dask worker can take it) run by :func:`reprocess_one`, which opens its own files (h5py objects
cannot travel between processes), writes ``OUT/<same relative path>.partial`` through
:func:`gaitmon.finish.reprocess.rewrite_processed` (as ``gaitmon process`` does) and returns a
small :class:`Outcome`: the session's summary row and its stride rows, or why it could not be
reprocessed. The driver, taking the outcome, moves the file into place (so a cancelled batch
publishes nothing once it has returned). A damaged file is an outcome ("damaged" and one
line), never an exception that stops the batch.

Resuming: after each session the driver writes a small record (its outcome, the source's size
and time, the settings, the output's name under OUT and size) under ``OUT/.gaitmon-batch/``,
atomically, keyed by the session's path under DIR: another spelling of DIR or OUT, or both
moved together, resume.
A rerun skips every session whose record matches and whose output is there whole; a session
killed mid-way has no record (or only a ``.partial`` output) and is done again. The CSVs are
written last, from every record, sorted by relative path, so two runs over the same files give
the same bytes whatever the order the workers finished in.

De-identified (``deidentify=True``), nothing in ``OUT`` names a patient or dates a recording:
the tables carry labels (``S0001``, ``P001``), the sessions are written as ``OUT/S0001.h5`` ...
(their labels in the tables) and cleaned as a de-identified export is
(:func:`gaitmon.io.session.deidentify.write_deidentified`), and the records, which hold the
patient ids and paths a resume needs, go to the key folder beside ``OUT``
(``OUT.gaitmon-key/``: the records, ``key.csv`` linking each label to its file and patient,
and the work files of sessions in flight): keep it, share ``OUT``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gaitmon import __version__
from gaitmon.analysis import (
    analyse_session,
    stride_cells,
    stride_start_times,
)
from gaitmon.batch_pool import dask_client, run_dask, run_local
from gaitmon.batch_tables import (  # noqa: F401  (the tables' names, as gaitmon.batch gave them)
    DAMAGED,
    OK,
    PARTIAL,
    SKIPPED,
    SPATIAL_MEASURES,
    STRIDES_COLUMNS,
    STRIDES_CSV,
    SUMMARY_COLUMNS,
    SUMMARY_CSV,
    SUMMARY_MEASURES,
    TEMPORAL_MEASURES,
    Outcome,
    Task,
    labels,
    scrub_reason,
    session_labels,
    write_atomic,
    write_key,
    write_tables,
)
from gaitmon.errors import DAMAGE_ERRORS, UserError
from gaitmon.io.deidentify import (
    create_private_file,
    make_private_dir,
)
from gaitmon.reprocessing import Reprocessing

STATE_DIR = ".gaitmon-batch"  # in OUT: one record per finished session
KEY_SUFFIX = ".gaitmon-key"  # de-identified: the folder beside OUT that re-identifies it
KEY_CSV = "key.csv"
RECORDS_DIR = "records"  # in the key folder
WORK_DIR = "work"  # in the key folder: a session reprocessed, before it is de-identified


Progress = Callable[[float, str], object]  # (fraction done, "12/200 sessions")


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:200] or type(exc).__name__


def reprocess_one(task: Task) -> Outcome:
    """Reprocess one session and analyse the result; never raises for a bad file.

    Runs in a worker: imports what it needs, opens its own files, returns plain values.
    """
    from gaitmon.finish import open_session
    from gaitmon.finish.reprocess import partial_path, rewrite_processed
    from gaitmon.io.session import SessionError
    from gaitmon.io.session.parts import is_bilateral

    bad_file: tuple[type[BaseException], ...] = (SessionError, *DAMAGE_ERRORS)
    src, dst = Path(task.src), staged(task.dst)  # the batch's own thread publishes it
    work = Path(task.work) if task.work else None
    t0, cpu0 = time.perf_counter(), time.thread_time()
    wrote = False
    try:
        if is_bilateral(src):  # a good file: not "damaged" (open_session refuses both legs)
            why = "" if src.exists() else " (interrupted: gaitmon info FILE combines its parts)"
            return Outcome(task.rel, SKIPPED, f"a session of both legs{why}: gaitmon batch "
                           "reprocesses one-unit sessions; use gaitmon process FILE -o NEW for "
                           "both legs")  # fmt: skip
        with open_session(src) as s:  # (recovers an interrupted recording first)
            if s.mode != "raw":
                return Outcome(task.rel, SKIPPED, f"{s.mode}-mode recording: it holds the "
                               "unit's own angles, not raw counts, so it cannot be reprocessed")
            recorded = s.config
            exclusions, problem = s.exclusions()  # the user's, from beside the recording
            patient, created = s.meta.patient_id, s.created_utc
        try:
            config = task.settings.apply(recorded) if task.settings is not None else recorded
        except UserError as exc:
            return Outcome(task.rel, SKIPPED, _one_line(exc), patient, created)
        t1 = time.perf_counter()
        dst.parent.mkdir(parents=True, exist_ok=True)
        wrote = True
        if work is None:
            rewrite_processed(src, dst, config, overwrite=True)
        else:
            from gaitmon.io.session.deidentify import write_deidentified

            make_private_dir(work.parent)
            os.close(create_private_file(partial_path(work)))  # the copy keeps its 0600
            rewrite_processed(src, work, config, overwrite=True)
            write_deidentified(work, dst)
        t2 = time.perf_counter()
        with open_session(dst) as new:
            t_s = new.read("timeline/t_s") if new.n_samples else None
            an = analyse_session(new, exclusions=exclusions, t_s=t_s)
            starts = stride_start_times(an.rows, t_s if t_s is not None else np.empty(0))
            rows = tuple(tuple(stride_cells(r, k + 1, t)) for k, (r, t)
                         in enumerate(zip(an.rows, starts, strict=True)))  # fmt: skip
            summ, spatial = an.summary(), an.spatial()
            method, duration = new.angle_method, new.duration_s
        t3 = time.perf_counter()
    except bad_file as exc:
        if wrote:  # only whole, analysed outputs stay in OUT
            extra = (work, partial_path(work)) if work is not None else ()
            for p in (dst, partial_path(dst), *extra):
                with contextlib.suppress(OSError):
                    p.unlink()
        return Outcome(task.rel, DAMAGED, _one_line(exc))
    return Outcome(
        task.rel, OK, problem, patient, created, duration, len(an.rows), an.n_included,
        {**{k: float(getattr(summ, k)) for k in TEMPORAL_MEASURES},
         "strides_with_length": spatial.n_strides,
         **{k: float(getattr(spatial, k)) for k in SPATIAL_MEASURES}}, method, rows,
        {"read_s": t1 - t0, "rewrite_s": t2 - t1, "analyse_s": t3 - t2,
         "cpu_s": time.thread_time() - cpu0},
    )  # fmt: skip


# -- finding the sessions and what is done ---------------------------------------------------


def find_sessions(root: Path, out: Path | None = None) -> list[str]:
    """Relative paths (sorted) of every session (``*.h5``) under ``root``, not under ``out``,
    as ``gaitmon info`` names them (:func:`gaitmon.io.session.parts.sessions_in`): one left as
    its journal or as a two-leg recording's parts is a row too (recovered as it is opened)."""
    from gaitmon.io.session.parts import sessions_in

    out_r = out.resolve() if out is not None else None
    found = []
    for p in sessions_in(root, suffixes=(".h5",)):
        if out_r is not None and p.resolve().is_relative_to(out_r):
            continue
        found.append(p.relative_to(root).as_posix())
    return sorted(found)


def key_dir(out: Path) -> Path:
    """The key folder of a de-identified run into ``out``: beside it, never inside."""
    out = Path(os.path.abspath(out))
    return out.with_name(out.name + KEY_SUFFIX)


def _state_dir(out: Path, deidentify: bool) -> Path:
    """Where the records are: in OUT, or (de-identified) in the key folder beside it."""
    return key_dir(out) / RECORDS_DIR if deidentify else out / STATE_DIR


def _record_path(state: Path, rel: str) -> Path:
    return state / (rel + ".json")


def _source_stamp(src: Path) -> list[int]:
    st = src.stat()
    return [st.st_size, st.st_mtime_ns]


def _fingerprint(settings: Reprocessing | None) -> str:
    return "recorded" if settings is None else settings.fingerprint()


def staged(dst: str | os.PathLike[str]) -> Path:
    """Where a worker leaves a session's output, whole: the batch's own thread moves it to
    ``dst`` when it takes the result (:func:`_publish`), so a cancelled batch publishes
    nothing after it returns, whatever its workers were doing."""
    return Path(os.fspath(dst) + PARTIAL)


def _publish(task: Task) -> None:
    try:
        os.replace(staged(task.dst), task.dst)
    except OSError as exc:
        raise UserError(f"cannot move {staged(task.dst)} to {task.dst} ({exc.strerror or exc}); "
                        "check the OUT folder and run the batch again (it resumes)") from None


def _output_name(task: Task, out: Path) -> str:
    """The output's name under OUT: how a record names it, whatever the spelling of OUT."""
    return Path(task.dst).relative_to(out).as_posix()


def _same_output(recorded: Any, task: Task, out: Path) -> bool:
    """A record's output is the task's (a de-identified label may now be another session's):
    by its name under OUT, so that another spelling of OUT (``out`` and ``$PWD/out``), or the
    study and OUT moved together, still resume; a record written before names were kept
    relative holds a path, compared resolved."""
    if not isinstance(recorded, str):
        return recorded is None  # (a record without one: no label to mismatch)
    if recorded == _output_name(task, out):
        return True
    return os.path.realpath(recorded) == os.path.realpath(task.dst)


def _finished(task: Task, state: Path, fingerprint: str, out: Path) -> Outcome | None:
    """The recorded outcome when ``task`` is done with these settings on this very source and
    its output is there whole, under the same name; else None (do it again)."""
    try:
        rec = json.loads(_record_path(state, task.rel).read_text(encoding="utf-8"))
        if (rec.get("version") != __version__ or rec.get("settings") != fingerprint
                or rec.get("source") != _source_stamp(Path(task.src))
                or not _same_output(rec.get("output"), task, out)):
            return None
        outcome = Outcome.from_record(rec["outcome"])
        if outcome.status != OK or Path(task.dst).stat().st_size != rec.get("output_size"):
            return None  # a damaged or skipped session is tried again: it may be fixed
        return outcome
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _save_record(task: Task, state: Path, fingerprint: str, outcome: Outcome, out: Path) -> None:
    with contextlib.suppress(OSError):  # a missing source or output: the record says so
        rec = {
            "version": __version__,
            "settings": fingerprint,
            "source": _source_stamp(Path(task.src)),
            "output": _output_name(task, out),
            "output_size": Path(task.dst).stat().st_size if outcome.status == OK else None,
            "outcome": outcome.as_record(),
        }
        write_atomic(_record_path(state, task.rel), json.dumps(rec).encode(),
                      private=bool(task.work))


@dataclass(frozen=True)
class BatchResult:
    outcomes: tuple[Outcome, ...]  # every session, sorted by relative path
    n_resumed: int  # finished by an earlier run, not done again
    summary_csv: Path
    strides_csv: Path
    elapsed_s: float
    key: Path | None = None  # de-identified: the key folder beside OUT (keep it, share OUT)

    def count(self, status: str) -> int:
        return sum(1 for o in self.outcomes if o.status == status)


def run_batch(
    root: str | os.PathLike[str],
    out: str | os.PathLike[str],
    settings: Reprocessing | None = None,
    *,
    jobs: int = 1,
    dask: Any = None,
    deidentify: bool = False,
    progress: Progress | None = None,
) -> BatchResult:
    """Reprocess every session under ``root`` into ``out`` (same layout) and write the summary
    and per-stride CSVs there. ``settings=None``: each file's own; ``dask``: a scheduler
    address (or cluster) to run on instead of ``jobs`` local processes. Raises
    :class:`UserError` for a bad folder; a bad session is a row, not an exception."""
    t0 = time.perf_counter()
    root_p, out_p = Path(root), Path(out)
    if not root_p.is_dir():
        raise UserError(f"folder {root_p} does not exist; give the folder that holds the sessions")
    if out_p.resolve() == root_p.resolve():
        raise UserError("OUT must be another folder: the original recordings are never modified")
    rels = find_sessions(root_p, out_p)
    if not rels:
        raise UserError(f"no session files (*.h5) under {root_p}")
    _check_same_kind(out_p, deidentify)
    client = dask_client(dask) if dask is not None else None  # (fails before any work)
    try:
        return _run(root_p, out_p, rels, settings, jobs, client, deidentify, progress, t0)
    finally:
        if client is not None:
            client.close()


def _check_same_kind(out: Path, deidentify: bool) -> None:
    """One OUT is de-identified throughout or not at all: a de-identified run into an OUT that
    holds identified sessions (or the reverse) would mix them in what is shared."""
    if deidentify and (out / STATE_DIR).is_dir():
        raise UserError(
            f"{out} holds a batch that was not de-identified (its sessions keep the patient "
            "ids); give another OUT folder for --deidentify"
        )
    if not deidentify and key_dir(out).is_dir():
        raise UserError(
            f"{out} holds a de-identified batch (its key is {key_dir(out)}); add --deidentify "
            "or give another OUT folder"
        )


def _tasks(root_p: Path, out_p: Path, rels: list[str], settings: Reprocessing | None,
           deidentify: bool) -> list[Task]:
    """Each session's task: OUT/<same path>, or, de-identified, OUT/<its label>.h5 (the
    label of the tables, S0001 ... in path order) from a work file in the key folder."""
    if not deidentify:
        return [Task(rel, str(root_p / rel), str(out_p / rel), settings) for rel in rels]
    work = key_dir(out_p) / WORK_DIR
    return [Task(rel, str(root_p / rel), str(out_p / f"{label}.h5"), settings,
                 str(work / f"{label}.h5"))
            for rel, label in zip(rels, session_labels(len(rels)), strict=True)]  # fmt: skip


def _run(
    root_p: Path, out_p: Path, rels: list[str], settings: Reprocessing | None, jobs: int,
    client: Any, deidentify: bool, progress: Progress | None, t0: float,
) -> BatchResult:  # fmt: skip
    out_p.mkdir(parents=True, exist_ok=True)
    if deidentify:
        make_private_dir(key_dir(out_p))  # before anything is written in it
    state = _state_dir(out_p, deidentify)
    fp = _fingerprint(settings)
    tasks = _tasks(root_p, out_p, rels, settings, deidentify)
    results: dict[str, Outcome] = {}
    todo = []
    for t in tasks:
        prev = _finished(t, state, fp, out_p)
        if prev is None:
            todo.append(t)
        else:
            results[t.rel] = dataclasses.replace(prev, strides=())
    n_resumed = len(results)
    total = len(tasks)
    by_rel = {t.rel: t for t in tasks}

    def report() -> None:
        if progress is not None:
            progress(len(results) / total, f"{len(results)}/{total} sessions")

    def done(outcome: Outcome) -> None:
        if outcome.status == OK:  # (an output without its record is only done again)
            _publish(by_rel[outcome.rel])
        _save_record(by_rel[outcome.rel], state, fp, outcome, out_p)
        # the stride rows stay in the record only: 10,000 ten-minute sessions hold ~5 million
        results[outcome.rel] = dataclasses.replace(outcome, strides=())
        report()

    report()
    if todo:
        if client is not None:
            run_dask(reprocess_one, todo, client, done)
        else:
            run_local(reprocess_one, todo, jobs, done)
    outcomes = tuple(results[r] for r in rels)
    summary_csv, strides_csv = write_tables(
        outcomes, out_p, deidentify=deidentify, strides_of=lambda o: _recorded_strides(state, o),
        root=root_p,
    )
    key = None
    if deidentify:
        key = key_dir(out_p)
        write_key(outcomes, tasks, key / KEY_CSV)
    return BatchResult(outcomes, n_resumed, summary_csv, strides_csv, time.perf_counter() - t0,
                       key)  # fmt: skip


def _recorded_strides(state: Path, o: Outcome) -> tuple[tuple[str, ...], ...]:
    """A finished session's stride rows, read back from its record (JSON keeps every float's
    exact value, so the table is the same as from the worker's own result)."""
    if o.status != OK:
        return ()
    try:
        rec = json.loads(_record_path(state, o.rel).read_text(encoding="utf-8"))
        return Outcome.from_record(rec["outcome"]).strides
    except (OSError, ValueError, KeyError, TypeError):
        return ()
