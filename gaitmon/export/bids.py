"""The BIDS format: a session as one recording of a Motion-BIDS dataset (the one-unit writer:
:mod:`gaitmon.export.writers.bids`); both legs as one recording with two tracking systems.

For both legs, each unit is a tracking system, ``tracksys-imuL`` and ``tracksys-imuR`` (the
labels a one-leg export gives the same unit), with its own ``_motion.tsv``, ``_channels.tsv``,
``_channels.json``, ``_motion.json`` and ``_gaitmon.json`` (the one-unit export's). Both
``_motion.tsv`` are on the common grid (:mod:`.grid`): row k of either is
common time k / SamplingFrequency, so a row of one is the same instant as that row of the
other. One ``_events.tsv`` (no tracksys entity: it belongs to both) holds both legs' heel
strikes and toe offs at their common times (``analyse_bilateral``'s), markers, and each leg's
gaps, with a ``side`` column.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gaitmon.export.base import ExportRequest, ExportResult, Format, write_atomic
from gaitmon.export.writers.errors import ExportError, step

if TYPE_CHECKING:
    import numpy as np

    from gaitmon.export.grid import CommonGrid, LegOnGrid
    from gaitmon.export.writers.bids import Channel, Names
    from gaitmon.export.writers.source import Source
    from gaitmon.export.writers.writer import FormatWriter
    from gaitmon.io.deidentify import Scrubber
    from gaitmon.values import JsonObject


@dataclass(frozen=True)
class BidsFormat(Format):
    def unit_writer(self, options: Mapping[str, object] | None) -> FormatWriter:
        from gaitmon.export.writers.bids import configure

        return configure(options)

    def export_units(self, request: ExportRequest) -> ExportResult:
        return export_bids(request)


BIDS = BidsFormat("bids", "", "BIDS motion dataset folder (Motion-BIDS; de-identified by "
                  "default)", folder=True, deidentify_default=True)

EVENTS_COLUMNS = ("onset", "duration", "trial_type", "sample", "side", "label")
EVENTS_JSON_BOTH: JsonObject = {  # beside the one-unit export's EVENTS_JSON
    "onset": {"Description": "time of the event on the session's common time line, from row "
                             "0 of both _motion.tsv files", "Units": "s"},
    "sample": {"Description": "0-based row of both _motion.tsv files nearest the onset (first "
                              "n/a row of a gap)"},
    "side": {"Description": "the leg whose unit recorded the event",
             "Levels": {"L": "left leg (tracksys-imuL)", "R": "right leg (tracksys-imuR)",
                        "n/a": "both (a marker set on both units)"}},
}  # fmt: skip
# (onset s, duration s, trial type, row, side, label)
Event = tuple[float, float, str, int | None, str, str]


def _events(grid: CommonGrid, an_hs: dict[str, np.ndarray], an_to: dict[str, np.ndarray],
            srcs: dict[str, Source], scrub: Scrubber) -> list[Event]:
    from gaitmon.export.writers.bids import NA, tsv_cell
    from gaitmon.export.writers.source import markers

    out: list[Event] = []
    for side in ("L", "R"):
        for kind, times in (("heel_strike", an_hs[side]), ("toe_off", an_to[side])):
            out += [(float(t), 0.0, kind, int(grid.frame_of(t)), side, NA) for t in times]
    marks: dict[tuple[int, str], list[Any]] = {}
    for side, src in srcs.items():
        c = grid.legs[side].common_s
        for m in markers(src, scrub):
            t = float(c[m["sample_idx"]])
            key = (int(grid.frame_of(t)), m["label"])
            if key in marks:  # one marker set on both units: one event, of both
                marks[key][4] = NA
            else:
                marks[key] = [t, 0.0, "marker", key[0], side, tsv_cell(m["label"])]
        out += _gaps(grid.legs[side], src, scrub, grid)
    out += [(e[0], e[1], e[2], e[3], e[4], e[5]) for e in marks.values()]
    order = {"gap": 0, "heel_strike": 1, "toe_off": 2, "marker": 3}
    return sorted(out, key=lambda e: (e[0], order[e[2]], e[4]))


def _gaps(leg: LegOnGrid, src: Source, scrub: Scrubber, grid: CommonGrid) -> list[Event]:
    """A leg's gaps inside its recording: the n/a rows between the rows around them."""
    from gaitmon.export.writers.bids import tsv_cell
    from gaitmon.export.writers.source import gaps

    c = leg.common_s
    out: list[Event] = []
    for g in gaps(src, scrub):
        row = g["sample_idx"]
        if 0 < row < src.n:
            first = int(grid.frame_of(c[row - 1])) + 1
            duration = (int(grid.frame_of(c[row])) - first) / grid.fs_hz
            out.append((first / grid.fs_hz, duration, "gap", first, leg.side,
                        tsv_cell(g["reason"])))  # fmt: skip
    return out


def _events_tsv(evs: list[Event]) -> str:
    from gaitmon.export.writers.bids import NA

    rows = ["\t".join(EVENTS_COLUMNS)]
    for e in evs:
        rows.append("\t".join((f"{e[0]:.6f}", f"{e[1]:.6f}", e[2],
                               NA if e[3] is None else str(e[3]), e[4], e[5])))  # fmt: skip
    return "\n".join(rows) + "\n"


