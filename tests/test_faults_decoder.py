"""The decoder against byte-level link faults with an exact ledger (gaitmon.io.sim.linkfaults):
no exception, no real frame swallowed, every counter equal to the ledger's, and the same output
whatever the chunking. The fast size of what ``benchmarks/fault_suite.py`` runs big."""

from __future__ import annotations

import binascii
from dataclasses import asdict

import numpy as np
import pytest

from gaitmon.io import protocol as p
from gaitmon.io.decoder import BUFFER_BOUND, FrameDecoder
from gaitmon.io.sim.linkfaults import (
    LinkFaultConfig,
    LinkFaultLedger,
    faulty_stream,
    last_byte_loss_stream,
)


def naive_crc_failures(stream: bytes) -> int:
    """Complete, header-valid candidates failing their CRC, at every offset (no find, no
    chunking): what docs/protocol.md says crc_failures counts."""
    n, count = len(stream), 0
    for pos in range(n - 3):
        if stream[pos] == 0xA5 and stream[pos + 1] == 0x5A:
            kind, length = stream[pos + 2], stream[pos + 3]
            end = pos + 8 + length
            if kind in p.PAYLOAD_LEN and length == p.PAYLOAD_LEN[kind] and end <= n:
                crc = int.from_bytes(stream[end - 2 : end], "little")
                count += binascii.crc_hqx(stream[pos + 2 : end - 2], 0xFFFF) != crc
    return count


def check_against_ledger(ledger: LinkFaultLedger, got: list[p.Frame], dec: FrameDecoder) -> None:
    stats = asdict(dec.stats)
    expected = ledger.expected_counters()
    assert {k: stats[k] for k in expected} == expected
    assert got == ledger.delivered()  # every intact frame, nothing else, in order
    assert stats["crc_failures"] == naive_crc_failures(ledger.stream)


@pytest.mark.parametrize("seed", range(5))
def test_counters_equal_the_ledger_under_byte_level_faults(seed):
    # lost tails 3x as often as the default, so the old decoder's swallowed frame shows up in
    # seed 4 (a lost last byte that was 0xA5) even at this fast size
    ledger = faulty_stream(3000, LinkFaultConfig(seed=seed, tail_pct=15.0), seq0=65536 - 1000)
    assert ledger.n_events > 800 and min(ledger.events.values()) > 0  # every fault injected
    dec = FrameDecoder()
    got = dec.feed(ledger.stream)
    check_against_ledger(ledger, got, dec)


def test_frames_that_lost_their_last_byte_swallow_none_of_the_next():
    """Every other frame loses its last byte. When that byte was 0xA5 the next frame's sync
    completes it; the old decoder then lost the next frame (about 1 in 256 of them)."""
    ledger = last_byte_loss_stream(4000, seed=3)
    dec = FrameDecoder()
    got = dec.feed(ledger.stream)
    completed = len(ledger.intact()) - 2000  # the shortened frames that are intact
    assert completed > 0  # the pattern really occurs in this stream
    check_against_ledger(ledger, got, dec)


@pytest.mark.parametrize("seed", [11, 12])
def test_random_chunks_of_1_byte_to_4_kib_give_identical_output(seed):
    ledger = faulty_stream(2500, LinkFaultConfig(seed=seed))
    stream = ledger.stream
    whole = FrameDecoder()
    ref = whole.feed(stream)
    rng = np.random.default_rng(seed)
    for _ in range(3):
        dec, got, at = FrameDecoder(), [], 0
        while at < len(stream):
            # chunk sizes log-uniform over 1 B .. 4 KiB, so single bytes are common too
            size = int(np.exp(rng.uniform(0.0, np.log(4096.0))))
            got += dec.feed(stream[at : at + size])
            at += size
            assert dec.buffered <= BUFFER_BOUND
        assert got == ref
        assert dec.stats == whole.stats
