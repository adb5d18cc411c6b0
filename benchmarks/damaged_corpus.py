"""Damaged variants of a real recorded session, for fault injection (issue 12, defect 3).

``make_corpus(src_path, out_dir, seed)`` copies one good session file into ≥100 damaged ones
and returns ``[(path, description), ...]``: truncations at many offsets, flipped bytes, zeroed
blocks, datasets of the wrong dtype or shape, missing groups, datasets and attributes, sample
rates of 0 / NaN / negative / infinite, events out of order or out of range, a 0-byte file,
foreign files (a PNG, a text file, an HDF5 file of another program) and orphaned or damaged
journals. Every variant is deterministic for a given ``seed``.

Used by ``tests/test_damaged_files.py`` (every command must answer with exit 0 or one line and
exit 2, never a traceback or a hang) and by the long fault-injection suite in ``benchmarks/``.
Run alone it writes the corpus and prints its size:

    python benchmarks/damaged_corpus.py SESSION.h5 OUT_DIR [--seed 1]
"""

from __future__ import annotations

import argparse
import shutil
import struct
import zlib
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

Variant = tuple[Path, str]

# the per-sample and table datasets a session holds (docs/file-format.md)
DATASETS = (
    "raw/adc", "timeline/t_s", "timeline/seq", "timeline/host_time_s",
    "processed/joint_deg", "processed/tilt_deg", "processed/fsr_counts", "processed/phase",
    "events/heel_strike", "events/toe_off", "markers", "gaps", "device/channels",
    "config/changes", "calibration/changes", "link/crc_failures",
)  # fmt: skip
GROUPS = ("session", "device", "config", "calibration", "events", "timeline", "processed",
          "raw", "link", "markers", "gaps")  # fmt: skip
ROOT_ATTRS = ("format", "format_version", "mode", "sample_rate_hz", "created_utc", "complete")


