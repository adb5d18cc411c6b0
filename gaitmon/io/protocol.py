"""The gaitmon wire protocol: frame and command layouts, CRC-16, encoders, and the command decoder.

This module owns the byte layout shared by the device firmware, the simulated unit and the PC.
`docs/protocol.md` is the human reference; the constants here are the machine one. The PC-side
frame decoder lives in `gaitmon.io.decoder`; the device-side command decoder lives here so the
simulated unit (and a firmware port) need only this module.

Device -> PC frame (all multi-byte fields little-endian)::

    offset  size  field
    0       2     sync 0xA5 0x5A
    2       1     kind (FrameKind)
    3       1     payload length; must equal the kind's fixed length (a header self-check)
    4       2     sequence number, uint16, +1 per frame transmitted (all kinds share it), wraps
    6       L     payload
    6+L     2     CRC-16/CCITT-FALSE over bytes 2 .. 6+L-1 (kind, length, seq, payload)

PC -> device command (6 bytes)::

    0  2  sync 0xC3 0x3C      (differs from the frame sync so the two streams cannot be confused)
    2  1  command (Command)
    3  1  argument (0 unless the command takes one)
    4  2  CRC-16/CCITT-FALSE over bytes 2..3

Angles travel as int16 in units of 0.01 deg, saturated to +-327.67 deg; -32768 is reserved for
"not available" and decodes to NaN.
"""

from __future__ import annotations

import binascii
import enum
import json
import struct
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from gaitmon.dsp.channels import DEFAULT_TABLE, N_CHANNELS, ChannelTable

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

N_SEGMENTS = 4  # body, thigh, shank, foot
N_JOINTS = 3  # hip, knee, ankle
NAME_LEN = 16  # identity name field, ASCII, NUL padded

BAUD_DEFAULT = 115200
SAMPLE_RATE_HZ_DEFAULT = 100
DEFAULT_TABLE_ID = 1


class FrameKind(enum.IntEnum):
    """Device -> PC frame kinds (byte 2 of a frame)."""

    RAW = 0x01  # 14 x uint16 ADC counts
    TILT = 0x02  # 4 accelerometer tilts + 4 Kalman tilts
    JOINT = 0x03  # 3 accelerometer + 3 Kalman joint angles, contacts, gait phase
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
    FrameKind.RAW: 2 * N_CHANNELS,  # 28
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
_CONTACT_RESERVED_MASK = 0xFF & ~(CONTACT_HEEL_BIT | CONTACT_TOE_BIT)


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
# Angle scaling
# --------------------------------------------------------------------------------------------


def angles_to_codes(angles_deg: np.ndarray) -> np.ndarray:
    """float degrees -> int16 codes (0.01 deg/LSB), saturated; NaN -> the reserved -32768."""
    a = np.asarray(angles_deg, dtype=np.float64)
    nan = np.isnan(a)
    codes = np.clip(
        np.rint(np.where(nan, 0.0, a) * ANGLE_CODES_PER_DEG), ANGLE_MIN_CODE, ANGLE_MAX_CODE
    )
    codes = codes.astype(np.int16)
    codes[nan] = ANGLE_NAN_CODE
    return codes


def codes_to_angles(codes: np.ndarray) -> np.ndarray:
    """int16 codes -> float64 degrees, the reserved code -> NaN."""
    c = np.asarray(codes, dtype=np.int16)
    out = c.astype(np.float64) / ANGLE_CODES_PER_DEG
    out[c == ANGLE_NAN_CODE] = np.nan
    return out


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


# --------------------------------------------------------------------------------------------
# Identity and the channel-table reference
# --------------------------------------------------------------------------------------------


def channel_table_crc(table: ChannelTable = DEFAULT_TABLE) -> int:
    """CRC-16 of the table's canonical JSON (sorted keys, compact): a fingerprint the device
    reports so the PC can tell whether its copy of the calibration table matches the unit's."""
    doc = [c.as_dict() for c in table.channels]
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"))
    return crc16(text.encode("utf-8"))


