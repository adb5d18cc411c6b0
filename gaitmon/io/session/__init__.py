"""Session files: the one owner of the session file format of ``docs/file-format.md``.

The format stores and reads; it computes nothing the pipeline makes (the finishing layer,
:mod:`gaitmon.finish`, recovers, reprocesses and derives ``/smoothed`` and ``/strides``, and
its :func:`gaitmon.finish.open_session` is how a session is opened by path). Every read and
write of a session file (and of its analysis state beside it) goes through this package:

* :mod:`.layout` - format name and version, modes, dataset paths, dtypes, chunking, the
  ``/smoothed`` paths;
* :mod:`.codec` - how format 2 stores each series (exact, quantised, derived on read);
* :mod:`.attributes` - the CF-style attributes (units, scale_factor, columns...) of every
  dataset, so a reader without gaitmon gets physical values;
* :mod:`.header` - :class:`SessionMeta`, :class:`SessionHeader`, :func:`device_info`,
  :class:`SessionError`;
* :mod:`.rows` - blocks to rows (pipeline and device blocks, the timeline);
* :mod:`.h5file` - the low-level HDF5 layout writer and fsync helpers;
* :mod:`.writer` - :class:`SessionWriter`, crash-safe recording (HDF5 + journal);
* :mod:`.reader` - :class:`StoredSession`, what a file stores; :mod:`.series` -
  :class:`Marker`, :class:`Gap`, the series view and the checks of a file's edge;
  :mod:`.opening` - a file opened as it is (:func:`read_stored`); :mod:`.trust` - what a file
  from elsewhere may make gaitmon read (only itself, within a bound on memory: checked at open);
* :mod:`.stored_overview` - ``/overview``, the joint angles' min/max for a long session's first
  view;
* :mod:`.truth` - the ``/truth`` group of simulated sessions;
* :mod:`.parts` - the two units' parts of a recording of both legs (combined by
  :mod:`gaitmon.finish.combine`);
* :mod:`.exclusions` - the user's excluded ranges, kept beside the recording in
  ``FILE.review.json`` (analysis state: the recording itself is never modified);
* :mod:`.deidentify` - a de-identified copy of a session file (``gaitmon batch --deidentify``).

Importing the package imports none of them (its ``__getattr__``): ``gaitmon info`` reads a file
without loading the writer, the device link or reprocessing.
"""

from typing import TYPE_CHECKING

from gaitmon.lazy import keep

if TYPE_CHECKING:
    from gaitmon.io.journal_files import journal_path
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
    from gaitmon.io.session.opening import read_stored
    from gaitmon.io.session.reader import StoredSession
    from gaitmon.io.session.rows import rows_from_pipeline
    from gaitmon.io.session.series import AttrValue, Gap, Marker
    from gaitmon.io.session.truth import read_truth
    from gaitmon.io.session.writer import SessionWriter


def __getattr__(name: str) -> object:
    """A name of the package, imported from its module on first use (PEP 562): a plain
    import here, so the layer test sees the arrow; later lookups find it in the package."""
    if name == "journal_path":
        from gaitmon.io import journal_files

        return keep(globals(), name, journal_files)
    if name == "Exclusion":
        from gaitmon.io.session import exclusions

        return keep(globals(), name, exclusions)
    if name in ("SessionError", "SessionHeader", "SessionMeta", "device_info"):
        from gaitmon.io.session import header

        return keep(globals(), name, header)
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

        return keep(globals(), name, layout)
    if name in ("AttrValue", "Gap", "Marker"):
        from gaitmon.io.session import series

        return keep(globals(), name, series)
    if name == "StoredSession":
        from gaitmon.io.session import reader

        return keep(globals(), name, reader)
    if name == "read_stored":
        from gaitmon.io.session import opening

        return keep(globals(), name, opening)
    if name == "rows_from_pipeline":
        from gaitmon.io.session import rows

        return keep(globals(), name, rows)
    if name == "read_truth":
        from gaitmon.io.session import truth

        return keep(globals(), name, truth)
    if name == "SessionWriter":
        from gaitmon.io.session import writer

        return keep(globals(), name, writer)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")



__all__ = [
    "ANGLE_CONVENTION",
    "CHUNK_ROWS",
    "FORMAT",
    "FORMAT_VERSION",
    "LINK_TOTALS",
    "MODES",
    "AttrValue",
    "Exclusion",
    "Gap",
    "Marker",
    "SessionError",
    "SessionHeader",
    "SessionMeta",
    "SessionWriter",
    "StoredSession",
    "device_info",
    "journal_path",
    "per_sample_datasets",
    "read_stored",
    "read_truth",
    "rows_from_pipeline",
]
