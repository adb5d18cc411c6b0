"""What the exports of a session of both legs share: the session opened as both legs and
analysed (its two-leg tables, :mod:`.tables`), each leg as the one-unit writers read it, and
the header of the two-leg side files (the common time line)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import TYPE_CHECKING

from gaitmon.export.base import ExportRequest
from gaitmon.export.writers.errors import ExportError

if TYPE_CHECKING:
    from collections.abc import Iterable

    from gaitmon.analysis import BilateralAnalysis
    from gaitmon.export.tables import BilateralTables
    from gaitmon.export.writers.source import Source
    from gaitmon.finish.bilateral import Bilateral
    from gaitmon.values import JsonObject


@contextlib.contextmanager
def analysed(job: ExportRequest) -> Iterator[tuple[Bilateral, BilateralAnalysis, BilateralTables]]:
    """The session opened as both legs, its analysis and its tables."""
    from gaitmon.analysis import analyse_bilateral
    from gaitmon.export.tables import bilateral_tables
    from gaitmon.finish.bilateral import open_bilateral
    from gaitmon.io.session import SessionError

    try:
        b = open_bilateral(job.src_path)
    except SessionError as exc:
        raise ExportError(str(exc)) from None
    with b:
        if set(b.sides) != {"L", "R"}:
            raise ExportError(f"{job.src_path.name} holds one leg only; export it with --side")
        an = analyse_bilateral(b)
        yield b, an, bilateral_tables(b, an)


@contextlib.contextmanager
def leg_sources(job: ExportRequest) -> Iterator[dict[str, Source]]:
    """Each leg as the one-leg exporters read it (angles as asked; host clock from 0 when
    de-identified, as ``export_session`` does)."""
    from gaitmon.export.writers.source import open_source

    with contextlib.ExitStack() as stack:
        srcs = {s: stack.enter_context(open_source(job.src_path, job.angles, s))
                for s in ("L", "R")}  # fmt: skip
        if job.deidentify:
            for src in srcs.values():
                src.shift_host_time()
        yield srcs


def meta_header(job: ExportRequest, b: Bilateral) -> JsonObject:
    """What every bilateral side file says of the export and of the common time line."""
    from gaitmon.export.writers.source import export_header_fields

    head = export_header_fields(f"bilateral-{job.fmt}", job.deidentify)
    if not job.deidentify:
        head["source_file"] = job.src_path.name
    common: JsonObject = {
        "definition": "common_s = (host(side, t_s) - host_t0_s) / host_s_per_common_s: each "
                      "unit's clock fit (/sync) mapped onto one time line, 0 at the first "
                      "sample of the unit that started first (docs/bilateral.md)",
        "host_s_per_common_s": b.host_s_per_common_s,
        "clock_ppm": {s: (b.host_s_per_common_s / b.sync[s].mean_slope - 1.0) * 1e6
                      for s in b.sides},
        "receive_delay_p95_ms": {s: b.sync[s].residual_p95_ms for s in b.sides},
        **caveat_fields(b),
    }  # fmt: skip
    head["common_time"] = common
    return head


def caveat_fields(b: Bilateral) -> JsonObject:
    """What may make the two-leg figures misleading (``Bilateral.caveats``: the sentences the
    report and review show), as fields of ``common_time``; none when there is nothing to say
    (so an ordinary session's metadata is as it was): ``clock_warning`` (the clock fits
    disagreed), ``together_s`` and ``together`` (both legs recorded together briefly)."""
    out: JsonObject = {}
    for c in b.caveats():
        if c.key == "warning":
            out["clock_warning"] = c.sentence
        else:
            out["together_s"] = round(c.together_s, 3)
            out["together"] = c.sentence
    return out


def problems_of(b: Bilateral, legs: Iterable[str]) -> tuple[str, ...]:
    """The export's notes (``ExportResult.problems``: ``gaitmon export`` warns of each, the
    export dialog shows them): the caveats' sentences, then the legs' own problems, once each."""
    return tuple(dict.fromkeys([*(c.sentence for c in b.caveats()), *legs]))
