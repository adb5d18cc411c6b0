"""PC-side frame decoder: bytes in (any chunking), frames out, health counters kept.

Pure (no I/O, no clock, no threads) and total: `FrameDecoder.feed` never raises, whatever bytes
it is given. The byte layout is defined in `gaitmon.io.protocol` and `docs/protocol.md`.

How it scans. Every offset where the sync pair 0xA5 0x5A begins is a candidate, and it is
examined once its bytes are all in. A candidate is accepted only if (1) the kind byte is a known
FrameKind, (2) the length byte equals that kind's fixed payload length, (3) the CRC-16 over
kind..payload matches, and (4) every value is in range. Whatever the outcome, scanning resumes
inside the candidate (at its next byte), never after it: so no real frame is ever swallowed.

Why "never after it", even for an accepted frame: a frame that lost bytes is completed by the
bytes of the next frame. When only its last CRC byte was lost and that byte was 0xA5 (1 in
256), the next frame's first byte (0xA5) completes it exactly, and it passes its CRC: its
content is the true content. Jumping to its end would eat the next frame's sync. Here both are
delivered; the two frames share that one byte. (Frames that overlap otherwise need a CRC-16
coincidence, 1 in 65536 per damaged frame, as any false accept does.)

Bounded buffer: between calls at most `BUFFER_BOUND` = MAX_FRAME_LEN - 1 = 38 bytes are kept
(a partial candidate that starts with the sync pair, or one trailing 0xA5). The decision on a
candidate depends only on its own bytes, so the output does not depend on the chunking, and no
frame waits for bytes after its own end: no latency is added.

Counters (see `DecoderStats`) follow exact accounting rules so a test can check them:

    bytes_received == bytes_in_frames + bytes_skipped + buffered

where bytes_in_frames is the number of bytes inside at least one CRC-valid frame (delivered or
rejected for out-of-range values; a byte shared by two frames counts once) and buffered the
held bytes not yet counted.
"""

from __future__ import annotations

from dataclasses import dataclass

from gaitmon.io.protocol import (
    CRC_LEN,
    FRAME_SYNC,
    HEADER_LEN,
    MAX_FRAME_LEN,
    PAYLOAD_LEN,
    SEQ_MODULO,
    Frame,
    crc16,
    decode_payload,
)

BUFFER_BOUND = MAX_FRAME_LEN - 1
"""Most bytes the decoder holds between feed() calls."""

_SYNC0 = FRAME_SYNC[0]
# kind byte -> payload length, 0 for unknown kinds (a 256-entry list is faster than a dict lookup)
_PAYLOAD_LEN_BY_BYTE: list[int] = [0] * 256
for _kind, _plen in PAYLOAD_LEN.items():
    _PAYLOAD_LEN_BY_BYTE[int(_kind)] = _plen
_HALF_SEQ = SEQ_MODULO // 2
# a forward jump is plausible when no longer than the frames the unit can have sent since the
# last frame arrived (at its frame rate, with this much slack for control frames and clock
# jitter) plus a few frames for frames that arrive bunched; a longer one waits for the next
# frame's confirmation
JUMP_RATE_SLACK = 1.25
JUMP_FRAMES_SLACK = 10


