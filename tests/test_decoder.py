"""Frame decoder: total on any input, chunking-invariant, only delivers frames that were sent,
and its counters add up exactly against injected corruption."""

from __future__ import annotations

import binascii
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gaitmon.io import protocol as p
from gaitmon.io.decoder import BUFFER_BOUND, FrameDecoder

IDENT = p.Identity(name="gaitmon-test", firmware="1.4.2", serial=4242, side="R")


def make_frame(rng: np.random.Generator, seq: int, kind: p.FrameKind | None = None) -> p.Frame:
    """A random frame whose values are on the wire grid, so encode/decode is exact."""
    if kind is None:
        kind = p.DATA_KINDS[int(rng.integers(3))] if rng.random() < 0.97 else p.FrameKind.ACK
    seq %= p.SEQ_MODULO
    if kind == p.FrameKind.RAW:
        return p.RawFrame(seq, rng.integers(0, 4096, 14))
    if kind == p.FrameKind.TILT:
        return p.TiltFrame(
            seq, rng.integers(-18000, 18000, 4) / 100, rng.integers(-9000, 9000, 4) / 100
        )
    if kind == p.FrameKind.JOINT:
        return p.JointFrame(
            seq,
            rng.integers(-9000, 9000, 3) / 100,
            rng.integers(-9000, 9000, 3) / 100,
            bool(rng.integers(2)),
            bool(rng.integers(2)),
            int(rng.integers(4)),
        )
    if kind == p.FrameKind.IDENTITY:
        return p.IdentityFrame(seq, IDENT)
    return p.AckFrame(seq, p.Command.START_STREAM, p.AckStatus.OK, 0)


def feed_chunked(dec: FrameDecoder, data: bytes, cuts: list[int]) -> list[p.Frame]:
    out: list[p.Frame] = []
    bounds = sorted({0, len(data), *[c for c in cuts if 0 < c < len(data)]})
    for a, b in itertools.pairwise(bounds):
        out += dec.feed(data[a:b])
        assert dec.buffered <= BUFFER_BOUND
    return out


# --- basics ------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", list(p.FrameKind))
def test_every_kind_roundtrips(kind):
    rng = np.random.default_rng(int(kind))
    frame = make_frame(rng, 77, kind)
    dec = FrameDecoder()
    assert dec.feed(p.encode_frame(frame)) == [frame]
    s = dec.stats
    assert (s.frames_ok, s.bytes_skipped, s.crc_failures, s.buffered) == (1, 0, 0, 0)


def test_raw_frame_with_sample_above_4095_is_rejected_and_counted():
    rng = np.random.default_rng(1)
    good = [make_frame(rng, i, p.FrameKind.RAW) for i in range(3)]
    adc = good[1].adc.copy()
    adc[5] = 4096
    bad = p.RawFrame(1, adc)
    dec = FrameDecoder()
    stream = p.encode_frame(good[0]) + p.encode_frame(bad, validate=False) + p.encode_frame(good[2])
    assert dec.feed(stream) == [good[0], good[2]]
    s = dec.stats
    assert (s.invalid_values, s.frames_lost, s.frames_ok, s.bytes_skipped) == (1, 0, 2, 0)


def test_joint_phase_above_3_is_rejected():
    bad = p.JointFrame(0, np.zeros(3), np.zeros(3), False, True, 7)
    dec = FrameDecoder()
    assert dec.feed(p.encode_frame(bad, validate=False)) == []
    assert dec.stats.invalid_values == 1


@pytest.mark.parametrize(
    ("seqs", "lost", "resets"),
    [
        ([65534, 65535, 0, 1], 0, 0),  # wrap-around is not a loss
        ([65535, 2], 2, 0),  # 0 and 1 missing across the wrap
        ([10, 11, 15], 3, 0),
        ([1000, 5], 0, 1),  # backwards: device restarted
        ([7, 7], 0, 1),  # repeated
    ],
)
def test_sequence_gap_accounting(seqs, lost, resets):
    rng = np.random.default_rng(0)
    dec = FrameDecoder()
    got = dec.feed(b"".join(p.encode_frame(make_frame(rng, s)) for s in seqs))
    assert [f.seq for f in got] == seqs
    assert dec.stats.frames_lost == lost
    assert dec.stats.sequence_resets == resets


