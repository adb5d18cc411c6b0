"""What goes wrong on a simulated unit's link, and the exact record of it.

``FaultConfig`` injects, on data frames: independent frame loss, bursts of consecutive losses,
and corruption (1..max_bit_flips bit flips at random positions); on every frame: scheduled
silences (nothing leaves the device) and link drops (the link is gone; ``pty.py`` removes the
port). Every transmitted frame consumes a sequence number, so a lost frame is a gap the decoder
can count. ``unit.ledger`` records each injected fault with its frame number (unwrapped), wire
sequence number, sample index and kind. Frames still in the device's output queue when the
link goes down (even partly read) are discarded and logged as ``link_down`` too, and queue
overflow (nobody reading 1 MiB) as ``overflow``; so for an in-process transport the ledger is
exact. Bytes already inside the OS pty buffer at a cut are beyond the unit's knowledge.

A scheduled stall (``stalls``) loses nothing: the unit holds every frame it produces (a
Bluetooth module whose radio is busy, a unit that stops sending for a while) and sends the
backlog at once when the stall ends, so the sequence numbers show no gap and only the wall
clock shows the pause.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from gaitmon.io.protocol import SEQ_MODULO


@dataclass(frozen=True)
class FaultConfig:
    """What goes wrong on the link. Percentages are per frame; times are device seconds."""

    seed: int = 0
    loss_pct: float = 0.0
    corrupt_pct: float = 0.0
    max_bit_flips: int = 3
    burst_pct: float = 0.0  # chance per data frame that a burst of losses starts
    burst_len_frames: int = 10
    silences: tuple[tuple[float, float], ...] = ()  # (start_s, duration_s): nothing is sent
    link_drops: tuple[tuple[float, float], ...] = ()  # (start_s, duration_s): the link is gone
    # (start_s, duration_s): frames are held, then the backlog is sent at once (none lost)
    stalls: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        for name in ("loss_pct", "corrupt_pct", "burst_pct"):
            v = getattr(self, name)
            if not 0.0 <= v <= 100.0:
                raise ValueError(f"{name} must be within 0..100 %, got {v}")
        if self.max_bit_flips < 1 or self.burst_len_frames < 1:
            raise ValueError("max_bit_flips and burst_len_frames must be >= 1")
        for name in ("silences", "link_drops", "stalls"):
            for start, dur in getattr(self, name):
                if start < 0 or dur <= 0:
                    raise ValueError(f"{name}: start must be >= 0 and duration > 0 s")


    def silent_at(self, t_s: float) -> bool:
        """Whether device time ``t_s`` lies in a scheduled silence."""
        return _within(self.silences, t_s)

    def link_down_at(self, t_s: float) -> bool:
        """Whether device time ``t_s`` lies in a scheduled link drop."""
        return _within(self.link_drops, t_s)

    def stalled_at(self, t_s: float) -> bool:
        """Whether device time ``t_s`` lies in a scheduled stall."""
        return _within(self.stalls, t_s)


def _within(spans: tuple[tuple[float, float], ...], t_s: float) -> bool:
    return any(s <= t_s < s + d for s, d in spans)


class LedgerEntry(NamedTuple):
    frame_no: int  # unwrapped count of frames the device produced (0 = first)
    seq: int  # what went on the wire: frame_no mod 2**16
    sample_idx: int  # data frames: the sample it carries; answers: -1
    kind: int  # protocol.FrameKind
    fault: str  # loss | burst | silent | link_down | overflow | corrupt
    bits: tuple[int, ...] = ()  # corrupt: flipped bit positions (byte * 8 + bit)


@dataclass
class FaultLedger:
    """The exact record of what the unit produced and what it broke."""

    frames_produced: int = 0  # every frame that consumed a sequence number
    data_frames_produced: int = 0
    bytes_queued: int = 0  # bytes that entered the output queue (intact or corrupted)
    dropped: list[LedgerEntry] = field(default_factory=list)
    corrupted: list[LedgerEntry] = field(default_factory=list)
    discarded_bytes: int = 0  # queued bytes thrown away when the link went down / overflowed

    def dropped_frame_nos(self, fault: str | None = None) -> list[int]:
        return [e.frame_no for e in self.dropped if fault is None or e.fault == fault]

    @property
    def corrupted_frame_nos(self) -> list[int]:
        return [e.frame_no for e in self.corrupted]

    def take_bytes(self, frames: deque[list[int]], n: int, fault: str) -> None:
        """``n`` bytes left the head of a unit's output queue, whose frames are ``frames``
        ([frame_no, sample_idx, kind, bytes still queued, logged], oldest first): read (fault
        "") or thrown away (each frame that lost a byte is logged once as ``fault``)."""
        if fault:
            self.discarded_bytes += n
        while n > 0 and frames:
            entry = frames[0]
            if fault and not entry[4]:
                # one byte lost is enough: the decoder cannot get that frame any more
                no = entry[0]
                self.dropped.append(LedgerEntry(no, no % SEQ_MODULO, entry[1], entry[2], fault))
                entry[4] = True
            take = min(n, entry[3])
            entry[3] -= take
            n -= take
            if entry[3] == 0:
                frames.popleft()

    def summary(self) -> dict[str, int]:
        by_fault: dict[str, int] = {}
        for e in self.dropped:
            by_fault[e.fault] = by_fault.get(e.fault, 0) + 1
        return {
            "frames_produced": self.frames_produced,
            "data_frames_produced": self.data_frames_produced,
            "dropped": len(self.dropped),
            "corrupted": len(self.corrupted),
            "discarded_bytes": self.discarded_bytes,
            **{f"dropped_{k}": v for k, v in sorted(by_fault.items())},
        }


def flip_bits(
    wire: bytes, rng: np.random.Generator, max_bit_flips: int
) -> tuple[bytes, tuple[int, ...]]:
    """``wire`` with 1..max_bit_flips distinct bits flipped at random, and their positions
    (byte * 8 + bit, ascending)."""
    n_bits = int(rng.integers(1, max_bit_flips + 1))
    bits = rng.choice(len(wire) * 8, size=n_bits, replace=False)
    b = bytearray(wire)
    for bit in bits:
        b[bit // 8] ^= 1 << (bit % 8)
    return bytes(b), tuple(sorted(int(x) for x in bits))
