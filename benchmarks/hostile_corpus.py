"""Hostile variants of a real recorded session (issue 26, items 1 and 6): files that try to make
gaitmon read other files or more memory than they hold.

``make_hostile(src, out_dir)`` copies one good session file into the variants below and returns
``[(path, description), ...]``; ``SECRET`` is a marker that only the files *outside* the
session hold (a "secret" text file and a foreign session's patient id), so any output holding
it was read from outside the session file:

* ``external_storage``: ``/raw/adc`` stored in an outside file (HDF5 external raw storage);
* ``external_link_session`` / ``external_link_adc``: ``/session`` or ``/raw/adc`` an HDF5
  external link into a foreign session (whose patient id is the secret);
* ``virtual_adc``: ``/raw/adc`` a virtual dataset mapping the foreign session's counts;
* ``counts_5000``: counts above the 12-bit ADC's 4095;
* ``huge_shape``: every per-sample dataset resized to 10^12 rows (nothing written);
* ``huge_events`` / ``huge_markers``: the heel strikes / markers table declared 10^12 rows;
* ``huge_attr_text``: a text attribute (the notes) of ``big_attr_bytes``;
* ``huge_attr_array``: a numeric attribute of ``big_attr_bytes`` (``/device`` rewritten with
  HDF5's newest object headers, which hold attributes above 64 KiB).

Used by ``tests/test_hostile_files.py`` and ``benchmarks/faults/hostile.py``. Run alone:

    python benchmarks/hostile_corpus.py SESSION.h5 OUT_DIR
"""

from __future__ import annotations

import argparse
import shutil
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

SECRET = "GAITMON-SECRET-7f3a"
HUGE_ROWS = 10**12
# per-sample datasets of a format-2 raw session (docs/file-format.md)
_PER_SAMPLE = (
    "timeline/seq", "timeline/host_time_s", "timeline/t_s", "raw/adc", "processed/tilt_deg",
    "processed/tilt_acc_deg", "processed/tilt_gyro_deg", "processed/acc_ms2",
    "processed/fsr_counts", "processed/heel_loaded", "processed/toe_loaded", "processed/phase",
)  # fmt: skip

Variant = tuple[Path, str]


def _edit(src: Path, dst: Path, edit: Callable[[h5py.File], None], **kw: object) -> Path:
    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+", **kw) as f:  # type: ignore[arg-type]
        edit(f)
    return dst


def make_hostile(src: Path, out_dir: Path, big_attr_bytes: int = 4 << 20) -> list[Variant]:
    """The hostile variants of the session ``src`` in ``out_dir`` (see the module's text)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    secret = out_dir / "secret.txt"
    with h5py.File(src, "r") as f:
        n, n_ch = f["raw/adc"].shape
    text = (SECRET + " root:x:0:0:root:/root:/bin/bash\n").encode()
    secret.write_bytes((text * (2 * n * n_ch // len(text) + 1))[: 2 * n * n_ch])
    # a foreign session: another patient's, whose counts are all 1234
    foreign = out_dir / "foreign.h5"

    def foreign_edit(f: h5py.File) -> None:
        f["session"].attrs["patient_id"] = SECRET
        f["raw/adc"][...] = 1234

    _edit(src, foreign, foreign_edit)
    out: list[Variant] = []

    def add(name: str, what: str, edit: Callable[[h5py.File], None], **kw: object) -> None:
        out.append((_edit(src, out_dir / f"{name}.h5", edit, **kw), what))

    def external_storage(f: h5py.File) -> None:
        del f["raw/adc"]
        f.create_dataset("raw/adc", shape=(n, n_ch), dtype="<u2",
                         external=[(str(secret), 0, h5py.h5f.UNLIMITED)])  # fmt: skip

    def link_session(f: h5py.File) -> None:
        del f["session"]
        f["session"] = h5py.ExternalLink(str(foreign), "/session")

    def link_adc(f: h5py.File) -> None:
        del f["raw/adc"]
        f["raw/adc"] = h5py.ExternalLink(str(foreign), "/raw/adc")

    def virtual_adc(f: h5py.File) -> None:
        del f["raw/adc"]
        layout = h5py.VirtualLayout(shape=(n, n_ch), dtype="<u2")
        layout[:] = h5py.VirtualSource(str(foreign), "raw/adc", shape=(n, n_ch))
        f["raw"].create_virtual_dataset("adc", layout)

    def counts_5000(f: h5py.File) -> None:
        f["raw/adc"][n // 2 : n // 2 + 10, 3] = 5000

    def huge_shape(f: h5py.File) -> None:
        for p in _PER_SAMPLE:
            ds = f[p]
            ds.resize(HUGE_ROWS, axis=0)
        f.attrs["n_samples"] = np.int64(HUGE_ROWS)

    def huge_events(f: h5py.File) -> None:
        f["events/heel_strike"].resize((HUGE_ROWS,))

    def huge_markers(f: h5py.File) -> None:
        f["markers"].resize((HUGE_ROWS,))

    def huge_attr_text(f: h5py.File) -> None:
        f["session"].attrs["notes"] = "x" * big_attr_bytes

    def huge_attr_array(f: h5py.File) -> None:
        attrs = dict(f["device"].attrs.items())
        channels = f["device/channels"][()]
        del f["device"]
        g = f.create_group("device")
        g.create_dataset("channels", data=channels)
        for k, v in attrs.items():
            g.attrs[k] = v
        g.attrs["calibration_table"] = np.zeros(big_attr_bytes // 8, "<f8")

    add("external_storage", "/raw/adc in an outside file (external raw storage)",
        external_storage)
    add("external_link_session", "/session an external link to a foreign session", link_session)
    add("external_link_adc", "/raw/adc an external link to a foreign session", link_adc)
    add("virtual_adc", "/raw/adc a virtual dataset of a foreign session's counts", virtual_adc)
    add("counts_5000", "counts of 5000 on a 12-bit ADC", counts_5000)
    add("huge_shape", "per-sample datasets declared 10^12 rows", huge_shape)
    add("huge_events", "heel strikes declared 10^12 rows", huge_events)
    add("huge_markers", "markers declared 10^12 rows", huge_markers)
    add("huge_attr_text", f"a {big_attr_bytes >> 20} MiB text attribute", huge_attr_text)
    add("huge_attr_array", f"a {big_attr_bytes >> 20} MiB numeric attribute", huge_attr_array,
        libver="latest")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("session", type=Path)
    ap.add_argument("out_dir", type=Path)
    ap.add_argument("--attr-mib", type=int, default=4, help="size of the huge attributes")
    args = ap.parse_args()
    for path, what in make_hostile(args.session, args.out_dir, args.attr_mib << 20):
        print(f"{path}: {what}")


if __name__ == "__main__":
    main()