DEFAULT_TABLE_CRC = channel_table_crc(DEFAULT_TABLE)


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

    def matches_table(self, table: ChannelTable = DEFAULT_TABLE) -> bool:
        """True if the unit's calibration table fingerprint equals this table's."""
        return self.n_channels == len(table.channels) and self.table_crc == channel_table_crc(table)


# --------------------------------------------------------------------------------------------
# Frames
# --------------------------------------------------------------------------------------------


def _arrays_equal(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))


@dataclass(frozen=True, eq=False)
class RawFrame:
    """14 ADC samples in channel-table order (see gaitmon.dsp.channels)."""

    seq: int
    adc: np.ndarray  # (14,) uint16, read-only

    kind = FrameKind.RAW

    def __post_init__(self) -> None:
        adc = np.asarray(self.adc)
        if adc.shape != (N_CHANNELS,):
            raise ValueError(f"RawFrame.adc must have shape ({N_CHANNELS},), got {adc.shape}")
        if adc.dtype != np.uint16 or adc.flags.writeable:
            # copy, so freezing never touches the caller's array
            adc = _frozen(np.array(adc, dtype=np.uint16))
        object.__setattr__(self, "adc", adc)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RawFrame):
            return NotImplemented
        return self.seq == other.seq and _arrays_equal(self.adc, other.adc)

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, eq=False)
class TiltFrame:
    """Segment tilts (body, thigh, shank, foot) in degrees: from the accelerometer and Kalman."""

    seq: int
    acc_tilt_deg: np.ndarray  # (4,) float64
    kalman_tilt_deg: np.ndarray  # (4,) float64

    kind = FrameKind.TILT

    def __post_init__(self) -> None:
        for name in ("acc_tilt_deg", "kalman_tilt_deg"):
            a = np.asarray(getattr(self, name), dtype=np.float64)
            if a.shape != (N_SEGMENTS,):
                raise ValueError(f"TiltFrame.{name} must have shape ({N_SEGMENTS},), got {a.shape}")
            object.__setattr__(self, name, _frozen(a.copy()) if a.flags.writeable else a)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TiltFrame):
            return NotImplemented
        return (
            self.seq == other.seq
            and _arrays_equal(self.acc_tilt_deg, other.acc_tilt_deg)
            and _arrays_equal(self.kalman_tilt_deg, other.kalman_tilt_deg)
        )

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, eq=False)
class JointFrame:
    """Joint angles (hip, knee, ankle; clinical signs) in degrees, foot contacts and gait phase."""

    seq: int
    acc_joint_deg: np.ndarray  # (3,) float64
    kalman_joint_deg: np.ndarray  # (3,) float64
    heel_loaded: bool
    toe_loaded: bool
    phase: int  # GaitPhase 0..3

    kind = FrameKind.JOINT

    def __post_init__(self) -> None:
        for name in ("acc_joint_deg", "kalman_joint_deg"):
            a = np.asarray(getattr(self, name), dtype=np.float64)
            if a.shape != (N_JOINTS,):
                raise ValueError(f"JointFrame.{name} must have shape ({N_JOINTS},), got {a.shape}")
            object.__setattr__(self, name, _frozen(a.copy()) if a.flags.writeable else a)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, JointFrame):
            return NotImplemented
        return (
            self.seq == other.seq
            and _arrays_equal(self.acc_joint_deg, other.acc_joint_deg)
            and _arrays_equal(self.kalman_joint_deg, other.kalman_joint_deg)
            and bool(self.heel_loaded) == bool(other.heel_loaded)
            and bool(self.toe_loaded) == bool(other.toe_loaded)
            and int(self.phase) == int(other.phase)
        )

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True)
class IdentityFrame:
    seq: int
    identity: Identity

    kind = FrameKind.IDENTITY