def export_bids(job: ExportRequest) -> ExportResult:
    """One recording with two tracking systems on the common grid."""
    from gaitmon.export.grid import grid_of, on_grid
    from gaitmon.export.legs import analysed, leg_sources, meta_header, problems_of
    from gaitmon.export.writers.bids import (
        EVENTS_JSON,
        TSV_CHUNK_FRAMES,
        UNIT_FILES,
        Names,
        acq_time,
        channels,
        channels_json,
        channels_tsv,
        dataset_files,
        merge_tsv,
        tracksys,
        write_dataset_files,
        write_grid_tsv,
        write_json,
        write_text,
    )
    from gaitmon.export.writers.bids_labels import BidsOptions
    from gaitmon.export.writers.outputs import make_folders
    from gaitmon.export.writers.source import as_text
    from gaitmon.io.deidentify import Scrubber

    options = BidsOptions.from_mapping(job.options)
    with analysed(job) as (b, an, _), leg_sources(job) as srcs:
        grid = grid_of(b, srcs)
        session_attrs = srcs["L"].group_attrs("session")
        scrub = Scrubber(session_attrs, job.deidentify)
        pid = as_text(session_attrs.get("patient_id", ""))
        names = Names(job.out, options.subject_label(pid), options.session_label,
                      options.task_label)  # fmt: skip
        options.check_subject_free(job.out / "participants.tsv", pid)
        per_leg = {s: [names.motion(x, tracksys(s)) for x in UNIT_FILES] for s in srcs}
        finals = [p for s in srcs for p in per_leg[s]]
        finals += [names.motion("events.tsv", None), names.motion("events.json", None)]
        dated = acq_time(srcs["L"]) if not scrub.enabled else ""
        if dated:
            finals.append(names.scans)
        finals += dataset_files(job.out)
        chans = {s: channels(src) for s, src in srcs.items()}
        if not all(chans.values()):
            raise ExportError(f"{job.src_path.name} has no series to export as BIDS motion "
                              "channels")  # fmt: skip
        folders = make_folders(job.out, finals)
        head = meta_header(job, b)

        def write(tmps: list[Path]) -> None:
            tmp = dict(zip(finals, tmps, strict=True))
            for k, (side, src) in enumerate(srcs.items()):
                leg = grid.legs[side]
                motion, chan, chan_json, sidecar, own = (tmp[p] for p in per_leg[side])
                chunk = TSV_CHUNK_FRAMES if job.chunk_rows is None else job.chunk_rows
                write_grid_tsv(chans[side], grid.n_frames, partial(on_grid, leg, src), motion,
                               job.stage(0.45 * k, 0.45 * (k + 1)), job.cancel, chunk)
                write_text(chan, channels_tsv(src, chans[side]))
                write_json(chan_json, channels_json(chans[side]))
                write_json(sidecar, _sidecar(src, chans[side], grid, leg, scrub, names, head))
                write_json(own, _own(src, scrub, head))
            write_text(tmp[names.motion("events.tsv", None)],
                       _events_tsv(_events(grid, an.heel_strike_s, an.toe_off_s, srcs, scrub)))
            write_json(tmp[names.motion("events.json", None)], {**EVENTS_JSON, **EVENTS_JSON_BOTH})
            if dated:
                rows = [{"filename": per_leg[s][0].relative_to(names.folder).as_posix(),
                         "acq_time": dated} for s in srcs]  # fmt: skip
                write_text(tmp[names.scans], merge_tsv(names.scans, *rows))
            write_dataset_files(names, tmp, options, [per_leg[s][3] for s in srcs], pid)

        shared = frozenset(p for p in finals if p == names.scans
                           or p.name in ("participants.tsv", "README", ".bidsignore"))
        written = write_atomic(job, finals, write, folders, shared)
        n = sum(src.n for src in srcs.values())
        problems = problems_of(b, (p for src in srcs.values() for p in src.problems))
        mode = srcs["L"].mode
    step(job.progress, job.cancel, 1.0)
    return ExportResult(tuple(written), n, mode, problems)


def _sidecar(src: Source, chans: list[Channel], grid: CommonGrid, leg: LegOnGrid,
             scrub: Scrubber, names: Names, head: JsonObject) -> JsonObject:
    """The one-leg sidecar, for this tracking system on the common grid."""
    import numpy as np

    from gaitmon.export.writers.bids import NA, motion_sidecar, tracksys

    have = np.isfinite(leg.resample(np.ones((len(leg.common_s), 1)), 0, 0, grid.n_frames))[:, 0]
    frames = np.flatnonzero(have)
    common = head["common_time"]
    per_host_s = common.get("host_s_per_common_s") if isinstance(common, dict) else None
    # rows are k / fs common seconds; a common second is host_s_per_common_s host seconds
    effective: float | str = (round(grid.fs_hz / float(per_host_s), 6)
                              if isinstance(per_host_s, (int, float)) and per_host_s > 0
                              else NA)  # fmt: skip
    side = motion_sidecar(src, chans, grid.n_frames, frames, scrub, names.task,
                          tracksys(leg.side), effective)
    n_na = grid.n_frames - len(frames)
    side["SubjectArtefactDescription"] = (
        f"{n_na} rows of n/a: before this unit started, after it stopped, and where its link "
        "lost frames ('gap' events)" if n_na else NA)
    return scrub.mapping(side)


def _own(src: Source, scrub: Scrubber, head: JsonObject) -> JsonObject:
    """gaitmon's own metadata of this tracking system (``_gaitmon.json``)."""
    from gaitmon.export.writers.bids import gaitmon_sidecar
    from gaitmon.export.writers.source import json_safe

    return gaitmon_sidecar(
        src, scrub, "row k of _motion.tsv is the common time k / SamplingFrequency, as in the "
        "other tracking system's; this unit's samples resampled linearly onto it by its clock "
        "fit; n/a where it has none", time_line=json_safe(head["common_time"]))
