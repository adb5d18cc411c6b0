"""Decoder and encoder speed: frames per second for each kind, clean and 5 % corrupted streams.

Run: python benchmarks/bench_decoder.py   (prints figures; no assertions)
     python benchmarks/bench_decoder.py --compare-with OLD_decoder.py
        (e.g. `git show main:gaitmon/io/decoder.py > /tmp/old.py`): this decoder against
        another version of gaitmon/io/decoder.py in the same run, interleaved, as the median
        of paired speed ratios (robust on a busy machine)
"""

from __future__ import annotations

import importlib.util
import statistics
import sys
import time

import numpy as np

from gaitmon.io import protocol as p
from gaitmon.io.decoder import FrameDecoder

N = 20000


def frames_of(kind: p.FrameKind, rng: np.random.Generator) -> list[p.Frame]:
    if kind == p.FrameKind.RAW:
        return [p.RawFrame(i, rng.integers(0, 4096, 14)) for i in range(N)]
    if kind == p.FrameKind.TILT:
        return [p.TiltFrame(i, rng.normal(0, 30, 4), rng.normal(0, 30, 4)) for i in range(N)]
    return [
        p.JointFrame(i, rng.normal(0, 30, 3), rng.normal(0, 30, 3), True, False, 1)
        for i in range(N)
    ]


def rate(fn, n: int) -> float:
    t0 = time.perf_counter()
    fn()
    return n / (time.perf_counter() - t0)


def compare(path: str, n: int = 5000, pairs: int = 25) -> None:
    spec = importlib.util.spec_from_file_location("other_decoder", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["other_decoder"] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    rng = np.random.default_rng(0)
    print(f"this decoder / {path}: speed ratio, median of {pairs} interleaved pairs, {n} frames")
    for kind in p.DATA_KINDS:
        stream = b"".join(p.encode_frame(f) for f in frames_of(kind, rng)[:n])
        for chunk in (1 << 16, 512, 36):

            def run(cls: type, s: bytes = stream, c: int = chunk) -> float:
                d = cls()
                t0 = time.perf_counter()
                for i in range(0, len(s), c):
                    d.feed(s[i : i + c])
                return time.perf_counter() - t0

            ratios = []
            for k in range(pairs):  # alternate who goes first
                if k % 2:
                    t_new, t_old = run(FrameDecoder), run(mod.FrameDecoder)
                else:
                    t_old, t_new = run(mod.FrameDecoder), run(FrameDecoder)
                ratios.append(t_old / t_new)
            print(f"  {kind.name:5s} {chunk:6d}-byte chunks: {statistics.median(ratios):.3f}")


def main() -> None:
    if len(sys.argv) == 3 and sys.argv[1] == "--compare-with":
        compare(sys.argv[2])
        return
    rng = np.random.default_rng(0)
    print(f"gaitmon decoder benchmark, {N} frames per run (real time needs 100 frames/s)")
    for kind in p.DATA_KINDS:
        frames = frames_of(kind, rng)
        enc_rate = rate(lambda fr=frames: [p.encode_frame(f) for f in fr], N)
        stream = b"".join(p.encode_frame(f) for f in frames)
        for chunk in (1 << 16, 512, 36):

            def run(s=stream, c=chunk) -> None:
                d = FrameDecoder()
                for i in range(0, len(s), c):
                    d.feed(s[i : i + c])

            print(
                f"  {kind.name:5s} decode, {chunk:6d}-byte chunks: {rate(run, N):10,.0f} frames/s"
            )
        print(f"  {kind.name:5s} encode_frame:               {enc_rate:10,.0f} frames/s")
    adc = rng.integers(0, 4096, (N, 14))
    print(
        f"  RAW   encode_raw_block:           {rate(lambda: p.encode_raw_block(0, adc), N):10,.0f}"
        " frames/s"
    )
    # 5 % of frames with one flipped bit: the resync path
    frames = frames_of(p.FrameKind.RAW, rng)
    wires = [bytearray(p.encode_frame(f)) for f in frames]
    for w in wires[::20]:
        w[int(rng.integers(len(w)))] ^= 0x10
    stream = b"".join(bytes(w) for w in wires)
    d = FrameDecoder()
    r = rate(lambda: d.feed(stream), N)
    print(f"  RAW   decode with 5 % corrupted:  {r:10,.0f} frames/s  ({d.stats})")
    t0 = time.perf_counter()
    for _ in range(20000):
        p.crc16_table_driven(stream[:34])
    t_table = (time.perf_counter() - t0) / 20000
    t0 = time.perf_counter()
    for _ in range(20000):
        p.crc16(stream[:34])
    t_fast = (time.perf_counter() - t0) / 20000
    print(
        f"  CRC-16 of 34 bytes: table-driven Python {t_table * 1e6:.2f} us, "
        f"binascii {t_fast * 1e6:.3f} us"
    )


if __name__ == "__main__":
    main()