@dataclass(frozen=True)
class AckFrame:
    """The device's answer to a command: status OK is an ACK, anything else a NAK."""

    seq: int
    command: int  # Command code being answered (int if the device did not know it)
    status: AckStatus = AckStatus.OK
    arg: int = 0  # the command's argument, echoed

    kind = FrameKind.ACK

    @property
    def ok(self) -> bool:
        return self.status == AckStatus.OK


Frame = RawFrame | TiltFrame | JointFrame | IdentityFrame | AckFrame
DataFrame = RawFrame | TiltFrame | JointFrame

# --------------------------------------------------------------------------------------------
# Encoding
# --------------------------------------------------------------------------------------------

_HEADER = struct.Struct("<2sBBH")
_CRC = struct.Struct("<H")
_IDENTITY = struct.Struct(f"<{NAME_LEN}s3BIcBHHH")
_ACK = struct.Struct("<BBB")
_JOINT_TAIL = struct.Struct("<BB")
_PREFIX = {k: bytes([k, PAYLOAD_LEN[k]]) for k in FrameKind}


def _pack(kind: FrameKind, seq: int, payload: bytes) -> bytes:
    body = _PREFIX[kind] + (seq % SEQ_MODULO).to_bytes(2, "little") + payload
    return FRAME_SYNC + body + _CRC.pack(crc16(body))


def _parse_firmware(text: str) -> tuple[int, int, int]:
    parts = text.split(".")
    try:
        nums = tuple(int(p) for p in parts)
    except ValueError:
        nums = ()
    if len(nums) != 3 or not all(0 <= n <= 255 for n in nums):
        raise ValueError(f"firmware version must be 'major.minor.patch' with 0..255, got {text!r}")
    return nums[0], nums[1], nums[2]


def encode_identity_payload(identity: Identity) -> bytes:
    name = identity.name.encode("ascii")
    if len(name) > NAME_LEN:
        raise ValueError(f"identity name longer than {NAME_LEN} bytes: {identity.name!r}")
    if identity.side not in ("L", "R"):
        raise ValueError(f"identity side must be 'L' or 'R', got {identity.side!r}")
    major, minor, patch = _parse_firmware(identity.firmware)
    return _IDENTITY.pack(
        name,
        major,
        minor,
        patch,
        identity.serial,
        identity.side.encode("ascii"),
        identity.n_channels,
        identity.sample_rate_hz,
        identity.table_id,
        identity.table_crc,
    )


def encode_payload(frame: Frame, *, validate: bool = True) -> bytes:
    """The payload bytes of a frame (no header, no CRC)."""
    if isinstance(frame, RawFrame):
        adc = frame.adc
        if validate and int(adc.max()) > ADC_MAX_COUNTS:
            raise ValueError(f"ADC sample above {ADC_MAX_COUNTS}: {int(adc.max())}")
        return adc.astype("<u2", copy=False).tobytes()
    if isinstance(frame, TiltFrame):
        codes = angles_to_codes(np.concatenate([frame.acc_tilt_deg, frame.kalman_tilt_deg]))
        return codes.astype("<i2", copy=False).tobytes()
    if isinstance(frame, JointFrame):
        codes = angles_to_codes(np.concatenate([frame.acc_joint_deg, frame.kalman_joint_deg]))
        phase = int(frame.phase)
        if validate and not 0 <= phase <= 3:
            raise ValueError(f"gait phase must be 0..3, got {phase}")
        contacts = (CONTACT_HEEL_BIT if frame.heel_loaded else 0) | (
            CONTACT_TOE_BIT if frame.toe_loaded else 0
        )
        return codes.astype("<i2", copy=False).tobytes() + _JOINT_TAIL.pack(contacts, phase & 0xFF)
    if isinstance(frame, IdentityFrame):
        return encode_identity_payload(frame.identity)
    if isinstance(frame, AckFrame):
        return _ACK.pack(int(frame.command) & 0xFF, int(frame.status) & 0xFF, int(frame.arg) & 0xFF)
    raise TypeError(f"not a gaitmon frame: {type(frame).__name__}")


