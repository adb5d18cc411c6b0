"""The crash journal: byte layout as documented, exact round trips, and tolerance of damage."""

from __future__ import annotations

import json
import struct
import zlib

import numpy as np
import pytest

from gaitmon.io.journal import (
    MAGIC,
    ROW_DTYPES,
    JournalWriter,
    RecordType,
    encode_block,
    encode_json,
    encode_record,
    journal_path,
    read_journal,
)

pytestmark = pytest.mark.timeout(60)

HEADER = {"mode": "raw", "sample_rate_hz": 100.0}


def _raw_rows(seq: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    rows = np.empty(len(seq), dtype=ROW_DTYPES[RecordType.RAW])
    rows["seq"] = seq
    rows["host_time_s"] = 1000.0 + seq / 100.0 + rng.random(len(seq)) * 1e-3
    rows["lost_before"] = rng.integers(0, 3, size=len(seq))
    rows["adc"] = rng.integers(0, 4096, size=(len(seq), 14))
    return rows


def _write_journal(path, blocks, extra=()):
    w = JournalWriter(path)
    w.write_raw(encode_json(RecordType.HEADER, HEADER))
    for rec in extra:
        w.write_raw(rec)
    for b in blocks:
        w.write_raw(encode_block(RecordType.RAW, 1.7e9, b))
    w.sync()
    w.close()
    return path.read_bytes()


def test_record_layout_matches_the_documented_bytes():
    # [u8 type][u32 length LE][payload][u32 CRC-32 of type+length+payload, LE], built by hand
    payload = b'{"a":1}'
    by_hand = bytes([7]) + len(payload).to_bytes(4, "little") + payload
    by_hand += (zlib.crc32(by_hand) & 0xFFFFFFFF).to_bytes(4, "little")
    assert encode_record(7, payload) == by_hand


def test_row_sizes_are_the_documented_ones():
    # docs/file-format.md: seq, host_time_s, lost_before (8+8+4) then raw 14*2, tilt 4*8+4*8,
    # joint 3*8+3*8+3 bytes
    sizes = {t: d.itemsize for t, d in ROW_DTYPES.items()}
    assert sizes == {RecordType.RAW: 48, RecordType.TILT: 84, RecordType.JOINT: 71}


def test_block_payload_is_n_wall_offset_then_packed_rows(tmp_path):
    rows = _raw_rows(np.array([5, 6, 9]), np.random.default_rng(0))
    rec = encode_block(RecordType.RAW, 12.5, rows)
    n, wall = struct.unpack_from("<Id", rec, 5)
    assert (n, wall) == (3, 12.5)
    # seq, host_time_s, lost_before, adc[14] of row 0
    first = struct.unpack_from("<qdI14H", rec, 5 + 12)
    assert first[0] == 5
    assert first[1] == rows["host_time_s"][0]
    assert first[2] == rows["lost_before"][0]
    assert list(first[3:]) == rows["adc"][0].tolist()
    assert len(rec) == 5 + 12 + 3 * (8 + 8 + 4 + 28) + 4


def test_round_trip_of_blocks_and_logs_is_exact(tmp_path):
    rng = np.random.default_rng(1)
    sizes = rng.integers(0, 7, size=300)  # includes empty blocks
    seq = np.arange(int(sizes.sum())) * 2 + 11
    parts = np.split(seq, np.cumsum(sizes)[:-1])
    blocks = [_raw_rows(p, rng) for p in parts]
    extra = [
        encode_json(RecordType.MARKER, {"sample_idx": 3, "label": "start ü"}),
        encode_json(
            RecordType.GAP, {"sample_idx": 4, "n_lost": 2, "duration_s": 0.02, "reason": "x"}
        ),
        encode_json(RecordType.CONFIG, {"sample_idx": 5, "config": {"cutoff_hz": 5.0}}),
        encode_json(RecordType.CALIBRATION, {"sample_idx": 6, "calibration": {}}),
        encode_json(RecordType.LINK, {"sample_idx": 7, "totals": {"crc_failures": 1}}),
        encode_record(200, b"a record type from a later version"),
    ]
    path = tmp_path / "s.h5.journal"
    _write_journal(path, blocks, extra)
    c = read_journal(path)
    assert c.problem == ""
    assert c.header == HEADER
    assert c.n_blocks == len(blocks)
    expected = np.concatenate(blocks)
    assert c.rows.dtype == expected.dtype
    assert np.array_equal(c.rows["seq"], expected["seq"])
    assert np.array_equal(c.rows["host_time_s"], expected["host_time_s"])
    assert np.array_equal(c.rows["lost_before"], expected["lost_before"])
    assert np.array_equal(c.rows["adc"], expected["adc"])
    assert c.wall_offset_s == 1.7e9
    assert c.markers == [{"sample_idx": 3, "label": "start ü"}]
    assert c.gaps[0]["n_lost"] == 2
    assert [t for t, _ in c.changes] == [RecordType.CONFIG, RecordType.CALIBRATION]
    assert c.links[0]["totals"] == {"crc_failures": 1}
    assert c.valid_bytes == c.total_bytes == path.stat().st_size


def test_every_truncation_keeps_all_whole_records(tmp_path):
    rng = np.random.default_rng(2)
    blocks = [_raw_rows(np.arange(3 * i, 3 * i + 3), rng) for i in range(6)]
    full = _write_journal(tmp_path / "full.journal", blocks)
    rec_len = len(encode_block(RecordType.RAW, 0.0, blocks[0]))
    header_end = len(full) - 6 * rec_len
    cut_path = tmp_path / "cut.journal"
    for cut in range(len(full) + 1):
        cut_path.write_bytes(full[:cut])
        c = read_journal(cut_path)  # must never raise
        whole_blocks = max(0, (cut - header_end) // rec_len)
        if cut < header_end:
            assert c.rows is None or len(c.rows) == 0
            assert c.problem
            continue
        assert c.n_rows == 3 * whole_blocks, cut
        assert np.array_equal(c.rows["seq"], np.arange(3 * whole_blocks))
        assert (c.problem == "") == (cut == header_end + whole_blocks * rec_len)


def test_a_flipped_bit_stops_reading_at_that_record(tmp_path):
    rng = np.random.default_rng(3)
    blocks = [_raw_rows(np.arange(4 * i, 4 * i + 4), rng) for i in range(10)]
    data = bytearray(_write_journal(tmp_path / "a.journal", blocks))
    rec_len = len(encode_block(RecordType.RAW, 0.0, blocks[0]))
    header_end = len(data) - 10 * rec_len
    # flip one bit inside the adc of block 6
    data[header_end + 6 * rec_len + 40] ^= 0x10
    path = tmp_path / "b.journal"
    path.write_bytes(bytes(data))
    c = read_journal(path)
    assert c.n_rows == 24
    assert "CRC" in c.problem
    assert np.array_equal(c.rows["adc"], np.concatenate(blocks[:6])["adc"])


@pytest.mark.parametrize(
    "content",
    [
        b"",
        MAGIC[:5],
        b"not a journal at all",
        MAGIC,
        MAGIC + b"\x01\xff\xff\xff\xff" + b"x" * 50,  # absurd length
        MAGIC + encode_record(RecordType.RAW, b"\x00" * 12),  # a block before any header
        MAGIC + encode_record(RecordType.HEADER, b"{not json"),
        MAGIC + encode_json(RecordType.HEADER, {"mode": "video"}),
    ],
)
def test_garbage_never_raises_and_gives_no_rows(tmp_path, content):
    path = tmp_path / "g.journal"
    path.write_bytes(content)
    c = read_journal(path)
    assert c.n_rows == 0
    assert c.problem


def test_random_garbage_never_raises(tmp_path):
    rng = np.random.default_rng(4)
    good = _write_journal(tmp_path / "good.journal", [_raw_rows(np.arange(5), rng)])
    path = tmp_path / "r.journal"
    for i in range(200):
        junk = rng.integers(0, 256, size=int(rng.integers(0, 400)), dtype=np.uint8).tobytes()
        path.write_bytes((good if i % 2 else MAGIC) + junk)
        c = read_journal(path)
        assert c.n_rows in (0, 5)


def test_a_block_of_the_wrong_kind_or_length_stops_reading(tmp_path):
    rng = np.random.default_rng(5)
    good = _raw_rows(np.arange(3), rng)
    tilt = np.zeros(2, dtype=ROW_DTYPES[RecordType.TILT])
    bad_len = encode_record(RecordType.RAW, struct.pack("<Id", 5, 0.0) + good.tobytes())
    for bad in (encode_block(RecordType.TILT, 0.0, tilt), bad_len):
        path = tmp_path / "k.journal"
        path.unlink(missing_ok=True)
        w = JournalWriter(path)
        w.write_raw(encode_json(RecordType.HEADER, HEADER))
        w.write_raw(encode_block(RecordType.RAW, 0.0, good))
        w.write_raw(bad)
        w.write_raw(encode_block(RecordType.RAW, 0.0, good))
        w.close()
        c = read_journal(path)
        assert c.n_rows == 3
        assert "malformed" in c.problem


def test_writer_refuses_to_overwrite_and_counts_bytes(tmp_path):
    path = tmp_path / "x.journal"
    w = JournalWriter(path)
    w.write_raw(encode_json(RecordType.HEADER, HEADER))
    assert w.bytes_written == path.stat().st_size
    w.close()
    with pytest.raises(FileExistsError):
        JournalWriter(path)


def test_journal_path_appends_the_suffix(tmp_path):
    assert journal_path(tmp_path / "a.h5") == tmp_path / "a.h5.journal"
    assert json.loads(encode_json(RecordType.HEADER, {"a": 1})[5:-4]) == {"a": 1}


def test_long_runs_of_equal_blocks_interleaved_with_other_records_keep_their_order(tmp_path):
    # the reader checks runs of same-sized blocks with numpy; breaks in a run must not reorder
    rng = np.random.default_rng(6)
    path = tmp_path / "runs.journal"
    w = JournalWriter(path)
    w.write_raw(encode_json(RecordType.HEADER, HEADER))
    expected = []
    next_seq = 0
    for run_len, n in ((500, 1), (3, 4), (1, 2), (700, 4), (0, 0), (40000, 1)):
        for _ in range(run_len):
            rows = _raw_rows(np.arange(next_seq, next_seq + n), rng)
            next_seq += n
            expected.append(rows)
            w.write_raw(encode_block(RecordType.RAW, 0.0, rows))
        w.write_raw(encode_json(RecordType.MARKER, {"sample_idx": next_seq, "label": "x"}))
    w.close()
    c = read_journal(path)
    assert c.problem == ""
    exp = np.concatenate(expected)
    assert np.array_equal(c.rows["seq"], np.arange(next_seq))
    assert np.array_equal(c.rows["adc"], exp["adc"])
    assert [m["sample_idx"] for m in c.markers] == [500, 512, 514, 3314, 3314, 43314]
    # a bad CRC deep inside a long run stops there
    data = bytearray(path.read_bytes())
    rec_len = len(encode_block(RecordType.RAW, 0.0, expected[-1]))
    marker_len = len(encode_json(RecordType.MARKER, {"sample_idx": 43314, "label": "x"}))
    bad_at = len(data) - marker_len - 1000 * rec_len + 30  # inside row 42314's record
    data[bad_at] ^= 1
    path.write_bytes(bytes(data))
    c = read_journal(path)
    assert c.n_rows == 42314
    assert "CRC" in c.problem
