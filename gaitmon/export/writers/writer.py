"""The contract of one unit's file writer (csv, mat, c3d, bids here; strides in
:mod:`gaitmon.export.strides`): what a format plugin (:mod:`gaitmon.export`) is given to
write one unit of a session."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from gaitmon.export.writers.errors import Cancel, Progress

if TYPE_CHECKING:
    from gaitmon.export.writers.source import Source
    from gaitmon.io.deidentify import Scrubber


class FormatWriter(Protocol):
    """What a one-unit writer provides (mypy checks csv, mat, c3d and bids against it where
    their plugins hand them out, :mod:`gaitmon.export`)."""

    def planned_outputs(self, src: Source, scrub: Scrubber, out: Path) -> list[Path]:
        """The final paths this export will write for the output name ``out``."""
        ...

    def write(self, src: Source, outputs: list[Path], scrub: Scrubber, deidentify: bool,
              progress: Progress | None, cancel: Cancel | None, chunk_rows: int | None) -> None:
        """Write the files; ``outputs`` are the temporary names of ``planned_outputs``, in
        the same order. ``chunk_rows`` is the read chunk of streaming formats (None:
        their default); formats that read whole series ignore it."""
        ...

    # Optional: ``merges_existing(path) -> bool`` says an output is a file several exports
    # share and add a row to (BIDS participants.tsv): it may exist already without --force.