def _png_bytes() -> bytes:
    """A valid 1x1 PNG (a foreign file a user might pick by mistake)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))  # fmt: skip

    ihdr = struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", zlib.compress(b"\x00\xff\x00\x00")) + chunk(b"IEND", b""))


def _h5_edit(src: Path, dst: Path, edit: Callable[[h5py.File], None]) -> None:
    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+") as f:
        edit(f)


def _replace(path: str, make: Callable[[np.ndarray], np.ndarray]) -> Callable[[h5py.File], None]:
    def edit(f: h5py.File) -> None:
        old = f[path][()]
        attrs = dict(f[path].attrs)
        del f[path]
        ds = f.create_dataset(path, data=make(old))
        for k, v in attrs.items():
            ds.attrs[k] = v

    return edit


def _set_attr(obj: str, key: str, value: object) -> Callable[[h5py.File], None]:
    def edit(f: h5py.File) -> None:
        f[obj].attrs[key] = value

    return edit


def _del_attr(obj: str, key: str) -> Callable[[h5py.File], None]:
    def edit(f: h5py.File) -> None:
        if key in f[obj].attrs:
            del f[obj].attrs[key]

    return edit


def _del(path: str) -> Callable[[h5py.File], None]:
    def edit(f: h5py.File) -> None:
        if path in f:
            del f[path]

    return edit


def _events(hs: Callable[[np.ndarray], np.ndarray]) -> Callable[[h5py.File], None]:
    return _replace("events/heel_strike", lambda a: np.asarray(hs(a.astype(np.int64))))


def make_corpus(src_path: str | Path, out_dir: str | Path, seed: int = 1) -> list[Variant]:
    """Write the damaged variants of the session ``src_path`` into ``out_dir`` (created) and
    return ``(path, description)`` for each. ``src_path`` must be a complete raw-mode session
    recorded by gaitmon; it is not modified."""
    src = Path(src_path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    data = src.read_bytes()
    size = len(data)
    variants: list[Variant] = []
    with h5py.File(src, "r") as f:
        present = {d for d in DATASETS if d in f}
        # format 2 derives the joint angles from the stored tilts: damage those instead
        joint = "processed/joint_deg" if "processed/joint_deg" in f else "processed/tilt_deg"

    def put(name: str, description: str, content: bytes) -> None:
        p = out / name
        p.write_bytes(content)
        variants.append((p, description))

    def h5(name: str, description: str, edit: Callable[[h5py.File], None]) -> None:
        p = out / name
        _h5_edit(src, p, edit)
        variants.append((p, description))

    # -- truncations: the superblock, the metadata, the middle of the data, the last byte
    small = [0, 1, 7, 8, 47, 96, 512, 1024, 2048, 4096]
    fractions = [0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99]
    offsets = sorted({*small, *(int(size * q) for q in fractions), size - 1,
                      *(int(x) for x in rng.integers(1, size - 1, 6))})  # fmt: skip
    for off in offsets:
        put(f"trunc_{off:08d}.h5", f"truncated to {off} of {size} bytes", data[:off])

    # -- flipped bytes: single bytes in the header, then bursts anywhere
    for k, pos in enumerate([0, 1, 8, 9, 16, 24, 40, 44, 60, 100]):
        b = bytearray(data)
        b[pos] ^= 0xFF
        put(f"flip_head_{k:02d}.h5", f"byte {pos} inverted", bytes(b))
    for k in range(16):
        b = bytearray(data)
        n_flips = int(rng.integers(1, 64))
        for pos in rng.integers(0, size, n_flips):
            b[int(pos)] ^= 1 << int(rng.integers(0, 8))
        put(f"flip_rand_{k:02d}.h5", f"{n_flips} random bit flips", bytes(b))

    # -- zeroed blocks of 512 B - 64 KiB at spread-out offsets
    for k, frac in enumerate(np.linspace(0.0, 0.97, 14)):
        b = bytearray(data)
        start = int(size * frac)
        length = int(rng.choice([512, 4096, 16384, 65536]))
        b[start : start + length] = bytes(min(length, size - start))
        put(f"zero_{k:02d}.h5", f"{length} bytes zeroed at {start}", bytes(b))

    # -- wrong dtypes and shapes
    h5("dtype_adc_float.h5", "raw/adc stored as float",
       _replace("raw/adc", lambda a: a.astype(np.float32) + 0.5))
    h5("dtype_adc_str.h5", "raw/adc stored as strings",
       _replace("raw/adc", lambda a: np.array([b"x"] * len(a))))
    h5("dtype_t_str.h5", "timeline/t_s stored as strings",
       _replace("timeline/t_s", lambda a: np.array([b"t"] * len(a))))
    h5("dtype_joint_1d.h5", "processed/joint_deg one column",
       _replace(joint, lambda a: a[:, 0].copy()))
    h5("dtype_joint_scalar.h5", "processed/joint_deg a scalar",
       _replace(joint, lambda a: np.float64(1.0)))
    h5("dtype_hs_float.h5", "heel strikes stored as float",
       _replace("events/heel_strike", lambda a: a.astype(np.float64) + 0.5))
    h5("dtype_hs_str.h5", "heel strikes stored as strings",
       _replace("events/heel_strike", lambda a: np.array([b"hs"] * max(1, len(a)))))
    h5("dtype_hs_2d.h5", "heel strikes 2-D", _replace("events/heel_strike",
                                                      lambda a: np.stack([a, a], axis=1)))
    h5("dtype_markers_plain.h5", "markers a plain int array",
       _replace("markers", lambda a: np.arange(3)))
    h5("dtype_gaps_plain.h5", "gaps a plain float array",
       _replace("gaps", lambda a: np.ones(4)))
    h5("dtype_channels_plain.h5", "device/channels a plain array",
       _replace("device/channels", lambda a: np.arange(14)))
    h5("dtype_config_changes_bad_json.h5", "config change with broken JSON",
       _replace("config/changes", lambda a: np.array(
           [(5, b"{not json")], dtype=[("sample_idx", "<i8"), ("json", "S10")])))
    h5("dtype_phase_float.h5", "processed/phase as float",
       _replace("processed/phase", lambda a: a.astype(np.float64)))

    # -- missing groups, datasets, attributes
    for g in GROUPS:
        h5(f"missing_group_{g}.h5", f"group /{g} removed", _del(g))
    for d in sorted(present, key=DATASETS.index):
        h5(f"missing_ds_{d.replace('/', '_')}.h5", f"dataset /{d} removed", _del(d))
    for a in ROOT_ATTRS:
        h5(f"missing_attr_{a}.h5", f"root attribute {a} removed", _del_attr("/", a))
    h5("missing_attr_cal_offset.h5", "calibration offsets removed",
       _del_attr("calibration", "tilt_offset_rad"))
    h5("missing_attr_cutoff.h5", "config cut-off removed", _del_attr("config", "cutoff_hz"))

    # -- bad attribute values
    for label, v in (("0", 0.0), ("nan", float("nan")), ("neg", -100.0), ("inf", float("inf")),
                     ("tiny", 1e-300), ("huge", 1e300)):
        h5(f"fs_{label}.h5", f"sample_rate_hz = {v}", _set_attr("/", "sample_rate_hz", v))
    h5("fs_str.h5", "sample_rate_hz a string", _set_attr("/", "sample_rate_hz", "fast"))
    h5("mode_bad.h5", "mode 'banana'", _set_attr("/", "mode", "banana"))
    h5("format_other.h5", "format of another program", _set_attr("/", "format", "other"))
    h5("format_future.h5", "format_version 999", _set_attr("/", "format_version", 999))
    h5("format_version_str.h5", "format_version a string",
       _set_attr("/", "format_version", "one"))
    h5("cutoff_nan.h5", "config cut-off NaN", _set_attr("config", "cutoff_hz", float("nan")))
    h5("cutoff_big.h5", "config cut-off above Nyquist", _set_attr("config", "cutoff_hz", 80.0))
    h5("cal_short.h5", "calibration offsets of length 2",
       _set_attr("calibration", "tilt_offset_rad", np.zeros(2)))
    h5("side_bad.h5", "session side 'X'", _set_attr("session", "side", "X"))
    h5("n_samples_wrong.h5", "n_samples attribute wrong", _set_attr("/", "n_samples", 7))
    h5("duration_nan.h5", "duration_s NaN", _set_attr("/", "duration_s", float("nan")))
    h5("wall_offset_str.h5", "wall_offset_s a string",
       _set_attr("timeline/host_time_s", "wall_offset_s", "noon"))

    # -- events out of order or out of range
    h5("events_reversed.h5", "heel strikes in reverse order", _events(lambda a: a[::-1]))
    h5("events_swapped.h5", "two heel strikes swapped",
       _events(lambda a: np.r_[a[:3], a[4], a[3], a[5:]] if len(a) > 5 else a[::-1]))
    h5("events_duplicate.h5", "a heel strike twice", _events(lambda a: np.r_[a[:2], a[1:]]))
    h5("events_negative.h5", "a negative heel strike", _events(lambda a: np.r_[-50, a]))
    h5("events_beyond.h5", "heel strikes beyond the data", _events(lambda a: np.r_[a, 10**9]))
    h5("events_huge.h5", "heel strike at 2^62", _events(lambda a: np.r_[a, 2**62]))
    h5("events_toe_off_reversed.h5", "toe offs reversed",
       _replace("events/toe_off", lambda a: a[::-1].copy()))
    h5("events_empty.h5", "no events at all", _events(lambda a: a[:0]))
    h5("ragged_lengths.h5", "processed/joint_deg shorter than the rest",
       _replace(joint, lambda a: a[: len(a) // 2]))
    h5("t_s_nan.h5", "timeline/t_s all NaN", _replace("timeline/t_s", lambda a: a * np.nan))
    h5("joint_nan.h5", "processed/joint_deg all NaN",
       _replace(joint, lambda a: a * np.nan))
    h5("markers_beyond.h5", "a marker far beyond the data", _replace("markers", lambda a: np.array(
        [(10**9, 1e9, b"far")], dtype=a.dtype) if a.dtype.names else a))

    # -- empty and foreign files
    put("empty.h5", "0-byte file", b"")
    put("picture.h5", "a PNG image named .h5", _png_bytes())
    put("notes.h5", "a text file named .h5", b"patient walked well\n" * 20)
    put("zeros.h5", "4 KiB of zero bytes", bytes(4096))
    put("random.h5", "64 KiB of random bytes", rng.integers(0, 256, 65536, np.uint8).tobytes())
    other = out / "other_program.h5"
    with h5py.File(other, "w") as f:
        f.create_dataset("images/frame0", data=np.zeros((8, 8)))
        f.attrs["creator"] = "another program"
    variants.append((other, "an HDF5 file of another program"))
    blank = out / "empty_hdf5.h5"
    with h5py.File(blank, "w"):
        pass
    variants.append((blank, "an HDF5 file with nothing in it"))

    # -- journals: orphaned (no session beside it), damaged, or of another session
    journal = src.with_name(src.name + ".journal")
    from gaitmon.io.journal import MAGIC, RecordType, encode_json

    header = encode_json(RecordType.HEADER, {"mode": "raw", "sample_rate_hz": 100.0})
    journals: list[tuple[str, str, bytes, bool]] = [
        ("orphan_empty", "an empty journal and no session file", b"", False),
        ("orphan_magic", "a journal of magic bytes only and no session file", MAGIC, False),
        ("orphan_header", "a journal with a bare header and no session file", MAGIC + header,
         False),
        ("orphan_garbage", "a journal of garbage and no session file",
         rng.integers(0, 256, 4096, np.uint8).tobytes(), False),
        ("beside_garbage", "a good file with a garbage journal beside it",
         rng.integers(0, 256, 4096, np.uint8).tobytes(), True),
        ("beside_header_only", "a good file with a header-only journal beside it",
         MAGIC + header, True),
        ("beside_bad_header", "a good file with a journal whose header has bad settings",
         MAGIC + encode_json(RecordType.HEADER, {"mode": "raw", "sample_rate_hz": 0.0,
                                                 "config": {}, "calibration": {}}), True),
    ]
    if journal.exists():  # the source's own journal is not expected, but use it if there
        journals.append(("beside_own", "the file with its own journal", journal.read_bytes(), True))
    for stem, description, content, with_file in journals:
        p = out / f"{stem}.h5"
        if with_file:
            shutil.copyfile(src, p)
        p.with_name(p.name + ".journal").write_bytes(content)
        variants.append((p, description))
    return variants


# -- files of both legs (issue 26, item 8) ---------------------------------------------------

UNIT_DATASETS = ("raw/adc", "timeline/t_s", "timeline/seq", "processed/tilt_deg",
                 "events/heel_strike", "gaps", "device/channels", "markers")  # fmt: skip


def _damaged_bytes(data: bytes, rng: np.random.Generator, put: Callable[[str, str, bytes], None],
                   prefix: str) -> None:
    """Truncations, flipped bytes and zeroed ranges of ``data`` (also 512 zero bytes at 512,
    the superblock's neighbourhood), each through ``put(name, description, bytes)``."""
    size = len(data)
    small = [0, 8, 96, 512, 1024, 2048, 4096]
    fractions = [0.05, 0.1, 0.25, 0.4, 0.5, 0.6, 0.75, 0.9, 0.99]
    offsets = sorted({*small, *(int(size * q) for q in fractions), size - 1} - {size})
    for off in offsets:
        put(f"{prefix}trunc_{off:08d}.h5", f"truncated to {off} of {size} bytes", data[:off])
    for k, pos in enumerate([0, 8, 9, 24, 40, 44, 60, 100]):
        b = bytearray(data)
        b[pos] ^= 0xFF
        put(f"{prefix}flip_head_{k:02d}.h5", f"byte {pos} inverted", bytes(b))
    for k in range(12):
        b = bytearray(data)
        n_flips = int(rng.integers(1, 64))
        for pos in rng.integers(0, size, n_flips):
            b[int(pos)] ^= 1 << int(rng.integers(0, 8))
        put(f"{prefix}flip_rand_{k:02d}.h5", f"{n_flips} random bit flips", bytes(b))
    starts = [(512, 512), *((int(size * f), int(rng.choice([512, 4096, 16384])))
                            for f in np.linspace(0.02, 0.97, 12))]  # fmt: skip
    for k, (start, length) in enumerate(starts):
        b = bytearray(data)
        b[start : start + length] = bytes(min(length, size - start))
        put(f"{prefix}zero_{k:02d}.h5", f"{length} bytes zeroed at {start}", bytes(b))


def make_bilateral_corpus(src_path: str | Path, out_dir: str | Path,
                          seed: int = 1) -> list[Variant]:  # fmt: skip
    """Damaged variants of a complete session of both legs (``gaitmon record
    --simulate-bilateral``): truncations, bit flips, zeroed ranges (raw bytes), and the
    groups, datasets and attributes of the layout removed or wrong (``/units/<side>``,
    ``/sync``, the root's ``bilateral`` and ``sides``, each unit's series)."""
    src = Path(src_path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    variants: list[Variant] = []

    def put(name: str, description: str, content: bytes) -> None:
        p = out / name
        p.write_bytes(content)
        variants.append((p, f"both legs: {description}"))

    def h5(name: str, description: str, edit: Callable[[h5py.File], None]) -> None:
        p = out / name
        _h5_edit(src, p, edit)
        variants.append((p, f"both legs: {description}"))

    _damaged_bytes(src.read_bytes(), rng, put, "bi_")
    for g in ("units/L", "units/R", "units", "sync", "sync/L", "sync/R/segments"):
        h5(f"bi_missing_{g.replace('/', '_')}.h5", f"/{g} removed", _del(g))
    for side in ("L", "R"):
        for d in UNIT_DATASETS:
            h5(f"bi_missing_{side}_{d.replace('/', '_')}.h5", f"/units/{side}/{d} removed",
               _del(f"units/{side}/{d}"))  # fmt: skip
    for a in ("bilateral", "sides", "complete", "format", "format_version", "sample_rate_hz"):
        h5(f"bi_missing_attr_{a}.h5", f"root attribute {a} removed", _del_attr("/", a))
    for a in ("host_t0_s", "host_s_per_common_s"):
        h5(f"bi_missing_sync_{a}.h5", f"/sync attribute {a} removed", _del_attr("sync", a))
    h5("bi_sides_extra.h5", "sides 'L R X'", _set_attr("/", "sides", "L R X"))
    h5("bi_sides_empty.h5", "sides ''", _set_attr("/", "sides", ""))
    h5("bi_sides_left_only.h5", "sides 'L' (the right leg's group still there)",
       _set_attr("/", "sides", "L"))
    h5("bi_sync_scale_nan.h5", "common time base NaN",
       _set_attr("sync", "host_s_per_common_s", float("nan")))
    h5("bi_sync_segments_plain.h5", "/sync/L/segments a plain array",
       _replace("sync/L/segments", lambda a: np.arange(4.0)))
    h5("bi_sync_segments_empty.h5", "/sync/R/segments empty",
       _replace("sync/R/segments", lambda a: a[:0]))
    h5("bi_fs_L_zero.h5", "left leg's sample_rate_hz 0",
       _set_attr("units/L", "sample_rate_hz", 0.0))
    h5("bi_R_ragged.h5", "right leg's tilts shorter than its rows",
       _replace("units/R/processed/tilt_deg", lambda a: a[: len(a) // 2]))
    h5("bi_L_adc_float.h5", "left leg's raw counts stored as float",
       _replace("units/L/raw/adc", lambda a: a.astype(np.float32) + 0.5))
    return variants


def make_parts_corpus(parts_dir: str | Path, name: str, out_dir: str | Path,
                      seed: int = 1) -> list[Variant]:  # fmt: skip
    """Damaged variants of a crashed recording of both legs: ``parts_dir`` holds ``name``'s
    parts and their journals (``NAME.L.partial``, ``NAME.L.partial.journal``, the same for R;
    a ``kill -9`` of ``gaitmon record --simulate-bilateral``) and no ``NAME``. Each variant is
    a session path with no file, its parts beside it: intact, one part cut, random, zeroed or
    gone, a journal gone or cut, only the journals."""
    src = Path(parts_dir)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    files = {p.name[len(name):]: p.read_bytes() for p in src.iterdir()
             if p.name.startswith(name + ".")}  # fmt: skip  # ".L.partial", ".L.partial.journal"
    variants: list[Variant] = []

    def variant(stem: str, description: str,
                change: Callable[[dict[str, bytes]], dict[str, bytes]]) -> None:
        for suffix, content in change(dict(files)).items():
            (out / f"{stem}.h5{suffix}").write_bytes(content)
        variants.append((out / f"{stem}.h5", f"crashed recording of both legs: {description}"))

    def cut(n: int) -> Callable[[bytes], bytes]:
        return lambda b: b[:n]

    def flips(b: bytes) -> bytes:
        a = bytearray(b)
        for pos in rng.integers(0, len(a), 32):
            a[int(pos)] ^= 1 << int(rng.integers(0, 8))
        return bytes(a)

    def zero512(b: bytes) -> bytes:
        return b[:512] + bytes(len(b[512:1024])) + b[1024:]

    def random(b: bytes) -> bytes:
        return rng.integers(0, 256, len(b), np.uint8).tobytes()

    Change = Callable[[dict[str, bytes]], dict[str, bytes]]

    def edit(key: str, how: Callable[[bytes], bytes]) -> Change:
        return lambda d: {**d, key: how(d[key])} if key in d else d

    def drop(*keys: str) -> Change:
        return lambda d: {k: v for k, v in d.items() if k not in keys}

    L, R = ".L.partial", ".R.partial"
    LJ, RJ = L + ".journal", R + ".journal"
    variant("parts_intact", "both parts and journals", lambda d: d)
    for key, what in ((L, "left part"), (LJ, "left part's journal"), (R, "right part")):
        k = key.replace(".", "_")
        variant(f"parts_cut300{k}", f"{what} cut to 300 bytes", edit(key, cut(300)))
        variant(f"parts_half{k}", f"{what} cut in half", edit(key, lambda b: b[: len(b) // 2]))
        variant(f"parts_flips{k}", f"32 bit flips in the {what}", edit(key, flips))
        variant(f"parts_zero512{k}", f"512 zero bytes at 512 in the {what}", edit(key, zero512))
        variant(f"parts_random{k}", f"{what} random bytes", edit(key, random))
        variant(f"parts_gone{k}", f"{what} gone", drop(key))
    variant("parts_no_journals", "both journals gone", drop(LJ, RJ))
    variant("parts_journals_only", "only the journals (both parts' files gone)", drop(L, R))
    variant("parts_left_only", "only the left part and its journal", drop(R, RJ))
    variant("parts_both_random", "both parts random bytes, journals gone",
            lambda d: {L: random(d[L]), R: random(d[R])})
    variant("parts_journals_cut", "both journals cut to 300 bytes, parts gone",
            lambda d: {LJ: d[LJ][:300], RJ: d[RJ][:300]})
    return variants


def make_crashed_corpus(crashed: str | Path, out_dir: str | Path) -> list[Variant]:
    """Variants of a crashed one-unit recording (``crashed`` and its journal, a ``kill -9``
    of ``gaitmon record``): the journal gone (the file as the recorder last flushed it), only
    the journal, the journal cut short, the file cut short with or without its journal."""
    src = Path(crashed)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    data = src.read_bytes()
    jdata = src.with_name(src.name + ".journal").read_bytes()
    variants: list[Variant] = []

    def put(stem: str, description: str, content: bytes | None, journal: bytes | None) -> None:
        p = out / f"{stem}.h5"
        if content is not None:
            p.write_bytes(content)
        if journal is not None:
            p.with_name(p.name + ".journal").write_bytes(journal)
        variants.append((p, f"crashed one-unit recording: {description}"))

    put("crashed", "the file and its journal", data, jdata)
    put("crashed_no_journal", "its journal gone", data, None)
    put("crashed_journal_only", "only its journal", None, jdata)
    put("crashed_journal_half", "only its journal, cut in half", None, jdata[: len(jdata) // 2])
    put("crashed_journal_cut", "the file and its journal cut to 300 bytes", data, jdata[:300])
    put("crashed_file_half", "the file cut in half, its journal kept", data[: len(data) // 2],
        jdata)
    put("crashed_file_half_no_journal", "the file cut in half, no journal",
        data[: len(data) // 2], None)
    put("crashed_zero512_no_journal", "512 zero bytes at 512, no journal",
        data[:512] + bytes(512) + data[1024:], None)
    return variants


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("session", help="a complete raw-mode session recorded by gaitmon")
    ap.add_argument("out_dir")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    corpus = make_corpus(a.session, a.out_dir, a.seed)
    print(f"{len(corpus)} damaged variants of {a.session} in {a.out_dir}")


if __name__ == "__main__":
    main()
