"""Session files: the one owner of the session file format of ``docs/file-format.md``.

Every read and write of a session file (and of its analysis state beside it) goes through this
package:

* :mod:`.layout` - format name and version, modes, dataset paths, dtypes, chunking;
* :mod:`.codec` - how format 2 stores each series (exact, quantised, derived on read);
* :mod:`.header` - :class:`SessionMeta`, :class:`SessionHeader`, :func:`device_info`,
  :class:`SessionError`;
* :mod:`.rows` - blocks to rows (pipeline and device blocks, the timeline);
* :mod:`.h5file` - the low-level HDF5 layout writer and fsync helpers;
* :mod:`.writer` - :class:`SessionWriter`, crash-safe recording (HDF5 + journal);
* :mod:`.recovery` - :func:`replay_pipeline`, :func:`recover_session`, :func:`build_session`
  (a whole file from rows in memory: the XDF import);
* :mod:`.reader` - :func:`open_session` / :class:`Session`, :class:`Marker`, :class:`Gap`;
* :mod:`.reprocess` - :func:`rewrite_processed`, a raw session re-run into a new file;
* :mod:`.smoothed` - the ``/smoothed`` zero-lag angles of raw sessions (the readers' default);
* :mod:`.stored_overview` - ``/overview``, the joint angles' min/max for a long session's first
  view;
* :mod:`.truth` - the ``/truth`` group of simulated sessions;
* :mod:`.parts`, :mod:`.combine`, :mod:`.bilateral` - bilateral sessions (both legs): the two
  units' parts while recording, combining them into one file with their clock fits, and
  :func:`~.bilateral.open_bilateral` (one leg: ``open_session(path, side="L")``);
* :mod:`.exclusions` - the user's excluded ranges, kept beside the recording in
  ``FILE.review.json`` (analysis state: the recording itself is never modified);
* :mod:`.deidentify` - a de-identified copy of a session file (``gaitmon batch --deidentify``).

Importing the package imports none of them (its ``__getattr__``): ``gaitmon info`` reads a file
without loading the writer, the device link or reprocessing.
"""

from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gaitmon.io.journal import journal_path
    from gaitmon.io.session.exclusions import Exclusion
    from gaitmon.io.session.header import SessionError, SessionHeader, SessionMeta, device_info
    from gaitmon.io.session.layout import (
        ANGLE_CONVENTION,
        CHUNK_ROWS,
        FORMAT,
        FORMAT_VERSION,
        LINK_TOTALS,
        MODES,
        per_sample_datasets,
    )
    from gaitmon.io.session.reader import Gap, Marker, Session, open_session
    from gaitmon.io.session.recovery import (
        build_session,
        flagged_at_start,
        flags_kept,
        recover_session,
        replay_pipeline,
    )
    from gaitmon.io.session.reprocess import RewriteResult, rewrite_processed
    from gaitmon.io.session.rows import rows_from_pipeline
    from gaitmon.io.session.truth import read_truth
    from gaitmon.io.session.writer import SessionWriter


def __getattr__(name: str) -> object:
    """A name of the package, imported from its module on first use (PEP 562): a plain
    import here, so the layer test sees the arrow; later lookups find it in the package."""
    if name == "journal_path":
        from gaitmon.io import journal

        return _keep(name, journal)
    if name == "Exclusion":
        from gaitmon.io.session import exclusions

        return _keep(name, exclusions)
    if name in ("SessionError", "SessionHeader", "SessionMeta", "device_info"):
        from gaitmon.io.session import header

        return _keep(name, header)
    if name in (
        "ANGLE_CONVENTION",
        "CHUNK_ROWS",
        "FORMAT",
        "FORMAT_VERSION",
        "LINK_TOTALS",
        "MODES",
        "per_sample_datasets",
    ):
        from gaitmon.io.session import layout

        return _keep(name, layout)
    if name in ("Gap", "Marker", "Session", "open_session"):
        from gaitmon.io.session import reader

        return _keep(name, reader)
    if name in (
        "build_session",
        "flagged_at_start",
        "flags_kept",
        "recover_session",
        "replay_pipeline",
    ):
        from gaitmon.io.session import recovery

        return _keep(name, recovery)
    if name in ("RewriteResult", "rewrite_processed"):
        from gaitmon.io.session import reprocess

        return _keep(name, reprocess)
    if name == "rows_from_pipeline":
        from gaitmon.io.session import rows

        return _keep(name, rows)
    if name == "read_truth":
        from gaitmon.io.session import truth

        return _keep(name, truth)
    if name == "SessionWriter":
        from gaitmon.io.session import writer

        return _keep(name, writer)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _keep(name: str, module: ModuleType) -> object:
    value = getattr(module, name)
    globals()[name] = value  # found once; later lookups are plain
    return value


__all__ = [
    "ANGLE_CONVENTION",
    "CHUNK_ROWS",
    "FORMAT",
    "FORMAT_VERSION",
    "LINK_TOTALS",
    "MODES",
    "Exclusion",
    "Gap",
    "Marker",
    "RewriteResult",
    "Session",
    "SessionError",
    "SessionHeader",
    "SessionMeta",
    "SessionWriter",
    "build_session",
    "device_info",
    "flagged_at_start",
    "flags_kept",
    "journal_path",
    "open_session",
    "per_sample_datasets",
    "read_truth",
    "recover_session",
    "replay_pipeline",
    "rewrite_processed",
    "rows_from_pipeline",
]
