"""Reprocessing a bilateral session: each unit through the one-unit path.

``gaitmon process both.h5 -o new.h5`` reprocesses every unit of the file: ``new.h5`` is a copy
of the whole bilateral file (``/sync`` and the common time base unchanged: the clock fits come
from the receive times, which reprocessing does not touch) in which each ``/units/<side>`` is
rewritten in place by :func:`gaitmon.finish.reprocess.rewrite_unit`, the same code a
one-unit file goes through. ``side="L"`` reprocesses one leg into a one-unit file: that unit's
layout copied to the root of a new file (its attributes with it), then rewritten the same way.
As for one unit, the new file is built as ``NEW.partial`` and moved into place; the original is
never modified.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import h5py

from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.finish.bilateral import open_bilateral
from gaitmon.finish.reprocess import (
    COPY_SHARE,
    Cancel,
    Progress,
    RewriteResult,
    UnitInputs,
    _building,
    _canceller,
    _copy,
    _reporter,
    check_destination,
    partial_path,
    rewrite_unit,
)
from gaitmon.io.session.attributes import described_once
from gaitmon.io.session.header import SessionError
from gaitmon.io.session.parts import SIDE_NAMES
from gaitmon.io.session.trust import written_here

Configure = Callable[[PipelineConfig], PipelineConfig]  # a unit's recorded settings -> new


def rewrite_bilateral(
    src: str | os.PathLike[str],
    dst: str | os.PathLike[str],
    configure: Configure,
    *,
    side: str | None = None,
    progress: Progress | None = None,
    cancel: Cancel | None = None,
    overwrite: bool = False,
) -> dict[str, RewriteResult]:
    """Write ``dst``: the bilateral session ``src`` with every unit (or only ``side``, as a
    one-unit file) reprocessed with ``configure(its recorded settings)``. Progress, Cancel and
    errors as :func:`gaitmon.finish.reprocess.rewrite_processed`; by side, what each unit
    became."""
    src, dst = Path(src), Path(dst)
    check_destination(src, dst, overwrite)
    report = _reporter(progress)
    check_cancel = _canceller(cancel)
    report(0.0)
    with open_bilateral(src) as b:  # (recovers and combines an interrupted recording first)
        if side is not None and side not in b.units:
            raise SessionError(
                f"{src.name} has no {SIDE_NAMES.get(side, side)} leg (it has "
                f"{' and '.join(SIDE_NAMES[s] for s in b.sides)})"
            )
        sides = [side] if side is not None else list(b.sides)
        units = {s: UnitInputs.of(b.unit(s)) for s in sides}
    configs = {s: configure(u.config) for s, u in units.items()}
    tmp = partial_path(dst)
    with _building(tmp, dst, src):
        if side is None:
            _copy(src, tmp, lambda f: report(COPY_SHARE * f), check_cancel)
        else:
            _copy_unit(src, tmp, side)
        total = max(1, sum(u.n for u in units.values()))
        done = 0
        # described once when whole: the units, and /sync (a file from before the attributes)
        with h5py.File(tmp, "r+") as f, described_once(f):
            for s, unit in units.items():
                root = f if side is not None else f[f"units/{s}"]

                def sub(x: float, before: int = done, n: int = unit.n) -> None:
                    report(COPY_SHARE + (1.0 - COPY_SHARE) * (before + x * n) / total)

                rewrite_unit(root, unit, configs[s], sub, check_cancel)
                done += unit.n
        check_cancel()
        os.replace(tmp, dst)
    written_here(dst)  # (read back next: the summary)
    report(1.0)
    return {s: RewriteResult(dst, u.n, configs[s]) for s, u in units.items()}


def _copy_unit(src: Path, tmp: Path, side: str) -> None:
    """One unit's whole layout (and its attributes) as the root of a new one-unit file."""
    with h5py.File(src, "r") as fs, h5py.File(tmp, "w") as fd:
        g = fs[f"units/{side}"]
        for key, value in g.attrs.items():
            fd.attrs[key] = value
        for name in g:
            g.copy(g[name], fd, name=name)