def test_empty_and_single_byte_feeds():
    rng = np.random.default_rng(2)
    frames = [make_frame(rng, i) for i in range(20)]
    data = b"".join(p.encode_frame(f) for f in frames)
    dec = FrameDecoder()
    got = []
    for b in data:
        assert dec.feed(b"") == []
        got += dec.feed(bytes([b]))
    assert got == frames


def test_resynchronises_after_garbage_that_mimics_a_header():
    rng = np.random.default_rng(3)
    frames = [make_frame(rng, i, p.FrameKind.RAW) for i in range(2)]
    # a false IDENTITY header right before the real frames: the decoder must not lose them
    garbage = b"\x00\xa5\x5a" + bytes([p.FrameKind.IDENTITY, p.PAYLOAD_LEN[p.FrameKind.IDENTITY]])
    dec = FrameDecoder()
    assert dec.feed(garbage + b"".join(p.encode_frame(f) for f in frames)) == frames
    assert dec.stats.bytes_skipped == len(garbage)


def _frame_ending_in(byte: int, kind: p.FrameKind = p.FrameKind.JOINT) -> p.Frame:
    """A frame whose last wire byte (the CRC's high byte) is `byte`."""
    rng = np.random.default_rng(7)
    for seq in range(100_000):
        frame = make_frame(rng, seq, kind)
        if p.encode_frame(frame)[-1] == byte:
            return frame
    raise AssertionError("no such frame")


def test_a_frame_that_lost_its_last_byte_does_not_swallow_the_next_one():
    """The lost CRC byte was 0xA5, so the next frame's sync completes the shortened frame and it
    passes its CRC. The old decoder delivered it and jumped past the next frame's first byte,
    losing that frame; now both are delivered (the first one's content is the true content)."""
    a = _frame_ending_in(0xA5)
    rng = np.random.default_rng(8)
    b, c = make_frame(rng, a.seq + 1, p.FrameKind.RAW), make_frame(rng, a.seq + 2)
    wire_a, wire_b, wire_c = (p.encode_frame(f) for f in (a, b, c))
    stream = wire_a[:-1] + wire_b + wire_c
    for cut in range(len(stream) + 1):  # the same whatever the chunking, single bytes included
        dec = FrameDecoder()
        got = dec.feed(stream[:cut]) + dec.feed(stream[cut:])
        assert got == [a, b, c]
        s = dec.stats
        assert (s.frames_ok, s.frames_lost, s.bytes_skipped, s.crc_failures) == (3, 0, 0, 0)
        assert (s.buffered, s.bytes_in_frames) == (0, len(stream))
    dec = FrameDecoder()
    assert [f for byte in stream for f in dec.feed(bytes([byte]))] == [a, b, c]


def test_a_lost_last_byte_that_was_not_0xa5_loses_only_that_frame():
    a = _frame_ending_in(0x11)
    rng = np.random.default_rng(9)
    b = make_frame(rng, a.seq + 1, p.FrameKind.TILT)
    wire_a = p.encode_frame(a)
    dec = FrameDecoder()
    assert dec.feed(wire_a[:-1] + p.encode_frame(b)) == [b]
    s = dec.stats
    assert (s.frames_ok, s.frames_lost, s.crc_failures) == (1, 0, 1)
    assert s.bytes_skipped == len(wire_a) - 1


def test_a_frame_inside_a_frame_is_found_and_its_bytes_are_counted_once():
    """Scanning resumes inside an accepted frame: a frame that lost its last 3 bytes and is
    still CRC-valid by coincidence cannot hide the next frame's start either (built here by
    choosing the tail so the CRC matches: the receiver cannot tell, and delivers both)."""
    rng = np.random.default_rng(10)
    b = make_frame(rng, 501, p.FrameKind.ACK)
    wire_b = p.encode_frame(b)
    # an IDENTITY frame whose last 3 wire bytes are wire_b[:3]: the low two bytes of its serial
    # span all 65536 CRC values (the CRC is linear), so one of them makes the CRC equal
    # wire_b[1:3]; its last payload byte, the table CRC's high byte, is wire_b[0] (0xA5). (An
    # angle frame cannot end in 0xA5 any more: its last angle would be -232.96 deg, out of range)
    assert wire_b[0] == 0xA5
    kind = p.FrameKind.IDENTITY
    name = b"FAKE"  # (struct pads it with NULs)
    for k in range(1 << 16):
        payload = p._IDENTITY.pack(name, 1, 0, 0, k, b"L", 14, 100, 1, 0xA500)
        body = bytes([kind, p.PAYLOAD_LEN[kind], 0xF4, 0x01]) + payload
        if p.crc16(body).to_bytes(2, "little") == wire_b[1:3]:
            break
    else:
        raise AssertionError("unreachable: 16 free bits reach every CRC value")
    fake = p.FRAME_SYNC + body + wire_b[1:3]
    got_fake = FrameDecoder().feed(fake)
    assert len(got_fake) == 1 and got_fake[0].seq == 500
    stream = fake[:-3] + wire_b
    dec = FrameDecoder()
    got = feed_chunked(dec, stream, [len(fake) - 2, len(fake)])
    assert [f.seq for f in got] == [500, 501] and got[1] == b
    s = dec.stats
    assert (s.bytes_in_frames, s.bytes_skipped, s.buffered) == (len(stream), 0, 0)


