"""Wire protocol: CRC against published check values, byte layouts built by hand, scaling, sizes."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gaitmon.dsp.channels import DEFAULT_TABLE, ChannelTable
from gaitmon.io import protocol as p


def crc16_bitwise(data: bytes) -> int:
    """Textbook bit-by-bit CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF), no table."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


# --- CRC ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("impl", [p.crc16, p.crc16_table_driven])
def test_crc_published_check_value(impl):
    # CRC-16/CCITT-FALSE catalogue entry: check = 0x29B1 for ASCII "123456789"
    assert impl(b"123456789") == 0x29B1
    assert impl(b"") == 0xFFFF  # init value, nothing shifted in


def test_crc_residue_of_message_with_its_crc_appended_big_endian_is_zero():
    # property of an unreflected CRC with xorout 0: appending the CRC (MSB first) gives 0
    msg = b"gaitmon"
    crc = p.crc16_table_driven(msg)
    assert p.crc16_table_driven(msg + crc.to_bytes(2, "big")) == 0


@given(st.binary(max_size=300))
def test_crc_table_fast_and_bitwise_agree(data):
    ref = crc16_bitwise(data)
    assert p.crc16_table_driven(data) == ref
    assert p.crc16(data) == ref


# --- frame layout ------------------------------------------------------------------------------


def test_raw_frame_bytes_by_hand():
    adc = np.array([0, 1, 2, 4095, 0x0123, 7, 8, 9, 10, 11, 12, 13, 1000, 2000], dtype=np.uint16)
    wire = p.encode_frame(p.RawFrame(0x1234, adc))
    body = bytes([0x01, 28, 0x34, 0x12])
    for v in adc.tolist():
        body += bytes([v & 0xFF, v >> 8])
    crc = crc16_bitwise(body)
    expected = b"\xa5\x5a" + body + bytes([crc & 0xFF, crc >> 8])
    assert wire == expected
    assert len(wire) == 36


def test_tilt_frame_scaling_saturation_and_nan():
    acc = [12.346, -0.004, 400.0, -400.0]
    kal = [float("nan"), 327.67, -327.67, 0.005]
    wire = p.encode_frame(p.TiltFrame(1, acc, kal))
    codes = np.frombuffer(wire[6:-2], dtype="<i2").tolist()
    # 0.01 deg/LSB, rounded; +-400 saturate to +-32767; NaN -> reserved -32768; 0.005 -> 0 or 1
    assert codes[:7] == [1235, 0, 32767, -32767, -32768, 32767, -32767]
    assert codes[7] in (0, 1)
    assert len(wire) == 24


def test_joint_frame_contacts_and_phase_bytes():
    wire = p.encode_frame(
        p.JointFrame(2, [10.0, 65.5, -5.25], [9.0, 60.0, -4.0], True, False, p.GaitPhase.LOADING)
    )
    assert len(wire) == 22
    payload = wire[6:-2]
    assert np.frombuffer(payload[:12], dtype="<i2").tolist() == [1000, 6550, -525, 900, 6000, -400]
    assert payload[12] == 0b01  # heel bit only
    assert payload[13] == 1


def test_angle_codes_roundtrip_on_grid():
    codes = np.arange(-32767, 32768, 97, dtype=np.int16)
    assert np.array_equal(p.angles_to_codes(p.codes_to_angles(codes)), codes)


def test_encode_rejects_out_of_range_unless_told_not_to():
    bad = p.RawFrame(0, np.full(14, 4096))
    with pytest.raises(ValueError, match="4095"):
        p.encode_frame(bad)
    assert len(p.encode_frame(bad, validate=False)) == 36
    with pytest.raises(ValueError, match="phase"):
        p.encode_frame(p.JointFrame(0, np.zeros(3), np.zeros(3), False, False, 4))


def test_frames_are_immutable_and_do_not_freeze_caller_arrays():
    adc = np.arange(14, dtype=np.uint16)
    f = p.RawFrame(0, adc)
    assert adc.flags.writeable
    with pytest.raises(ValueError):
        f.adc[0] = 5
    with pytest.raises(dataclasses.FrozenInstanceError):
        f.seq = 3  # type: ignore[misc]


def test_identity_payload_and_errors():
    ident = p.Identity(name="unit-7", firmware="2.10.3", serial=0xDEADBEEF, side="L")
    payload = p.encode_identity_payload(ident)
    assert len(payload) == p.PAYLOAD_LEN[p.FrameKind.IDENTITY]
    assert payload[:16] == b"unit-7" + b"\x00" * 10
    assert payload[16:19] == bytes([2, 10, 3])
    assert payload[19:23] == (0xDEADBEEF).to_bytes(4, "little")
    assert payload[23:24] == b"L"
    frame = p.decode_payload(p.FrameKind.IDENTITY, 9, payload)
    assert frame == p.IdentityFrame(9, ident)
    with pytest.raises(ValueError, match="side"):
        p.encode_identity_payload(dataclasses.replace(ident, side="X"))
    with pytest.raises(ValueError, match="16"):
        p.encode_identity_payload(dataclasses.replace(ident, name="x" * 17))
    with pytest.raises(ValueError, match="firmware"):
        p.encode_identity_payload(dataclasses.replace(ident, firmware="1.2"))


