"""The wire protocol's byte layout, without numpy: constants, frame kinds and commands, payload
lengths, CRC-16, the unit's identity, and the device-side command codec.

``gaitmon.io.protocol`` adds the frames (their values are numpy arrays) and their codec, and
re-exports every name here, so ``gaitmon.io.protocol`` is still the one name to import; this
module is what a light importer (a firmware port, the command decoder of the simulated unit, a
command-line parser) needs, and it imports no numpy. The counts that size the data frames come
from the channel table (``gaitmon.dsp.channel_table``).
"""

from __future__ import annotations

import binascii
import enum
import json
import struct
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

from gaitmon.dsp.channel_table import CHANNELS, N_CHANNELS, N_JOINTS, N_SEGMENTS, ChannelSpec

# --------------------------------------------------------------------------------------------
# Constants
# --------------------------------------------------------------------------------------------

FRAME_SYNC = b"\xa5\x5a"
COMMAND_SYNC = b"\xc3\x3c"
HEADER_LEN = 6  # sync(2) + kind(1) + length(1) + seq(2)
CRC_LEN = 2
FRAME_OVERHEAD = HEADER_LEN + CRC_LEN  # 8 bytes around every payload
COMMAND_LEN = 6
SEQ_MODULO = 1 << 16

ADC_MAX_COUNTS = 4095  # 12-bit ADC; anything above is a corrupted or bogus sample
ANGLE_LSB_DEG = 0.01
ANGLE_CODES_PER_DEG = 100  # divide by the integer, so code/100 is the nearest double to the decimal
ANGLE_NAN_CODE = -32768  # reserved: "not available"
ANGLE_MAX_CODE = 32767
ANGLE_MIN_CODE = -32767  # saturation floor (one above the NaN code)
ANGLE_MAX_DEG = ANGLE_MAX_CODE * ANGLE_LSB_DEG

NAME_LEN = 16  # identity name field, ASCII, NUL padded

BAUD_DEFAULT = 115200
SAMPLE_RATE_HZ_DEFAULT = 100
DEFAULT_TABLE_ID = 1


class FrameKind(enum.IntEnum):
    """Device -> PC frame kinds (byte 2 of a frame)."""

    RAW = 0x01  # N_CHANNELS (14) x uint16 ADC counts
    TILT = 0x02  # N_SEGMENTS (4) accelerometer tilts + 4 Kalman tilts
    JOINT = 0x03  # N_JOINTS (3) accelerometer + 3 Kalman joint angles, contacts, gait phase
    IDENTITY = 0x10  # answer to IDENTIFY
    ACK = 0x11  # answer to SELECT_KIND / START_STREAM / STOP_STREAM / ZERO, and any NAK


DATA_KINDS: tuple[FrameKind, ...] = (FrameKind.RAW, FrameKind.TILT, FrameKind.JOINT)


class Command(enum.IntEnum):
    """PC -> device command codes (byte 2 of a command)."""

    SELECT_KIND = 0x01  # arg = FrameKind.RAW | TILT | JOINT            -> ACK
    REQUEST_FRAME = 0x02  # arg = 0; one frame of the selected kind      -> that frame
    START_STREAM = 0x03  # arg = 0                                       -> ACK, then 100 Hz frames
    STOP_STREAM = 0x04  # arg = 0                                        -> ACK, frames stop
    IDENTIFY = 0x05  # arg = 0                                           -> IDENTITY frame
    ZERO = 0x06  # arg = 0; standing calibration of the angle offsets    -> ACK when done


class AckStatus(enum.IntEnum):
    """Status byte of an ACK frame; anything but OK is a NAK."""

    OK = 0
    BAD_ARGUMENT = 1  # e.g. SELECT_KIND with a non-data kind
    UNKNOWN_COMMAND = 2  # CRC-valid command with a code this firmware does not know
    BUSY = 3  # e.g. ZERO while the device cannot calibrate