@dataclass(frozen=True)
class DecoderStats:
    """A snapshot of the decoder's counters. Every count starts at 0 and only grows.

    bytes_received   every byte passed to feed().
    frames_ok        frames delivered: header valid, CRC valid, all values in range.
    crc_failures     candidates with sync, a known kind and the matching length byte, fully
                     received, whose CRC did not match. A corrupted frame usually counts once,
                     but a false candidate inside garbage or inside a corrupted frame counts too.
    bytes_skipped    bytes discarded outside any CRC-valid frame while searching for sync
                     (garbage, corrupted frames, rejected headers). Each byte counts once.
    frames_lost      sequence numbers skipped between consecutive CRC-valid frames (delivered
                     or rejected for values; not implausible ones, below): for a forward gap
                     g = (seq - last - 1) mod 2**16 below 2**15, g frames are counted lost.
                     Losses before the first CRC-valid frame, and after the last one, cannot
                     be seen.
    invalid_values   CRC-valid frames rejected because a value is out of range (ADC > 4095,
                     an angle beyond +-180 deg, gait phase > 3, reserved contact bits set,
                     identity side not L/R, ...).
                     They are not delivered, but their sequence number is tracked.
    sequence_resets  CRC-valid frames whose sequence number went backwards or repeated (a
                     forward gap of 2**15 or more, e.g. a device reboot); no loss is counted.
                     With a clock, counted only when the next frame confirms the new sequence.
    implausible_frames  CRC-valid frames dropped because their sequence number jumped further
                     than the time since the last frame allows (a false CRC accept: a random
                     sequence number would invent thousands of lost frames) and the next frame
                     did not confirm the jump. Only with a clock (``feed(data, now_s)`` and
                     ``frame_rate_hz``); neither delivered nor tracked, no loss is counted.
    buffered         bytes held for the next feed() and not yet counted (a held byte inside
                     a frame already delivered, the first byte of a possible next sync, is
                     not counted again).
    """

    bytes_received: int = 0
    frames_ok: int = 0
    crc_failures: int = 0
    bytes_skipped: int = 0
    frames_lost: int = 0
    invalid_values: int = 0
    sequence_resets: int = 0
    buffered: int = 0
    implausible_frames: int = 0

    @property
    def bytes_in_frames(self) -> int:
        """Bytes inside at least one CRC-valid frame (from the accounting identity)."""
        return self.bytes_received - self.bytes_skipped - self.buffered


