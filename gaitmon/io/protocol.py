"""The gaitmon wire protocol: its frames as values and their codec (encode, decode a payload).

This module owns the byte layout shared by the device firmware, the simulated unit and the PC,
in two parts: the layout itself (constants, kinds, commands, payload lengths, CRC-16, the
identity, the device-side command decoder) is ``gaitmon.io.wire``, which imports no numpy; this
module adds the frames, whose values are numpy arrays, and re-exports every name of
``gaitmon.io.wire``: import the protocol from here. `docs/protocol.md` is the human reference;
the constants are the machine one. The PC-side frame decoder lives in `gaitmon.io.decoder`.

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

import struct
from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.channel_table import CHANNELS, N_CHANNELS, N_JOINTS, N_SEGMENTS
from gaitmon.io.wire import (
    _CRC,
    ADC_MAX_COUNTS,
    ANGLE_CODES_PER_DEG,
    ANGLE_LSB_DEG,
    ANGLE_MAX_CODE,
    ANGLE_MAX_DEG,
    ANGLE_MIN_CODE,
    ANGLE_NAN_CODE,
    BAUD_DEFAULT,
    COMMAND_LEN,
    COMMAND_SYNC,
    CONTACT_HEEL_BIT,
    CONTACT_RESERVED_MASK,
    CONTACT_TOE_BIT,
    CRC16_INIT,
    CRC16_POLY,
    CRC16_TABLE,
    CRC_LEN,
    DATA_KINDS,
    DEFAULT_TABLE_CRC,
    DEFAULT_TABLE_ID,
    FRAME_LEN,
    FRAME_OVERHEAD,
    FRAME_SYNC,
    HEADER_LEN,
    MAX_DATA_FRAME_LEN,
    MAX_FRAME_LEN,
    NAME_LEN,
    PAPER_FRAME_LEN,
    PAYLOAD_LEN,
    SAMPLE_RATE_HZ_DEFAULT,
    SEQ_MODULO,
    AckStatus,
    Command,
    CommandDecoder,
    CommandDecoderStats,
    CommandRequest,
    FrameKind,
    GaitPhase,
    HasChannels,
    Identity,
    channel_table_crc,
    crc16,
    crc16_table_driven,
    encode_command,
    link_load,
)
from gaitmon.io.wire import CONTACT_RESERVED_MASK as _CONTACT_RESERVED_MASK

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


ANGLE_RANGE_DEG = 180.0
"""Every angle the unit sends (segment tilt, joint angle) is on the circle, |angle| <= 180 deg
(the docs say (-180, 180]; -180.00 is the same angle as 180.00 and atan2 can return it, so it
is accepted). The wire carries up to +-327.67 deg: anything beyond 180 is a damaged frame that
passed its CRC by chance."""


# each channel's largest count, from the channel table's ADC bits (the wire's 4095 today)
_CHANNEL_FULL_SCALE = np.array([min(c.full_scale_counts, ADC_MAX_COUNTS) for c in CHANNELS])


def _angles_ok(ang: np.ndarray) -> bool:
    return not bool(np.any(np.abs(ang) > ANGLE_RANGE_DEG))  # (NaN, "not available", is fine)


def decode_payload(kind: int, seq: int, payload: bytes) -> Frame | None:
    """Decode a CRC-checked payload of a known kind; None if a value is out of range (ADC
    counts above 4095, an angle beyond +-180 deg, a gait phase above 3, ...)."""
    if kind == FrameKind.RAW:
        adc = np.frombuffer(payload, dtype="<u2").astype(np.uint16, copy=False)
        if bool(np.any(adc > _CHANNEL_FULL_SCALE)):
            return None
        return RawFrame(seq, adc)
    if kind == FrameKind.TILT:
        ang = codes_to_angles(np.frombuffer(payload, dtype="<i2"))
        if not _angles_ok(ang):
            return None
        return TiltFrame(seq, ang[:N_SEGMENTS], ang[N_SEGMENTS:])
    if kind == FrameKind.JOINT:
        ang = codes_to_angles(np.frombuffer(payload, dtype="<i2", count=2 * N_JOINTS))
        contacts, phase = payload[-2], payload[-1]
        if contacts & _CONTACT_RESERVED_MASK or phase > 3 or not _angles_ok(ang):
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


__all__ = [
    "ADC_MAX_COUNTS",
    "ANGLE_CODES_PER_DEG",
    "ANGLE_LSB_DEG",
    "ANGLE_MAX_CODE",
    "ANGLE_MAX_DEG",
    "ANGLE_MIN_CODE",
    "ANGLE_NAN_CODE",
    "BAUD_DEFAULT",
    "COMMAND_LEN",
    "COMMAND_SYNC",
    "CONTACT_HEEL_BIT",
    "CONTACT_RESERVED_MASK",
    "CONTACT_TOE_BIT",
    "CRC16_INIT",
    "CRC16_POLY",
    "CRC16_TABLE",
    "CRC_LEN",
    "DATA_KINDS",
    "DEFAULT_TABLE_CRC",
    "DEFAULT_TABLE_ID",
    "FRAME_LEN",
    "FRAME_OVERHEAD",
    "FRAME_SYNC",
    "HEADER_LEN",
    "MAX_DATA_FRAME_LEN",
    "MAX_FRAME_LEN",
    "NAME_LEN",
    "PAPER_FRAME_LEN",
    "PAYLOAD_LEN",
    "SAMPLE_RATE_HZ_DEFAULT",
    "SEQ_MODULO",
    "AckFrame",
    "AckStatus",
    "Command",
    "CommandDecoder",
    "CommandDecoderStats",
    "CommandRequest",
    "DataFrame",
    "Frame",
    "FrameKind",
    "GaitPhase",
    "HasChannels",
    "Identity",
    "IdentityFrame",
    "JointFrame",
    "RawFrame",
    "TiltFrame",
    "angles_to_codes",
    "channel_table_crc",
    "codes_to_angles",
    "crc16",
    "crc16_table_driven",
    "decode_payload",
    "encode_command",
    "encode_frame",
    "encode_identity_payload",
    "encode_payload",
    "encode_raw_block",
    "link_load",
]