class GaitPhase(enum.IntEnum):
    """Gait phase byte of a JOINT frame (from heel/toe contact, see SPEC section 6)."""

    SWING = 0
    LOADING = 1
    FOOT_FLAT = 2
    PUSH_OFF = 3


# Fixed payload length per kind. Every kind is fixed-length so a false header found inside
# garbage can make the decoder wait for at most one maximum-size frame before it is rejected.
PAYLOAD_LEN: dict[FrameKind, int] = {
    FrameKind.RAW: 2 * N_CHANNELS,  # 28 (the channel table's count: gaitmon.dsp.channel_table)
    FrameKind.TILT: 2 * 2 * N_SEGMENTS,  # 16
    FrameKind.JOINT: 2 * 2 * N_JOINTS + 2,  # 12 angles + contact byte + phase byte = 14
    FrameKind.IDENTITY: NAME_LEN + 3 + 4 + 1 + 1 + 2 + 2 + 2,  # 31
    FrameKind.ACK: 3,  # command, status, argument echoed
}
FRAME_LEN: dict[FrameKind, int] = {k: v + FRAME_OVERHEAD for k, v in PAYLOAD_LEN.items()}
MAX_FRAME_LEN = max(FRAME_LEN.values())
MAX_DATA_FRAME_LEN = max(FRAME_LEN[k] for k in DATA_KINDS)

# The paper's frames (1 start + 1 seq byte + payload + 1 check byte), for the budget table.
PAPER_FRAME_LEN: dict[FrameKind, int] = {FrameKind.RAW: 31, FrameKind.TILT: 19, FrameKind.JOINT: 20}

CONTACT_HEEL_BIT = 0x01
CONTACT_TOE_BIT = 0x02
CONTACT_RESERVED_MASK = 0xFF & ~(CONTACT_HEEL_BIT | CONTACT_TOE_BIT)


# --------------------------------------------------------------------------------------------
# CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, xorout 0; check("123456789")=0x29B1
# --------------------------------------------------------------------------------------------

CRC16_POLY = 0x1021
CRC16_INIT = 0xFFFF


def _make_crc16_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ CRC16_POLY) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


CRC16_TABLE: tuple[int, ...] = _make_crc16_table()


def crc16_table_driven(data: bytes | bytearray | memoryview, crc: int = CRC16_INIT) -> int:
    """CRC-16/CCITT-FALSE, table-driven, pure Python: the reference a firmware port follows."""
    table = CRC16_TABLE
    for b in bytes(data):
        crc = ((crc << 8) & 0xFFFF) ^ table[((crc >> 8) ^ b) & 0xFF]
    return crc


def crc16(data: bytes | bytearray | memoryview, crc: int = CRC16_INIT) -> int:
    """CRC-16/CCITT-FALSE, fast path.

    binascii.crc_hqx is the same polynomial, unreflected, with the initial value passed in; the
    tests check it against `crc16_table_driven` and the published check value.
    """
    return binascii.crc_hqx(data, crc)


# --------------------------------------------------------------------------------------------
# Identity and the channel-table reference (the IDENTITY payload is packed in protocol.py)
# --------------------------------------------------------------------------------------------


class HasChannels(Protocol):
    """A channel table (``gaitmon.dsp.channels.ChannelTable``, or one read from a file)."""

    @property
    def channels(self) -> tuple[ChannelSpec, ...]: ...


def channel_table_crc(table: HasChannels | None = None) -> int:
    """CRC-16 of the table's canonical JSON (sorted keys, compact): a fingerprint the device
    reports so the PC can tell whether its copy of the calibration table matches the unit's.
    Without a table, the unit's own (``gaitmon.dsp.channel_table.CHANNELS``)."""
    doc = [c.as_dict() for c in (CHANNELS if table is None else table.channels)]
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"))
    return crc16(text.encode("utf-8"))


DEFAULT_TABLE_CRC = channel_table_crc()