class FrameDecoder:
    """Streaming decoder for device -> PC frames. Not thread-safe: feed it from one thread.

    ``frame_rate_hz`` (the unit's frame rate) with ``feed(data, now_s)`` (the host's clock when
    the bytes came) turns on the sequence plausibility check: a CRC-valid frame whose sequence
    number jumps (forward) further than the time since the last frame allows, or backwards, is
    held until the next CRC-valid frame. If that one follows it, the jump was real (a link cut,
    a reboot, a sped-up simulator): both are delivered, a forward jump counted as lost frames as
    always. If not, the held frame was a false CRC accept: it is dropped and counted in
    ``implausible_frames``, and no loss is counted for it. Without a clock nothing is held."""

    def __init__(self, frame_rate_hz: float | None = None) -> None:
        self.frame_rate_hz = frame_rate_hz
        self._buf = bytearray()
        self._bytes_received = 0
        self._frames_ok = 0
        self._crc_failures = 0
        self._bytes_skipped = 0
        self._frames_lost = 0
        self._invalid_values = 0
        self._sequence_resets = 0
        self._last_seq: int | None = None
        self._covered = 0  # leading held bytes that are inside a frame already counted
        self._implausible = 0
        self._last_time_s: float | None = None  # host time of the last tracked frame
        # a frame whose sequence jump waits for the next frame: (frame or None, seq, time)
        self._held: tuple[Frame | None, int, float] | None = None

    @property
    def stats(self) -> DecoderStats:
        return DecoderStats(
            bytes_received=self._bytes_received,
            frames_ok=self._frames_ok,
            crc_failures=self._crc_failures,
            bytes_skipped=self._bytes_skipped,
            frames_lost=self._frames_lost,
            invalid_values=self._invalid_values,
            sequence_resets=self._sequence_resets,
            buffered=len(self._buf) - self._covered,
            implausible_frames=self._implausible,
        )

    @property
    def buffered(self) -> int:
        """Bytes held for the next feed() (<= BUFFER_BOUND), counted or not."""
        return len(self._buf)

    @property
    def last_seq(self) -> int | None:
        """Sequence number of the last CRC-valid frame, or None before the first."""
        return self._last_seq

    def discard_buffer(self) -> None:
        """Drop held bytes (counted as skipped), e.g. after the link was re-opened, so a partial
        frame from before a cut is not glued to bytes from after it."""
        self._bytes_skipped += len(self._buf) - self._covered
        self._buf.clear()
        self._covered = 0

    def feed(self, data: bytes | bytearray | memoryview, now_s: float | None = None) -> list[Frame]:
        """Consume bytes, return the frames completed by them, in order. Never raises.
        ``now_s``: the host's clock when they came (the sequence plausibility check)."""
        if not data:
            return []
        buf = self._buf
        buf += data
        self._bytes_received += len(data)
        out: list[Frame] = []
        pos, n = 0, len(buf)
        # buf[:cov] is inside a CRC-valid frame already counted: scanning goes on inside such a
        # frame (the next one may start in it), but its bytes are never counted as skipped
        cov = self._covered
        skipped = 0
        plen_by_byte = _PAYLOAD_LEN_BY_BYTE
        while True:
            i = buf.find(FRAME_SYNC, pos)
            if i < 0:
                # keep a trailing first sync byte: its partner may be in the next chunk
                keep = n - 1 if n > pos and buf[n - 1] == _SYNC0 else n
                if keep > cov:
                    skipped += keep - (pos if pos > cov else cov)
                pos = keep
                break
            if i > cov:
                skipped += i - (pos if pos > cov else cov)
            pos = i
            if n - pos < HEADER_LEN:
                break
            kind = buf[pos + 2]
            plen = plen_by_byte[kind]
            if plen == 0 or buf[pos + 3] != plen:
                if pos >= cov:
                    skipped += 1
                pos += 1
                continue
            flen = plen + HEADER_LEN + CRC_LEN
            if n - pos < flen:
                break
            end = pos + flen
            body = bytes(buf[pos + 2 : end - CRC_LEN])
            if crc16(body) != buf[end - 2] | (buf[end - 1] << 8):
                self._crc_failures += 1
                if pos >= cov:
                    skipped += 1
                pos += 1
                continue
            seq = body[2] | (body[3] << 8)
            try:
                frame = decode_payload(kind, seq, body[4:])
            except Exception:  # defensive: a decoding bug must not kill the acquisition thread
                frame = None
            if now_s is None or self.frame_rate_hz is None:
                self._accept(frame, seq, None, out)
            else:
                self._judge(frame, seq, now_s, out)
            if end > cov:
                cov = end
            pos += 2  # not `end`: the next frame may start inside this one (module docstring)
        del buf[:pos]
        self._covered = cov - pos if cov > pos else 0
        self._bytes_skipped += skipped
        return out

    def _accept(self, frame: Frame | None, seq: int, now_s: float | None,
                out: list[Frame]) -> None:  # fmt: skip
        """A CRC-valid frame taken as the unit's: its sequence tracked, delivered if valid."""
        self._track_seq(seq)
        self._last_time_s = now_s
        if frame is None:
            self._invalid_values += 1
        else:
            self._frames_ok += 1
            out.append(frame)

    def _plausible(self, seq: int, after: int, since_s: float, now_s: float) -> bool:
        """Whether ``seq`` can follow ``after`` (a forward gap the time allows)."""
        gap = (seq - after - 1) % SEQ_MODULO
        rate = self.frame_rate_hz or 0.0
        allowed = JUMP_FRAMES_SLACK + JUMP_RATE_SLACK * rate * max(now_s - since_s, 0.0)
        return gap < _HALF_SEQ and gap <= allowed

    def _judge(self, frame: Frame | None, seq: int, now_s: float, out: list[Frame]) -> None:
        held = self._held
        if held is not None:
            self._held = None
            h_frame, h_seq, h_time = held
            if self._plausible(seq, h_seq, h_time, now_s):  # it follows: the jump was real
                self._accept(h_frame, h_seq, h_time, out)
                self._accept(frame, seq, now_s, out)
                return
            self._implausible += 1  # a false accept: the unit's sequence goes on without it
        last, since = self._last_seq, self._last_time_s
        if last is None or since is None or self._plausible(seq, last, since, now_s):
            self._accept(frame, seq, now_s, out)
        else:
            self._held = (frame, seq, now_s)

    def _track_seq(self, seq: int) -> None:
        last = self._last_seq
        if last is not None:
            gap = (seq - last - 1) % SEQ_MODULO
            if gap < _HALF_SEQ:
                self._frames_lost += gap
            else:
                self._sequence_resets += 1
        self._last_seq = seq
