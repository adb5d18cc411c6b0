"""A de-identified copy of a session file (``gaitmon batch --deidentify`` writes these).

The same things leave the file as leave a de-identified export (the lists of
:mod:`gaitmon.io.deidentify`, docs/file-format.md "De-identified session files"):

* ``/session`` ``patient_id``, ``operator`` and ``notes`` are blanked, and their values are
  removed from the marker labels (typed, or sent by another program) and from the file names
  quoted in gaitmon's own texts (gap reasons, the stop reason), never from gaitmon's words;
* ``/device`` ``serial`` and ``transport`` (a serial port or Bluetooth address names the unit)
  are blanked, as for a unit that did not say who it is;
* the recording's date: the root ``created_utc`` is left out, the host clock
  (``/timeline/host_time_s``) starts at 0 and its ``wall_offset_s`` is left out.

Every measurement, event, setting and calibration is kept, so the copy opens in review and
reprocesses like the original. HDF5 does not erase what an attribute held before it was
rewritten (the bytes stay in the file's free space), so the cleaned file is copied object by
object into a new file, which holds only what is live; the cleaned work file is then deleted.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import h5py
import numpy as np

from gaitmon.io.deidentify import (
    DEVICE_FIELDS_DROPPED,
    IDENTIFYING_FIELDS,
    REDACTED,
    ROOT_FIELDS_DROPPED,
    scrub_file_names,
    scrub_free_text,
)
from gaitmon.io.session.layout import _STR
from gaitmon.io.session.series import attr_text

# texts that may hold an identifying value: (dataset, field, typed by a person?), and root
# attributes gaitmon composed (they may quote a file name)
_TEXT_FIELDS: tuple[tuple[str, str, bool], ...] = (("markers", "label", True),
                                                   ("gaps", "reason", False))  # fmt: skip
_ROOT_TEXTS: tuple[str, ...] = ("stop_reason",)
WALL_OFFSET_ATTR = "wall_offset_s"




def secrets_of(f: h5py.File) -> list[str]:
    """The identifying values of a session (longest first, so one containing another goes
    whole)."""
    attrs = f["session"].attrs if "session" in f else {}
    values = {attr_text(attrs.get(k, "")).strip() for k in IDENTIFYING_FIELDS}
    return sorted((v for v in values if v), key=len, reverse=True)


def _clean_in_place(f: h5py.File) -> None:
    secrets = [(s, REDACTED) for s in secrets_of(f)]
    for key in ROOT_FIELDS_DROPPED:
        if key in f.attrs:
            del f.attrs[key]
    for key in _ROOT_TEXTS:
        if key in f.attrs:
            f.attrs[key] = scrub_file_names(attr_text(f.attrs[key]), secrets)
    if "session" in f:
        for key in IDENTIFYING_FIELDS:
            f["session"].attrs.create(key, "", dtype=_STR)
    if "device" in f:
        for key in DEVICE_FIELDS_DROPPED:
            if key in f["device"].attrs:
                f["device"].attrs.create(key, "", dtype=_STR)
    if "timeline/host_time_s" in f:
        host = f["timeline/host_time_s"]
        if WALL_OFFSET_ATTR in host.attrs:
            del host.attrs[WALL_OFFSET_ATTR]
        if host.shape and host.shape[0]:
            values = host[...]
            host[...] = values - values[0]
    for path, field, typed in _TEXT_FIELDS:
        if path not in f or f[path].shape == (0,):
            continue
        rows = f[path][...]
        texts = [attr_text(t) for t in rows[field]]
        scrub = scrub_free_text if typed else scrub_file_names
        cleaned = [scrub(t, secrets) for t in texts]
        if cleaned != texts:
            rows[field] = np.array(cleaned, dtype=object)
            f[path][...] = rows


def _copy_live(src: h5py.File, dst: h5py.File) -> None:
    for key in src.attrs:
        dst.attrs.create(key, src.attrs[key], dtype=src.attrs.get_id(key).dtype)
    for name in src:
        src.copy(src[name], dst, name=name)


def write_deidentified(work: Path, dst: Path) -> None:
    """Clean ``work`` (a session file of ours: it is modified, then deleted) and write the
    result to ``dst`` (built as ``dst.partial`` and moved into place)."""
    work, dst = Path(work), Path(dst)
    tmp = dst.with_name(dst.name + ".partial")
    try:
        with h5py.File(work, "r+") as f:
            _clean_in_place(f)
        with h5py.File(work, "r") as f, h5py.File(tmp, "w") as g:
            _copy_live(f, g)
        os.replace(tmp, dst)
    finally:
        for p in (tmp, work):
            with contextlib.suppress(OSError):
                p.unlink()