def test_channel_table_fingerprint_detects_a_changed_table():
    ident = p.Identity(name="u", firmware="1.0.0", serial=1, side="R")
    assert ident.matches_table(DEFAULT_TABLE)
    changed = list(DEFAULT_TABLE.channels)
    changed[3] = dataclasses.replace(changed[3], zero_v=changed[3].zero_v + 0.01)
    other = ChannelTable(tuple(changed))
    assert p.channel_table_crc(other) != p.channel_table_crc(DEFAULT_TABLE)
    assert not ident.matches_table(other)


# --- sizes and link budget ---------------------------------------------------------------------


def test_frame_sizes_against_paper_and_link_budget():
    assert p.FRAME_LEN[p.FrameKind.RAW] == 36  # paper 31: +2 sync, +1 kind, +1 len, +1 seq, +1 CRC
    assert p.FRAME_LEN[p.FrameKind.TILT] == 24  # paper 19
    assert p.FRAME_LEN[p.FrameKind.JOINT] == 22  # paper 20
    # 100 Hz of the largest data frame at 115200 baud, 10 bits per byte on the wire
    largest = max(p.FRAME_LEN[k] for k in p.DATA_KINDS)
    assert largest * 10 * 100 / 115200 <= 0.35
    assert p.link_load(largest, 100) == pytest.approx(largest * 1000 / 115200)


# --- commands ----------------------------------------------------------------------------------


def test_command_bytes_by_hand():
    wire = p.encode_command(p.Command.SELECT_KIND, p.FrameKind.JOINT)
    crc = crc16_bitwise(bytes([0x01, 0x03]))
    assert wire == bytes([0xC3, 0x3C, 0x01, 0x03, crc & 0xFF, crc >> 8])
    with pytest.raises(ValueError):
        p.encode_command(p.Command.SELECT_KIND, 300)


def test_command_sync_cannot_be_mistaken_for_frame_sync():
    assert p.COMMAND_SYNC != p.FRAME_SYNC
    assert p.FRAME_SYNC not in p.COMMAND_SYNC + p.COMMAND_SYNC


COMMANDS = [(c, 0) for c in p.Command] + [(p.Command.SELECT_KIND, k) for k in p.DATA_KINDS]


@given(
    garbage=st.lists(st.binary(max_size=8), min_size=len(COMMANDS) + 1, max_size=len(COMMANDS) + 1),
    cuts=st.lists(st.integers(min_value=0, max_value=400), max_size=30),
)
def test_command_decoder_finds_every_command_between_garbage_in_any_chunking(garbage, cuts):
    # garbage without the command sync's first byte cannot start a false candidate
    garbage = [g.replace(b"\xc3", b"\x00") for g in garbage]
    stream = garbage[0]
    for (cmd, arg), g in zip(COMMANDS, garbage[1:], strict=True):
        stream += p.encode_command(cmd, arg) + g
    dec = p.CommandDecoder()
    got = []
    bounds = sorted({0, len(stream), *[c for c in cuts if c < len(stream)]})
    for a, b in itertools.pairwise(bounds):
        got += dec.feed(stream[a:b])
        assert dec.buffered < p.COMMAND_LEN
    assert [(c, a) for c, a in got] == COMMANDS
    s = dec.stats
    assert s.bytes_received == len(stream)
    assert s.bytes_skipped == sum(len(g) for g in garbage)
    assert s.commands_ok == len(COMMANDS)
    assert s.crc_failures == 0


@given(st.binary(max_size=500))
def test_command_decoder_never_raises(data):
    dec = p.CommandDecoder()
    dec.feed(data)
    dec.feed(data[::-1])
    assert dec.buffered < p.COMMAND_LEN


def test_command_decoder_reports_unknown_codes_and_counts_crc_failures():
    good = p.encode_command(0x7E, 5)
    bad = bytearray(p.encode_command(p.Command.ZERO))
    bad[3] ^= 0x40
    dec = p.CommandDecoder()
    got = dec.feed(bytes(bad) + good)
    assert got == [(0x7E, 5)]
    assert not isinstance(got[0].command, p.Command)
    assert dec.stats.crc_failures == 1
    assert dec.stats.bytes_skipped == 6


def test_protocol_doc_examples_match_the_code():
    """docs/protocol.md is the firmware's reference: its worked examples must be what we send."""
    from pathlib import Path

    doc = (Path(__file__).parents[1] / "docs" / "protocol.md").read_text()
    assert p.encode_command(p.Command.START_STREAM).hex(" ") in doc
    assert p.encode_command(p.Command.SELECT_KIND, p.FrameKind.RAW).hex(" ") in doc
    assert p.encode_frame(p.AckFrame(7, p.Command.START_STREAM)).hex(" ") in doc
    assert f"0x{p.DEFAULT_TABLE_CRC:04X}" in doc
    for kind in p.DATA_KINDS:
        assert f"**{p.FRAME_LEN[kind]}**" in doc
    assert f"**{100 * p.link_load(p.FRAME_LEN[p.FrameKind.RAW], 100):.2f} %**" in doc