@dataclass(frozen=True)
class Identity:
    """What the unit says about itself in an IDENTITY frame."""

    name: str  # ASCII, at most 16 bytes
    firmware: str  # "major.minor.patch", each 0..255
    serial: int  # uint32
    side: str  # "L" or "R": which leg the unit is worn on
    sample_rate_hz: int = SAMPLE_RATE_HZ_DEFAULT  # uint16
    n_channels: int = N_CHANNELS  # uint8
    table_id: int = DEFAULT_TABLE_ID  # uint16: which channel calibration table the unit uses
    table_crc: int = DEFAULT_TABLE_CRC  # uint16: channel_table_crc() of that table

    def matches_table(self, table: HasChannels | None = None) -> bool:
        """True if the unit's calibration table fingerprint equals this table's (default: the
        unit's own)."""
        channels = CHANNELS if table is None else table.channels
        return self.n_channels == len(channels) and self.table_crc == channel_table_crc(table)


# --------------------------------------------------------------------------------------------
# Commands (PC -> device)
# --------------------------------------------------------------------------------------------

_CRC = struct.Struct("<H")


def encode_command(cmd: Command | int, arg: int = 0) -> bytes:
    """Encode a 6-byte command. SELECT_KIND takes the FrameKind as arg; the others take 0."""
    code = int(cmd)
    if not 0 <= code <= 255 or not 0 <= int(arg) <= 255:
        raise ValueError(f"command code and argument must be bytes, got {code}, {arg}")
    body = bytes((code, int(arg)))
    return COMMAND_SYNC + body + _CRC.pack(crc16(body))


class CommandRequest(NamedTuple):
    """A decoded command. `command` is a Command, or a plain int for a code the PC side does
    not know (the device answers those with a NAK UNKNOWN_COMMAND)."""

    command: Any
    arg: int


@dataclass(frozen=True)
class CommandDecoderStats:
    bytes_received: int = 0  # every byte fed
    commands_ok: int = 0  # CRC-valid commands returned (known or not)
    crc_failures: int = 0  # sync found, 6 bytes present, CRC mismatch
    bytes_skipped: int = 0  # bytes discarded outside CRC-valid commands


@dataclass
class CommandDecoder:
    """Device-side command decoder: feed bytes in any chunking, get CommandRequests.

    Pure and total: never raises on any input; keeps at most COMMAND_LEN - 1 bytes between calls.
    """

    _buf: bytearray = field(default_factory=bytearray)
    _received: int = 0
    _ok: int = 0
    _crc_fail: int = 0
    _skipped: int = 0

    def feed(self, data: bytes | bytearray | memoryview) -> list[CommandRequest]:
        if not data:
            return []
        buf = self._buf
        buf += data
        self._received += len(data)
        out: list[CommandRequest] = []
        pos, n = 0, len(buf)
        while True:
            i = buf.find(COMMAND_SYNC, pos)
            if i < 0:
                keep = n - 1 if n > pos and buf[n - 1] == COMMAND_SYNC[0] else n
                self._skipped += keep - pos
                pos = keep
                break
            self._skipped += i - pos
            pos = i
            if n - pos < COMMAND_LEN:
                break
            body = bytes(buf[pos + 2 : pos + 4])
            if crc16(body) != buf[pos + 4] | (buf[pos + 5] << 8):
                self._crc_fail += 1
                self._skipped += 1
                pos += 1
                continue
            code, arg = body[0], body[1]
            cmd = Command(code) if code in Command._value2member_map_ else code
            out.append(CommandRequest(cmd, arg))
            self._ok += 1
            pos += COMMAND_LEN
        del buf[:pos]
        return out

    @property
    def stats(self) -> CommandDecoderStats:
        return CommandDecoderStats(self._received, self._ok, self._crc_fail, self._skipped)

    @property
    def buffered(self) -> int:
        return len(self._buf)


def link_load(frame_len_bytes: int, rate_hz: float, baud: int = BAUD_DEFAULT) -> float:
    """Fraction of a UART link used by `rate_hz` frames of `frame_len_bytes` (8N1: 10 bits/byte)."""
    return frame_len_bytes * 10 * rate_hz / baud
