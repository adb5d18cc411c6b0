"""One reader of HDF5 text attributes (`attr_text`), as h5py hands them over from real files."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from gaitmon.io.session.series import attr_text


def test_text_attributes_read_the_same_however_they_were_stored(tmp_path: Path) -> None:
    p = tmp_path / "a.h5"
    with h5py.File(p, "w") as f:
        f.attrs["str"] = "raw"
        f.attrs["bytes"] = np.bytes_(b"raw")  # fixed-length ASCII, as MATLAB and older tools write
        f.attrs.create("vlen", "raw", dtype=h5py.string_dtype("utf-8"))
        f.attrs["damaged"] = np.void(b"r\xffw")  # opaque bytes, not UTF-8
        f.attrs["umlaut"] = np.bytes_("Müller".encode())
    with h5py.File(p, "r") as f:
        assert [attr_text(f.attrs[k]) for k in ("str", "bytes", "vlen")] == ["raw"] * 3
        assert attr_text(f.attrs["umlaut"]) == "Müller"
        assert attr_text(f.attrs["damaged"].tobytes()) == "r\ufffdw"  # replaced, never raised
    assert attr_text(np.array(b"raw")) == "raw"  # a 0-d array, as some fields come back
    assert attr_text(np.array("raw")) == "raw"
    assert attr_text(3) == "3"