# --- properties --------------------------------------------------------------------------------


@settings(max_examples=300)
@given(st.binary(max_size=2000), st.lists(st.integers(0, 2000), max_size=40))
def test_never_raises_and_buffer_bounded_on_arbitrary_bytes(data, cuts):
    dec = FrameDecoder()
    feed_chunked(dec, data, cuts)
    s = dec.stats
    assert s.bytes_received == len(data)
    assert s.buffered <= BUFFER_BOUND
    assert s.bytes_skipped <= len(data)


@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(0, 30),
    cuts=st.lists(st.integers(0, 1200), max_size=60),
    garbage=st.binary(max_size=80),
)
def test_same_frames_whatever_the_chunking(seed, n, cuts, garbage):
    rng = np.random.default_rng(seed)
    frames = [make_frame(rng, 60000 + 300 * i, None) for i in range(n)]
    stream = garbage + b"".join(p.encode_frame(f) for f in frames)
    whole = FrameDecoder()
    ref = whole.feed(stream)
    chunked = FrameDecoder()
    assert feed_chunked(chunked, stream, cuts) == ref
    assert chunked.stats == whole.stats
    # after arbitrary garbage every real frame is found (the spec asks for resync within 2)
    assert ref[len(ref) - n :] == frames


CORRUPTIONS = st.lists(
    st.tuples(
        st.sampled_from(["flip", "insert", "delete", "overwrite"]),
        st.integers(0, 10**6),
        st.binary(min_size=1, max_size=12),
    ),
    max_size=12,
)


@settings(max_examples=300)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 25),
    ops=CORRUPTIONS,
    cuts=st.lists(st.integers(0, 1000)),
)
def test_every_delivered_frame_was_sent(seed, n, ops, cuts):
    rng = np.random.default_rng(seed)
    frames = [make_frame(rng, i) for i in range(n)]
    stream = bytearray(b"".join(p.encode_frame(f) for f in frames))
    for op, where, blob in ops:
        i = where % (len(stream) + 1)
        if op == "flip" and stream:
            stream[i % len(stream)] ^= 1 << (blob[0] % 8)
        elif op == "insert":
            stream[i:i] = blob
        elif op == "delete":
            del stream[i : i + len(blob)]
        elif op == "overwrite":
            stream[i : i + len(blob)] = blob
    dec = FrameDecoder()
    got = feed_chunked(dec, bytes(stream), cuts)
    # each delivered frame is one of the sent frames, in the order sent (CRC-16 makes a false
    # accept a ~1/65536 event per false candidate; hypothesis does not compute CRCs)
    it = iter(frames)
    assert all(any(g == f for f in it) for g in got)
    s = dec.stats
    assert s.bytes_received == len(stream)
    # frames may share one byte: one that lost its last byte, completed by the next frame's sync
    in_frames = sum(len(p.encode_frame(g)) for g in got)
    assert in_frames - max(0, len(got) - 1) <= s.bytes_in_frames <= in_frames


# --- a long seeded corruption run with exact accounting ----------------------------------------


