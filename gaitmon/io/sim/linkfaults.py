"""Byte-level link faults on an encoded frame stream, with an exact ledger.

``SimulatedUnit``'s ``FaultConfig`` breaks whole frames (loss, bursts, bit flips). A real UART
or Bluetooth link also loses single bytes (an overrun), truncates a frame, inserts noise and
garbles runs across frame boundaries. This module applies those faults to a sequence of random
frames and keeps a ledger of where every frame landed in the received stream and which faults
were injected, so a test (or ``benchmarks/fault_suite.py``) can predict every counter of
``gaitmon.io.decoder.FrameDecoder`` from the ground truth alone:

* a frame is *intact* iff its original bytes sit unchanged at its offset in the stream (a frame
  that lost its last byte is intact when the next frame's first byte equals the lost one: its
  content really did arrive, sharing one byte with the next frame);
* intact frames with in-range values are delivered, intact frames with an out-of-range value
  are counted as invalid values, and every other frame is lost;
* the bytes of no intact frame are skipped.

Pure Python and numpy; the expectations do not use the decoder.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from gaitmon.dsp.channel_table import N_CHANNELS, N_JOINTS, N_SEGMENTS
from gaitmon.io import protocol as P

_IDENT = P.Identity(name="gaitmon-faults", firmware="1.0.0", serial=77, side="R")


def random_frame(rng: np.random.Generator, seq: int, *, invalid: bool = False) -> P.Frame:
    """A random frame of a random kind (mostly data kinds), on the wire grid so that encoding
    and decoding are exact; with ``invalid`` a value is out of range (encode with
    ``validate=False``): an ADC sample above 4095 or a gait phase above 3."""
    seq %= P.SEQ_MODULO
    u = rng.random()
    if invalid:
        if u < 0.5:
            adc = rng.integers(0, 4096, N_CHANNELS)
            adc[int(rng.integers(N_CHANNELS))] = int(rng.integers(4096, 65536))
            return P.RawFrame(seq, adc)
        zero = np.zeros(N_JOINTS)
        return P.JointFrame(seq, zero, zero, False, False, int(rng.integers(4, 256)))
    if u < 0.32:
        return P.RawFrame(seq, rng.integers(0, 4096, N_CHANNELS))
    if u < 0.64:
        return P.TiltFrame(
            seq,
            rng.integers(-18000, 18000, N_SEGMENTS) / 100,
            rng.integers(-9000, 9000, N_SEGMENTS) / 100,
        )
    if u < 0.96:
        return P.JointFrame(
            seq,
            rng.integers(-9000, 9000, N_JOINTS) / 100,
            rng.integers(-9000, 9000, N_JOINTS) / 100,
            bool(rng.integers(2)),
            bool(rng.integers(2)),
            int(rng.integers(4)),
        )
    if u < 0.98:
        return P.AckFrame(seq, P.Command.START_STREAM, P.AckStatus.OK, 0)
    return P.IdentityFrame(seq, _IDENT)


@dataclass(frozen=True)
class LinkFaultConfig:
    """Per-frame chances (%) of each fault (at most one per frame, plus garbage after it), and
    overwrite bursts per 10,000 frames. The defaults give ~0.3 events per frame."""

    seed: int = 0
    drop_pct: float = 5.0  # the whole frame never arrives
    flip_pct: float = 7.0  # 1..3 bit flips anywhere in the frame
    tail_pct: float = 5.0  # the frame loses its last k bytes (k = 1 half of the time)
    delete_pct: float = 4.0  # 1..3 bytes lost inside the frame (a UART overrun)
    insert_pct: float = 3.0  # 1..5 noise bytes inside the frame (after the sync)
    garbage_pct: float = 4.0  # 1..50 noise bytes after the frame
    invalid_pct: float = 0.5  # a value out of range, CRC valid
    bursts_per_10k: float = 10.0  # 4..64 bytes overwritten in place, across frame boundaries
    protect: int = 3  # the first and last frames are never faulted (losses need neighbours)


@dataclass
class LinkFaultLedger:
    """What was sent, what was broken and where each frame landed in ``stream``."""

    stream: bytes
    frames: list[P.Frame]  # every frame sent, in order
    wires: list[bytes]  # each frame's original bytes
    offsets: list[int]  # where each frame starts in the stream; -1 = dropped
    valid: list[bool]  # values in range
    events: dict[str, int] = field(default_factory=dict)  # fault -> how many were injected

    @property
    def n_events(self) -> int:
        return sum(self.events.values())

    def intact(self) -> list[int]:
        """Indices of the frames whose original bytes sit unchanged at their offset."""
        s = self.stream
        return [
            i
            for i, (at, w) in enumerate(zip(self.offsets, self.wires, strict=True))
            if at >= 0 and s[at : at + len(w)] == w
        ]

    def delivered(self) -> list[P.Frame]:
        """The frames a decoder that never swallows a real frame must deliver, in order."""
        return [self.frames[i] for i in self.intact() if self.valid[i]]

    def expected_counters(self) -> dict[str, int]:
        """Every ``DecoderStats`` counter but ``crc_failures`` (false candidates inside garbage
        are not the ledger's business), from the ground truth alone."""
        ok = self.intact()
        lost = resets = 0
        for a, b in itertools.pairwise(ok):
            gap = (self.frames[b].seq - self.frames[a].seq - 1) % P.SEQ_MODULO
            if gap < P.SEQ_MODULO // 2:
                lost += gap
            else:
                resets += 1
        covered = np.zeros(len(self.stream), dtype=bool)
        for i in ok:
            covered[self.offsets[i] : self.offsets[i] + len(self.wires[i])] = True
        return {
            "bytes_received": len(self.stream),
            "frames_ok": sum(self.valid[i] for i in ok),
            "invalid_values": sum(not self.valid[i] for i in ok),
            "frames_lost": lost,
            "sequence_resets": resets,
            "bytes_skipped": int(len(self.stream) - covered.sum()),
            "buffered": 0,
        }


def _noise(rng: np.random.Generator, n: int) -> bytes:
    return rng.integers(0, 256, n, dtype=np.uint8).tobytes()


def faulty_stream(n_frames: int, config: LinkFaultConfig, seq0: int = 0) -> LinkFaultLedger:
    """``n_frames`` random frames (sequence numbers from ``seq0``, wrapping) sent over a link
    with the faults of ``config``; the received stream and its ledger."""
    rng = np.random.default_rng(config.seed)
    c = config
    edges = np.cumsum([c.drop_pct, c.flip_pct, c.tail_pct, c.delete_pct, c.insert_pct]) / 100.0
    names = ("drop", "flip", "tail", "delete", "insert")
    events: dict[str, int] = {}
    stream = bytearray()
    frames: list[P.Frame] = []
    wires: list[bytes] = []
    offsets: list[int] = []
    valid: list[bool] = []
    for k in range(n_frames):
        protect = k < c.protect or k >= n_frames - c.protect
        bad_value = not protect and rng.random() * 100.0 < c.invalid_pct
        frame = random_frame(rng, seq0 + k, invalid=bad_value)
        original = P.encode_frame(frame, validate=False)
        frames.append(frame)
        wires.append(original)
        valid.append(not bad_value)
        if bad_value:
            events["invalid"] = events.get("invalid", 0) + 1
        u = 1.0 if protect else rng.random()
        j = int(np.searchsorted(edges, u, side="right"))
        fault = names[j] if j < len(names) else ""
        wire = bytearray(original)
        if fault == "flip":
            bits = rng.choice(len(wire) * 8, size=int(rng.integers(1, 4)), replace=False)
            for bit in bits:
                wire[bit // 8] ^= 1 << (bit % 8)
        elif fault == "tail":
            n_lost = 1 if rng.random() < 0.5 else int(rng.integers(2, len(wire)))
            del wire[len(wire) - n_lost :]
        elif fault == "delete":
            at = int(rng.integers(2, len(wire) - 3))
            del wire[at : at + int(rng.integers(1, 4))]
        elif fault == "insert":
            at = int(rng.integers(2, len(wire)))
            wire[at:at] = _noise(rng, int(rng.integers(1, 6)))
        if fault:
            events[fault] = events.get(fault, 0) + 1
        if fault == "drop":
            offsets.append(-1)
        else:
            offsets.append(len(stream))
            stream += wire
        if not protect and rng.random() * 100.0 < c.garbage_pct:
            stream += _noise(rng, int(rng.integers(1, 51)))
            events["garbage"] = events.get("garbage", 0) + 1
    # overwrite bursts, kept clear of the protected head and tail
    n_bursts = round(c.bursts_per_10k * n_frames / 10_000)
    if n_bursts and n_frames > 2 * c.protect:
        lo = offsets[c.protect]  # protected frames are never dropped: their offsets are real
        hi = max(lo + 1, offsets[n_frames - c.protect] - 64)
        for _ in range(n_bursts):
            at = int(rng.integers(lo, hi))
            length = int(rng.integers(4, 65))
            stream[at : at + length] = _noise(rng, length)
            events["burst"] = events.get("burst", 0) + 1
    return LinkFaultLedger(bytes(stream), frames, wires, offsets, valid, events)


def last_byte_loss_stream(n_frames: int, seed: int = 0) -> LinkFaultLedger:
    """The pattern that used to make the decoder swallow frames: every other frame loses its
    last byte, so the next frame's first byte (0xA5) completes it; when the lost CRC byte was
    0xA5 (1 in 256) the shortened frame still passes its CRC."""
    config = LinkFaultConfig(
        seed=seed, drop_pct=0, flip_pct=0, tail_pct=0, delete_pct=0, insert_pct=0,
        garbage_pct=0, invalid_pct=0, bursts_per_10k=0, protect=0,
    )  # fmt: skip
    clean = faulty_stream(n_frames, config)
    stream = bytearray()
    offsets = []
    for k, w in enumerate(clean.wires):
        offsets.append(len(stream))
        stream += w[:-1] if k % 2 == 0 and k < n_frames - 1 else w
    return LinkFaultLedger(
        bytes(stream), clean.frames, clean.wires, offsets, clean.valid,
        {"tail": len(range(0, n_frames - 1, 2))},
    )  # fmt: skip
