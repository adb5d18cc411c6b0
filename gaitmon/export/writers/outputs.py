"""Where an export writes: derived output names, checks, and atomic writes.

Every output is written to a temporary name beside it and renamed into place at the end, so an
error, a cancel or Ctrl-C never leaves a half-written file under the final name.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

from gaitmon.export.writers.errors import ExportError


def csv_meta_path(csv_path: Path) -> Path:
    """The JSON side file written beside a CSV export: <stem>.meta.json."""
    return csv_path.with_name(csv_path.stem + ".meta.json")


def c3d_part_path(c3d_path: Path, part: int) -> Path:
    """Part k (1-based) of a split C3D export: <stem>_part001.c3d, ..."""
    return c3d_path.with_name(f"{c3d_path.stem}_part{part:03d}{c3d_path.suffix}")


def _tmp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.partial")


class AtomicOutputs:
    """Collects temp files; renames them into place on success, deletes them on failure."""

    def __init__(self) -> None:
        self.pairs: list[tuple[Path, Path]] = []

    def tmp(self, final: Path, suffix: str = "") -> Path:
        """The temporary name for ``final`` (``suffix`` appended, for writers that insist)."""
        t = _tmp_path(final)
        t = t.with_name(t.name + suffix)
        self.pairs.append((t, final))
        return t

    def final_of(self, name: object, default: Path) -> Path:
        """The final output a temporary ``name`` stands for (an OSError's filename): the
        user chose that name, never saw the temporary one; ``default`` if it is none."""
        if isinstance(name, (str, os.PathLike)):
            for t, final in self.pairs:
                if os.fspath(t) == os.fspath(name) or os.fspath(final) == os.fspath(name):
                    return final
            return Path(name)
        return default

    def commit(self) -> list[Path]:
        for t, final in self.pairs:
            os.replace(t, final)
        return [final for _, final in self.pairs]

    def discard(self, folders: list[Path] | None = None) -> None:
        """Delete the temporary files, then ``folders`` (those the export made) if empty."""
        for t, _ in self.pairs:
            # OSError, not only FileNotFoundError: a read-only drive answers EROFS even for
            # a file that was never made, and that must not hide why the export failed
            with contextlib.suppress(OSError):
                t.unlink()
        for d in sorted(folders or (), key=lambda p: len(p.parts), reverse=True):
            with contextlib.suppress(OSError):  # not empty: something else is in it
                d.rmdir()


def make_folders(root: Path, paths: list[Path]) -> list[Path]:
    """Create the folders of a folder format's outputs (``root`` and below it); returns the
    ones made here, so a failed export can remove them again."""
    if root.exists() and not root.is_dir():
        raise ExportError(f"output {root} is a file; a {root.name!r} folder is needed here")
    if not root.parent.is_dir():
        raise ExportError(f"output folder does not exist: {root.parent}")
    made: list[Path] = []
    for folder in sorted({p.parent for p in paths}, key=lambda p: len(p.parts)):
        missing = [d for d in (folder, *folder.parents) if not d.exists()]
        for d in reversed(missing):
            d.mkdir()
            made.append(d)
    return made


def check_outputs(paths: list[Path], src_path: Path, force: bool) -> None:
    for p in paths:
        if p.resolve() == src_path.resolve():
            raise ExportError(f"refusing to overwrite the session file itself: {p}")
        if p.is_dir():
            raise ExportError(f"output {p} is a directory")
        if p.exists() and not force:
            raise ExportError(f"{p} already exists (use --force to overwrite)")
        if not p.parent.is_dir():
            raise ExportError(f"output folder does not exist: {p.parent}")