def encode_frame(frame: Frame, *, validate: bool = True) -> bytes:
    """Encode one frame to wire bytes. The sequence number is taken modulo 2**16.

    validate=False lets a fault injector put out-of-range values (ADC > 4095, phase > 3) on the
    wire; normally they raise ValueError. Angles are always saturated, never rejected.
    """
    return _pack(frame.kind, int(frame.seq), encode_payload(frame, validate=validate))


def encode_raw_block(seq_start: int, adc: np.ndarray) -> bytes:
    """Encode N RAW frames (seq_start, seq_start+1, ...) from (N, 14) counts in one call.

    Faster than N encode_frame calls for a simulator that produces blocks. Values are saturated
    to the ADC range.
    """
    a = np.clip(np.asarray(adc), 0, ADC_MAX_COUNTS).astype("<u2")
    if a.ndim != 2 or a.shape[1] != N_CHANNELS:
        raise ValueError(f"adc must have shape (N, {N_CHANNELS}), got {a.shape}")
    prefix = _PREFIX[FrameKind.RAW]
    out = []
    for i, row in enumerate(a):
        body = prefix + ((seq_start + i) % SEQ_MODULO).to_bytes(2, "little") + row.tobytes()
        out.append(FRAME_SYNC + body + _CRC.pack(crc16(body)))
    return b"".join(out)


# --------------------------------------------------------------------------------------------
# Payload decoding (used by gaitmon.io.decoder; pure, returns None for out-of-range values)
# --------------------------------------------------------------------------------------------


def decode_payload(kind: int, seq: int, payload: bytes) -> Frame | None:
    """Decode a CRC-checked payload of a known kind; None if a value is out of range."""
    if kind == FrameKind.RAW:
        adc = np.frombuffer(payload, dtype="<u2").astype(np.uint16, copy=False)
        if int(adc.max()) > ADC_MAX_COUNTS:
            return None
        return RawFrame(seq, adc)
    if kind == FrameKind.TILT:
        ang = codes_to_angles(np.frombuffer(payload, dtype="<i2"))
        return TiltFrame(seq, ang[:N_SEGMENTS], ang[N_SEGMENTS:])
    if kind == FrameKind.JOINT:
        ang = codes_to_angles(np.frombuffer(payload, dtype="<i2", count=2 * N_JOINTS))
        contacts, phase = payload[-2], payload[-1]
        if contacts & _CONTACT_RESERVED_MASK or phase > 3:
            return None
        return JointFrame(
            seq,
            ang[:N_JOINTS],
            ang[N_JOINTS:],
            heel_loaded=bool(contacts & CONTACT_HEEL_BIT),
            toe_loaded=bool(contacts & CONTACT_TOE_BIT),
            phase=phase,
        )
    if kind == FrameKind.IDENTITY:
        (name, major, minor, patch, serial, side, n_ch, rate, table_id, table_crc) = (
            _IDENTITY.unpack(payload)
        )
        try:
            name_text = name.rstrip(b"\x00").decode("ascii")
        except UnicodeDecodeError:
            return None
        if side not in (b"L", b"R") or "\x00" in name_text:
            return None
        ident = Identity(
            name=name_text,
            firmware=f"{major}.{minor}.{patch}",
            serial=serial,
            side=side.decode("ascii"),
            sample_rate_hz=rate,
            n_channels=n_ch,
            table_id=table_id,
            table_crc=table_crc,
        )
        return IdentityFrame(seq, ident)
    if kind == FrameKind.ACK:
        command, status, arg = _ACK.unpack(payload)
        if status not in AckStatus._value2member_map_:
            return None
        cmd: int = Command(command) if command in Command._value2member_map_ else command
        return AckFrame(seq, cmd, AckStatus(status), arg)
    return None


# --------------------------------------------------------------------------------------------
# Commands (PC -> device)
# --------------------------------------------------------------------------------------------

_COMMAND = struct.Struct("<2sBBH")


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
