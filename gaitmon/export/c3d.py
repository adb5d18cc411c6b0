"""The C3D format: angles as POINTs, raw channels as ANALOGs, gait events as EVENTs (the
one-unit writer: :mod:`gaitmon.export.writers.c3d`); both legs in one file on one frame grid.

For both legs, points and analogs are each unit's, as the one-unit C3D has them, named with
their side as Plug-in Gait does (``LKneeAngles``, ``RKneeAngles``; the trunk ``LBodyTilt`` /
``RBodyTilt``: each unit has its own trunk sensor; analogs ``L_<channel>``, ``R_<channel>``),
resampled onto the common grid (:mod:`.grid`). Heel strikes and toe offs are ``Foot Strike`` /
``Foot Off`` events in the ``Left`` / ``Right`` contexts (as Vicon Nexus and pyCGM2 read
them), at their exact common times (``analyse_bilateral``'s); clinician markers in
``General``. Parts as the one-unit C3D (600 s, 255 events).
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from gaitmon.export.base import ExportRequest, ExportResult, Format, write_atomic
from gaitmon.export.writers.errors import step

if TYPE_CHECKING:
    import numpy as np

    from gaitmon.export.grid import CommonGrid
    from gaitmon.export.writers.c3d_file import C3dSpec
    from gaitmon.export.writers.source import Source
    from gaitmon.export.writers.writer import FormatWriter
    from gaitmon.io.deidentify import Scrubber


@dataclass(frozen=True)
class C3dFormat(Format):
    def unit_writer(self, options: Mapping[str, object] | None) -> FormatWriter:
        from gaitmon.export.writers import c3d

        self.no_options(options)
        return c3d

    def export_units(self, request: ExportRequest) -> ExportResult:
        return export_c3d(request)


# ezc3d adds ".c3d" to a temporary name not ending in it
C3D = C3dFormat("c3d", ".c3d", "C3D (Mokka, Nexus, btk; angles as points, events)",
                temp_suffix=".c3d")

CONTEXT = {"L": "Left", "R": "Right"}
# (common time s, context, label, description, icon id) of one event
Event = tuple[float, str, str, str, int]


def events(an_hs: dict[str, np.ndarray], an_to: dict[str, np.ndarray], grid: CommonGrid,
           srcs: dict[str, Source], scrub: Scrubber) -> list[Event]:
    """Both legs' gait events and the markers, by time (strikes before offs at one time)."""
    from gaitmon.export.writers.source import markers

    out: list[Event] = []
    for side in ("L", "R"):
        out += [(float(t), CONTEXT[side], "Foot Strike", "heel strike", 1) for t in an_hs[side]]
        out += [(float(t), CONTEXT[side], "Foot Off", "toe off", 2) for t in an_to[side]]
    seen = set()
    for side, src in srcs.items():
        c = grid.legs[side].common_s
        for m in markers(src, scrub):  # one marker set on both units is one event
            key = (int(grid.frame_of(c[m["sample_idx"]])), m["label"])
            if key not in seen:
                seen.add(key)
                out.append((float(c[m["sample_idx"]]), "General", m["label"][:64] or "Marker",
                            "clinician marker", 0))  # fmt: skip
    return sorted(out, key=lambda e: e[0])


def _part_spec(job: ExportRequest, grid: CommonGrid, srcs: dict[str, Source],
               part: tuple[int, int], part_no: int, n_parts: int, evs: list[Event],
               scrub: Scrubber, caveats: tuple[str, ...] = ()) -> C3dSpec:
    import numpy as np

    from gaitmon.export.grid import on_grid
    from gaitmon.export.writers.c3d import (
        device_text,
        leg_analogs,
        leg_points,
        put_analogs,
        put_events,
        put_gaitmon,
        put_points,
    )
    from gaitmon.export.writers.c3d_file import C3dSpec
    from gaitmon.export.writers.source import as_text
    from gaitmon.io.deidentify import ANONYMOUS, IDENTIFYING_FIELDS

    f0, f1 = part
    nf = f1 - f0
    fs = grid.fs_hz
    points, analogs = [], []
    for side, src in srcs.items():
        read = on_grid(grid.legs[side], src, f0, f1)
        points.append(leg_points(src, read, side, side))
        analogs.append(leg_analogs(src, read, side + "_"))
    c = C3dSpec()
    put_points(c, fs, nf, *points)
    put_analogs(c, fs, nf, *analogs)
    subject = (ANONYMOUS if job.deidentify
               else as_text(srcs["L"].group_attrs("session").get("patient_id", "")) or ANONYMOUS)
    frames = grid.frame_of(np.array([e[0] for e in evs]))
    t0 = f0 / fs
    put_events(c, nf, subject, [(e[0] - t0, *e[1:]) for e, fr in zip(evs, frames, strict=True)
                                if f0 <= fr < f1])  # fmt: skip
    session = scrub.session({**{k: "" for k in IDENTIFYING_FIELDS},
                             **srcs["L"].group_attrs("session")})
    device = "; ".join(f"{s}: {device_text(scrub.device(src.group_attrs('device')))}"
                       for s, src in srcs.items())  # fmt: skip
    put_gaitmon(c, srcs["L"], scrub, job.deidentify, "both", device, session,
                (part_no, n_parts, t0))
    c.add_parameter("GAITMON", "TIME_LINE", "common: frame 1 at PART_START_S; each unit "
                    "resampled linearly by its clock fit (docs/bilateral.md)")
    if caveats:  # what may make the legs' relative timing misleading (Bilateral.caveats)
        c.add_parameter("GAITMON", "CAUTION", [ln for s in caveats for ln in textwrap.wrap(s, 80)],
                        "may make the two legs' figures misleading (docs/bilateral.md)")
    return c


def export_c3d(job: ExportRequest) -> ExportResult:
    """One file (or its parts) of both legs on the common grid."""
    import numpy as np

    from gaitmon.export.grid import grid_of
    from gaitmon.export.legs import analysed, leg_sources, problems_of
    from gaitmon.export.writers.c3d import part_frames, split_parts, write_c3d_parts
    from gaitmon.export.writers.outputs import c3d_part_path
    from gaitmon.io.deidentify import Scrubber

    with analysed(job) as (b, an, _), leg_sources(job) as srcs:
        grid = grid_of(b, srcs)
        scrub = Scrubber(srcs["L"].group_attrs("session"), job.deidentify)
        evs = events(an.heel_strike_s, an.toe_off_s, grid, srcs, scrub)
        ev_frames = np.sort(grid.frame_of(np.array([e[0] for e in evs])))
        parts = split_parts(grid.n_frames, part_frames(grid.fs_hz), ev_frames)
        finals = ([job.out] if len(parts) == 1
                  else [c3d_part_path(job.out, k + 1) for k in range(len(parts))])

        caveats = tuple(c.sentence for c in b.caveats())

        def specs() -> Iterator[C3dSpec]:
            for k, part in enumerate(parts):
                yield _part_spec(job, grid, srcs, part, k, len(parts), evs, scrub, caveats)

        def write(tmps: list[Path]) -> None:
            write_c3d_parts(specs(), tmps, job.progress, job.cancel)

        written = write_atomic(job, finals, write)
        n = sum(src.n for src in srcs.values())
        problems = problems_of(b, (p for src in srcs.values() for p in src.problems))
        mode = srcs["L"].mode
    step(job.progress, job.cancel, 1.0)
    return ExportResult(tuple(written), n, mode, problems)