def reference_scan(stream: bytes) -> tuple[list[int], int]:
    """Naive whole-buffer scanner (no find, no chunking) of every offset, as docs/protocol.md
    says the receiver does: offsets of CRC-valid frames and the number of complete,
    header-valid candidates that failed their CRC."""
    starts, crc_failures, pos, n = [], 0, 0, len(stream)
    while pos + 4 <= n:
        if stream[pos] == 0xA5 and stream[pos + 1] == 0x5A:
            kind, length = stream[pos + 2], stream[pos + 3]
            if kind in p.PAYLOAD_LEN and length == p.PAYLOAD_LEN[kind]:
                end = pos + 8 + length
                if end <= n:
                    crc = int.from_bytes(stream[end - 2 : end], "little")
                    if binascii.crc_hqx(stream[pos + 2 : end - 2], 0xFFFF) == crc:
                        starts.append(pos)
                    else:
                        crc_failures += 1
        pos += 1
    return starts, crc_failures


def test_long_injected_corruption_run_counters_match_truth_exactly():
    rng = np.random.default_rng(20240611)
    n_frames = 15000
    seq0 = 65536 - 4000  # wraps around during the run
    stream = bytearray()
    # (start offset, original bytes, frame, valid values) for every frame put on the wire
    placed: list[tuple[int, bytes, p.Frame, bool]] = []
    dropped = 0
    for k in range(n_frames):
        frame = make_frame(rng, seq0 + k)
        protect = k < 3 or k >= n_frames - 3  # losses are only visible between valid frames
        valid = True
        if not protect and rng.random() < 0.003:
            # out-of-range value with a correct CRC
            if isinstance(frame, p.RawFrame):
                adc = frame.adc.copy()
                adc[int(rng.integers(14))] = int(rng.integers(4096, 65536))
                frame = p.RawFrame(frame.seq, adc)
                valid = False
            elif isinstance(frame, p.JointFrame):
                frame = p.JointFrame(
                    frame.seq, frame.acc_joint_deg, frame.kalman_joint_deg, False, False, 9
                )
                valid = False
        wire = bytearray(p.encode_frame(frame, validate=False))
        original = bytes(wire)
        u = rng.random() if not protect else 1.0
        if u < 0.01:  # dropped by the radio
            dropped += 1
            continue
        if u < 0.025:  # 1..3 bit flips anywhere in the frame
            for _ in range(int(rng.integers(1, 4))):
                wire[int(rng.integers(len(wire)))] ^= 1 << int(rng.integers(8))
        elif u < 0.035:  # bytes inserted inside the frame (after the sync pair)
            at = int(rng.integers(2, len(wire)))
            wire[at:at] = rng.integers(0, 256, int(rng.integers(1, 6)), dtype=np.uint8).tobytes()
        elif u < 0.04:  # truncated
            del wire[int(rng.integers(1, len(wire))) :]
        placed.append((len(stream), original, frame, valid))
        stream += wire
        if not protect and rng.random() < 0.01:  # garbage between frames
            stream += rng.integers(0, 256, int(rng.integers(1, 50)), dtype=np.uint8).tobytes()
    # bursts that overwrite the stream in place, across frame boundaries
    protected_tail = placed[-3][0]
    for _ in range(40):
        at = int(rng.integers(placed[3][0], protected_tail - 64))
        length = int(rng.integers(4, 64))
        stream[at : at + length] = rng.integers(0, 256, length, dtype=np.uint8).tobytes()
    stream = bytes(stream)

    # truth: a placed frame is intact iff its bytes sit unchanged at its offset
    intact = [(f, v, len(o)) for (at, o, f, v) in placed if stream[at : at + len(o)] == o]
    corrupted = len(placed) - len(intact)
    assert dropped > 50 and corrupted > 200  # the run really injects faults

    dec = FrameDecoder()
    cuts = np.cumsum(rng.integers(1, 200, len(stream) // 50)).tolist()
    got = feed_chunked(dec, stream, cuts)
    s = dec.stats

    assert got == [f for f, v, _ in intact if v]
    assert s.frames_ok == sum(v for _, v, _ in intact)
    assert s.invalid_values == sum(not v for _, v, _ in intact) > 0
    assert s.frames_lost == dropped + corrupted
    assert s.bytes_received == len(stream)
    assert s.buffered == 0
    assert s.bytes_skipped == len(stream) - sum(n for _, _, n in intact)
    assert s.sequence_resets == 0
    ref_starts, ref_crc_failures = reference_scan(stream)
    assert len(ref_starts) == len(intact)
    assert s.crc_failures == ref_crc_failures
