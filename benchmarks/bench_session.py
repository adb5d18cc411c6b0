"""Session file speed: recorder cost per block and per flush, bytes handed to the OS with and
without the HDF5 chunk cache, bulk write throughput, and the recovery time of a long session.

Run: python benchmarks/bench_session.py [--hours 8] [--block-rows 1] [--dir /tmp]
(prints figures; no assertions). Needs ~2 GB of free disk for an 8-hour recovery.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np

import gaitmon.io.session.h5file as session_h5
from gaitmon.dsp.pipeline import Pipeline
from gaitmon.finish import open_session, recover_session
from gaitmon.io.device import SampleBlock
from gaitmon.io.journal import MAGIC, ROW_DTYPES, RecordType, encode_json, journal_path
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import SessionHeader, SessionWriter
from gaitmon.io.sim.sensors import simulate

FS = 100.0


def _wchar() -> int | None:
    """Bytes this process has passed to write() so far (Linux)."""
    try:
        with open("/proc/self/io") as f:
            for line in f:
                if line.startswith("wchar:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def _remove(path: Path) -> None:
    for p in (path, journal_path(path)):
        p.unlink(missing_ok=True)


def recorder_cost(directory: Path, block_rows: int, n_blocks: int, cache_bytes: int) -> None:
    """Append n_blocks as the engine's recorder would at 100 blocks/s, flushing every 10 blocks
    (= every 100 ms at that rate), timing appends and flushes separately."""
    counts = simulate(n_blocks * block_rows).counts
    pipe = Pipeline()
    blocks = []
    for k in range(n_blocks):
        a, b = k * block_rows, (k + 1) * block_rows
        blk = SampleBlock(
            FrameKind.RAW,
            np.arange(a, b, dtype=np.int64),
            np.full(b - a, a / FS),
            1.7e9,
            adc=counts[a:b],
        )
        blocks.append((blk, pipe.process(counts[a:b])))
    path = directory / "bench_rec.h5"
    _remove(path)
    session_h5.WRITER_CHUNK_CACHE_BYTES = cache_bytes
    w0 = _wchar()
    c0 = time.process_time()
    w = SessionWriter(path, SessionHeader("raw"), flush_interval_s=1e9)
    t_append = t_flush = 0.0
    n_flush = 0
    for k, (blk, proc) in enumerate(blocks):
        t = time.perf_counter()
        w.append(blk, proc)
        t_append += time.perf_counter() - t
        if k % 10 == 9:
            t = time.perf_counter()
            w.flush()
            t_flush += time.perf_counter() - t
            n_flush += 1
    w.close()
    cpu = time.process_time() - c0
    w1 = _wchar()
    session_h5.WRITER_CHUNK_CACHE_BYTES = 0
    size = path.stat().st_size
    append_us = t_append / n_blocks * 1e6
    flush_ms = t_flush / n_flush * 1e3
    # at 100 blocks/s: 100 appends + 10 flushes per second of recording
    core = (100 * append_us * 1e-6 + 10 * flush_ms * 1e-3) * 100
    cache = "no chunk cache" if cache_bytes == 0 else f"{cache_bytes // 1024} KB chunk cache"
    written = "n/a" if w0 is None or w1 is None else f"{(w1 - w0) / 1e6:8.1f} MB"
    print(
        f"  {block_rows} row(s)/block, {cache}: append {append_us:6.1f} us, flush (HDF5 + "
        f"fdatasync) {flush_ms:5.2f} ms -> {core:4.2f} % of the thread's time at 100 blocks/s; "
        f"CPU {cpu / (n_blocks / 100) * 100:4.2f} % of a core; handed to the OS {written} "
        f"for a {size / 1e6:.1f} MB file"
    )
    _remove(path)


def bulk_write(directory: Path, n_rows: int) -> None:
    """Upper bound of the writer: blocks of 1000 rows (one pipeline block reused for all, the
    writer's cost does not depend on the values)."""
    step = 1000
    counts = simulate(step).counts
    proc = Pipeline().process(counts)
    path = directory / "bench_bulk.h5"
    _remove(path)
    t = time.perf_counter()
    with SessionWriter(path, SessionHeader("raw")) as w:
        for a in range(0, n_rows, step):
            seq = np.arange(a, a + step)
            w.append(SampleBlock(FrameKind.RAW, seq, seq / FS, 0.0, adc=counts), proc)
    dt = time.perf_counter() - t
    print(
        f"  bulk: {n_rows / dt / 1e3:7.0f} k rows/s ({path.stat().st_size / n_rows:.0f} bytes/row "
        "in the file, raw mode)"
    )
    _remove(path)


def make_long_journal(path: Path, n_rows: int, block_rows: int) -> float:
    """An interrupted raw session's journal, written directly (the writer would take minutes):
    one minute of simulated counts repeated, in blocks of block_rows, 100 blocks/s apart."""
    t0 = time.perf_counter()
    minute = simulate(6000).counts
    dtype = ROW_DTYPES[RecordType.RAW]
    n_blocks = n_rows // block_rows
    n_rows = n_blocks * block_rows
    rows = np.empty(n_rows, dtype=dtype)
    rows["seq"] = np.arange(n_rows)
    rows["host_time_s"] = np.arange(n_rows) / FS
    rows["lost_before"] = 0
    rows["adc"] = np.resize(minute, (n_rows, 14))
    payload_len = 12 + block_rows * dtype.itemsize
    rec = np.dtype(
        [
            ("type", "u1"),
            ("length", "<u4"),
            ("n", "<u4"),
            ("wall", "<f8"),
            ("rows", dtype, (block_rows,)),
            ("crc", "<u4"),
        ]
    )
    recs = np.empty(n_blocks, dtype=rec)
    recs["type"] = RecordType.RAW
    recs["length"] = payload_len
    recs["n"] = block_rows
    recs["wall"] = 1.7e9
    recs["rows"] = rows.reshape(n_blocks, block_rows)
    raw = recs.view(np.uint8).reshape(n_blocks, rec.itemsize)
    body = raw[:, : rec.itemsize - 4]
    crc = np.fromiter((zlib.crc32(r) for r in body), dtype=np.uint32, count=n_blocks)
    recs["crc"] = crc
    header = SessionHeader("raw").as_dict()
    with open(path, "wb") as f:
        f.write(MAGIC + encode_json(RecordType.HEADER, header))
        f.write(recs.tobytes())
    return time.perf_counter() - t0


def recovery(directory: Path, hours: float, block_rows: int) -> None:
    n_rows = int(hours * 3600 * FS)
    path = directory / "bench_long.h5"
    _remove(path)
    build_s = make_long_journal(journal_path(path), n_rows, block_rows)
    jsize = journal_path(path).stat().st_size
    print(
        f"  {hours:g} h = {n_rows / 1e6:.2f} M rows in {n_rows // block_rows / 1e6:.2f} M "
        f"journal records of {block_rows} row(s): journal {jsize / 1e6:.0f} MB "
        f"(built in {build_s:.1f} s)"
    )
    from gaitmon.io.journal import read_journal

    t = time.perf_counter()
    contents = read_journal(journal_path(path))
    read_s = time.perf_counter() - t
    assert contents.n_rows == n_rows - n_rows % block_rows, contents.problem
    del contents
    t = time.perf_counter()
    Pipeline().process(np.resize(simulate(6000).counts, (n_rows, 14)))
    pipe_s = time.perf_counter() - t
    t = time.perf_counter()
    recover_session(path)
    total_s = time.perf_counter() - t
    size = path.stat().st_size
    print(
        f"  recovery {total_s:5.1f} s in all ({n_rows / total_s / 1e6:.2f} M rows/s): reading "
        f"the journal {read_s:.1f} s, the pipeline alone {pipe_s:.1f} s; file {size / 1e6:.0f} MB"
    )
    t = time.perf_counter()
    with open_session(path) as s:
        opened = time.perf_counter() - t
        mid = s.n_samples // 2
        t = time.perf_counter()
        s.read_range(mid, mid + 1000, ["processed/joint_deg", "raw/adc"])
        window = time.perf_counter() - t
        t = time.perf_counter()
        s.read("processed/joint_deg")
        whole = time.perf_counter() - t
    print(
        f"  reading it: open {opened * 1e3:.0f} ms, a 10 s window of 2 datasets "
        f"{window * 1e3:.1f} ms, the whole joint_deg {whole:.2f} s"
    )
    _remove(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=8.0, help="length of the recovered session")
    ap.add_argument("--block-rows", type=int, default=1, help="rows per journal record")
    ap.add_argument("--dir", default=None, help="where to write (default: a temp folder)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(dir=args.dir) as d:
        directory = Path(d)
        print(f"gaitmon session benchmark in {directory} ({os.cpu_count()} CPUs)")
        print("recorder thread (the engine calls append per block and flush every 100 ms):")
        for block_rows in (1, 4):
            recorder_cost(directory, block_rows, 6000, cache_bytes=0)
        recorder_cost(directory, 1, 6000, cache_bytes=1024 * 1024)
        bulk_write(directory, 200_000)
        print("recovery of an interrupted session (journal -> pipeline -> new HDF5 file):")
        recovery(directory, args.hours, args.block_rows)


if __name__ == "__main__":
    main()
