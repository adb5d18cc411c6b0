"""Transports: port listing, clear open errors, and SerialTransport over a real pseudo-terminal
(real pyserial) including loss by exception, loss by silence, backoff without spinning, and
reconnection."""

from __future__ import annotations

import argparse
import os
import select
import threading
import time
import tty
from pathlib import Path

import numpy as np
import pytest
import serial

from gaitmon.commands import ports as ports_cmd
from gaitmon.io import protocol as p
from gaitmon.io.decoder import FrameDecoder
from gaitmon.io.ports import PortInfo
from gaitmon.io.transport import (
    InProcessTransport,
    LinkError,
    LinkState,
    PortOpenError,
    ReconnectPolicy,
    SerialTransport,
    Transport,
)

pytestmark = pytest.mark.timeout(60)


class PtyUnit:
    """A stand-in unit on the master side of a real pty, reachable through a stable symlink."""

    def __init__(self, link: Path) -> None:
        self.link = link
        self.master: int | None = None
        self.slave: int | None = None
        self.restore()

    def restore(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        if self.link.is_symlink():
            self.link.unlink()
        self.link.symlink_to(os.ttyname(self.slave))

    def cut(self) -> None:
        """The unit vanishes: pty closed, path gone (like an RFCOMM device disappearing)."""
        self.link.unlink()
        for fd in (self.master, self.slave):
            if fd is not None:
                os.close(fd)
        self.master = self.slave = None

    def write(self, data: bytes) -> None:
        assert self.master is not None
        view = memoryview(data)
        while view:
            n = os.write(self.master, view)
            view = view[n:]

    def read_available(self, timeout_s: float = 0.5) -> bytes:
        assert self.master is not None
        ready, _, _ = select.select([self.master], [], [], timeout_s)
        return os.read(self.master, 4096) if ready else b""


@pytest.fixture
def unit(tmp_path):
    u = PtyUnit(tmp_path / "gaitmon-unit")
    yield u
    if u.master is not None:
        u.cut()


def raw_frames(n: int, seq0: int = 0) -> list[p.RawFrame]:
    rng = np.random.default_rng(seq0)
    return [p.RawFrame((seq0 + i) % 65536, rng.integers(0, 4096, 14)) for i in range(n)]


def read_until(t: SerialTransport, dec: FrameDecoder, n_frames: int, timeout_s: float = 10.0):
    got: list[p.Frame] = []
    deadline = time.monotonic() + timeout_s
    while len(got) < n_frames and time.monotonic() < deadline:
        got += dec.feed(t.read(0.1))
    return got


# --- listing and errors ------------------------------------------------------------------------


def test_port_info_friendly_line():
    assert PortInfo("/dev/ttyUSB0", "CP2102 USB to UART", "USB VID:PID=10C4:EA60").friendly() == (
        "/dev/ttyUSB0 - CP2102 USB to UART - USB VID:PID=10C4:EA60"
    )
    assert PortInfo("/dev/rfcomm0", "n/a", "n/a").friendly() == (
        "/dev/rfcomm0 - Bluetooth serial (RFCOMM)"
    )


def test_ports_command_lists_ports_or_says_none(monkeypatch, capsys):
    monkeypatch.setattr(ports_cmd, "list_ports", lambda: [])
    assert ports_cmd.run(argparse.Namespace()) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1 and "no serial ports found" in out
    monkeypatch.setattr(
        ports_cmd, "list_ports", lambda: [PortInfo("/dev/ttyUSB0", "FT232R", "USB VID:PID=0403")]
    )
    ports_cmd.run(argparse.Namespace())
    assert capsys.readouterr().out == "/dev/ttyUSB0 - FT232R - USB VID:PID=0403\n"


def test_missing_port_gives_one_line_error(tmp_path):
    t = SerialTransport(str(tmp_path / "nope"))
    with pytest.raises(PortOpenError) as err:
        t.open()
    msg = str(err.value)
    assert "\n" not in msg and "no such port" in msg and str(tmp_path / "nope") in msg
    assert t.status.state == LinkState.FAILED and t.status.reason == msg


def test_busy_port_gives_one_line_error(unit):
    holder = serial.Serial(str(unit.link), exclusive=True)
    try:
        t = SerialTransport(str(unit.link))
        with pytest.raises(PortOpenError, match="port busy") as err:
            t.open()
        assert "\n" not in str(err.value)
    finally:
        holder.close()


def test_backoff_schedule_is_exponential_and_capped():
    pol = ReconnectPolicy(initial_s=0.25, factor=2.0, max_s=5.0)
    assert [pol.delay_s(k) for k in range(7)] == [0.25, 0.5, 1.0, 2.0, 4.0, 5.0, 5.0]


def test_transports_satisfy_the_protocol(unit):
    assert isinstance(SerialTransport(str(unit.link)), Transport)
    assert isinstance(InProcessTransport(object()), Transport)


# --- over a real pty ---------------------------------------------------------------------------


def test_frames_arrive_intact_and_commands_reach_the_unit(unit):
    frames = raw_frames(3000, seq0=65000)  # crosses the 16-bit wrap
    t = SerialTransport(str(unit.link))
    t.open()
    try:
        assert t.status.state == LinkState.CONNECTED and t.status.connections == 1
        writer = threading.Thread(
            target=lambda: unit.write(b"".join(p.encode_frame(f) for f in frames))
        )
        writer.start()
        dec = FrameDecoder()
        got = read_until(t, dec, len(frames))
        writer.join()
        assert got == frames
        s = dec.stats
        assert (s.frames_lost, s.crc_failures, s.bytes_skipped) == (0, 0, 0)
        assert s.bytes_received == 36 * len(frames)

        t.write(p.encode_command(p.Command.SELECT_KIND, p.FrameKind.TILT))
        t.write(p.encode_command(p.Command.START_STREAM))
        cmd_dec = p.CommandDecoder()
        cmds: list = []
        deadline = time.monotonic() + 30
        while len(cmds) < 2 and time.monotonic() < deadline:
            cmds += cmd_dec.feed(unit.read_available())
        assert cmds == [(p.Command.SELECT_KIND, p.FrameKind.TILT), (p.Command.START_STREAM, 0)]
    finally:
        t.close()
    assert t.status.state == LinkState.CLOSED
    assert t.read(0.01) == b""
    with pytest.raises(LinkError):
        t.write(b"x")


def test_vanished_port_backs_off_without_spinning_then_reconnects(unit):
    opens = []

    def counting_factory(**kw):
        opens.append(time.monotonic())
        return serial.Serial(**kw)

    policy = ReconnectPolicy(initial_s=0.05, factor=2.0, max_s=0.4)
    t = SerialTransport(str(unit.link), reconnect=policy, serial_factory=counting_factory)
    t.open()
    try:
        unit.write(p.encode_frame(raw_frames(1)[0]))
        dec = FrameDecoder()
        assert len(read_until(t, dec, 1)) == 1

        unit.cut()
        t_cut = time.monotonic()
        while t.status.state == LinkState.CONNECTED and time.monotonic() - t_cut < 5:
            t.read(0.05)
        st = t.status
        assert st.state == LinkState.RECONNECTING and st.link_losses == 1
        assert "link lost" in st.reason and "\n" not in st.reason
        assert st.next_attempt_s is not None

        # keep reading for a while with the port gone; count reopen attempts
        t0 = time.monotonic()
        reads = 0
        while time.monotonic() - t0 < 1.5:
            assert t.read(0.05) == b""
            reads += 1
        elapsed = time.monotonic() - t_cut
        attempts = len(opens) - 1
        # the most attempts the backoff schedule allows in `elapsed` (a spin would do thousands)
        allowed, total, k = 0, 0.0, 0
        while total + policy.delay_s(k) <= elapsed:
            total += policy.delay_s(k)
            allowed += 1
            k += 1
        assert 1 <= attempts <= allowed
        assert reads >= 3  # read() returned on its timeout instead of blocking forever
        st = t.status
        assert st.state == LinkState.RECONNECTING and st.attempt == attempts
        assert "no such port" in st.reason
        assert st.describe().startswith("reconnecting to")

        unit.restore()
        more = raw_frames(50, seq0=1)
        deadline = time.monotonic() + 30
        while t.status.state != LinkState.CONNECTED and time.monotonic() < deadline:
            t.read(0.05)
        assert t.status.state == LinkState.CONNECTED
        assert t.status.connections == 2 and t.status.reconnects == 1
        unit.write(b"".join(p.encode_frame(f) for f in more))
        dec.discard_buffer()
        assert read_until(t, dec, 50) == more
    finally:
        t.close()


def test_silence_while_armed_is_a_lost_link_and_recovers(unit):
    t = SerialTransport(
        str(unit.link), silence_timeout_s=0.3, reconnect=ReconnectPolicy(initial_s=0.05)
    )
    t.open()
    try:
        t.read(0.5)  # silent, but not armed: nothing happens
        assert t.status.state == LinkState.CONNECTED and t.status.link_losses == 0
        t.arm_watchdog(True)
        deadline = time.monotonic() + 30
        while t.status.link_losses == 0 and time.monotonic() < deadline:
            t.read(0.05)
        assert t.status.link_losses == 1
        assert "no data for 0.3 s" in t.status.reason
        # the pty is still there, so the reopen succeeds
        while t.status.connections < 2 and time.monotonic() < deadline:
            t.read(0.05)
        assert t.status.state == LinkState.CONNECTED and t.status.connections == 2
    finally:
        t.close()


# --- failure paths with a fake port ------------------------------------------------------------


class FlakyPort:
    """A pyserial stand-in whose read fails with EIO, as a vanished RFCOMM/pty device does."""

    def __init__(self, **kw):
        self.in_waiting = 0

    def read(self, n):
        raise serial.SerialException("read failed: [Errno 5] Input/output error")

    def write(self, data):
        raise OSError(5, "Input/output error")

    def cancel_read(self):
        pass

    def close(self):
        pass


def test_gives_up_after_max_attempts_with_reason():
    calls = []

    def factory(**kw):
        calls.append(kw["port"])
        if len(calls) == 1:
            return FlakyPort()
        raise serial.SerialException(2, "could not open port: No such file or directory")

    t = SerialTransport(
        "/dev/rfcomm-gone",
        reconnect=ReconnectPolicy(initial_s=0.01, max_s=0.02, max_attempts=3),
        serial_factory=factory,
    )
    t.open()
    deadline = time.monotonic() + 30
    while t.status.state != LinkState.FAILED and time.monotonic() < deadline:
        t.read(0.05)
    st = t.status
    assert st.state == LinkState.FAILED
    assert st.reason.startswith("gave up after 3 attempts") and "\n" not in st.reason
    assert len(calls) == 1 + 3
    with pytest.raises(LinkError):
        t.write(b"\x00")
    t.close()


def test_write_failure_marks_link_lost():
    t = SerialTransport("/dev/fake", serial_factory=lambda **kw: FlakyPort())
    t.open()
    with pytest.raises(LinkError, match="Input/output error"):
        t.write(b"abc")
    assert t.status.state == LinkState.RECONNECTING
    t.close()


# --- in-process ----------------------------------------------------------------------------


def test_in_process_transport_moves_bytes_both_ways():
    class Echo:
        def __init__(self):
            self.pending = b""

        def write(self, data):
            self.pending += data

        def read(self):
            out, self.pending = self.pending, b""
            return out

    t = InProcessTransport(Echo())
    t.open()
    t.write(b"hello")
    assert t.read(0.1) == b"hello"
    assert t.read(0.02) == b""
    t.close()
    assert t.status.state == LinkState.CLOSED


def test_status_and_close_do_not_wait_for_a_slow_reopen():
    """An RFCOMM connect can block for seconds; the window reads status ~30 times a second.
    The slow connect here blocks until the test lets it go: status and close return while it
    still blocks (however slow the machine, a wait for the port would never end)."""
    opened = []
    connecting = threading.Event()
    release = threading.Event()

    def factory(**kw):
        opened.append(time.monotonic())
        if len(opened) == 1:
            return FlakyPort()
        connecting.set()
        release.wait(120)  # the slow connect
        raise serial.SerialException(2, "could not open port: Host is down")

    t = SerialTransport(
        "/dev/rfcomm0", reconnect=ReconnectPolicy(initial_s=0.01), serial_factory=factory
    )
    t.open()
    reader = threading.Thread(target=lambda: [t.read(0.05) for _ in range(40)], daemon=True)
    reader.start()
    try:
        assert connecting.wait(60)  # the reopen has begun
        got = []
        status = threading.Thread(target=lambda: got.append(t.status), daemon=True)
        status.start()
        status.join(60)
        assert got, "status waited for the port to open"
        assert got[0].state == LinkState.RECONNECTING
        closer = threading.Thread(target=t.close, daemon=True)
        closer.start()
        closer.join(60)
        assert not closer.is_alive(), "close waited for the port to open"
    finally:
        release.set()
    reader.join(60)
    assert not reader.is_alive()
    assert t.status.state == LinkState.CLOSED


def test_a_flapping_link_backs_off_instead_of_retrying_at_the_initial_rate():
    opened = []

    def factory(**kw):
        opened.append(time.monotonic())
        return FlakyPort()  # opens fine, fails on the first read

    policy = ReconnectPolicy(initial_s=0.02, factor=2.0, max_s=1.0, stable_s=5.0)
    t = SerialTransport("/dev/flappy", reconnect=policy, serial_factory=factory)
    t.open()
    deadline = time.monotonic() + 30
    while len(opened) < 6 and time.monotonic() < deadline:
        t.read(0.05)
    t.close()
    gaps = np.diff(opened)
    assert len(gaps) >= 4
    # each quick drop counts as a failure: the waits grow (0.02, 0.04, 0.08, 0.16, ...)
    assert gaps[3] > 3 * gaps[0]
    assert np.all(gaps[1:] >= gaps[:-1] * 0.9)


def test_a_present_port_is_retried_often_and_a_missing_one_backs_off(tmp_path):
    """While the port's node exists a failed reopen is retried <= present_max_s later (the
    unit is back or about to be); while it is missing the backoff grows (no spin)."""
    node = tmp_path / "rfcomm0"
    node.touch()
    calls: list[float] = []

    def factory(**kw):
        calls.append(time.monotonic())
        if len(calls) == 1:
            return FlakyPort()
        raise serial.SerialException(16, "could not open port: Device or resource busy")

    policy = ReconnectPolicy(initial_s=0.01, factor=2.0, max_s=5.0, present_max_s=0.05,
                             stable_s=0.0)  # fmt: skip
    t = SerialTransport(str(node), reconnect=policy, serial_factory=factory)
    t.open()
    scheduled: list[float] = []
    deadline = time.monotonic() + 30
    while len(calls) < 10 and time.monotonic() < deadline:
        t.read(0.01)
        st = t.status
        if st.next_attempt_s is not None and st.attempt > len(scheduled):
            scheduled.append(st.next_attempt_s - time.monotonic())
    assert len(calls) == 10 and t.status.state == LinkState.RECONNECTING
    assert "port busy" in t.status.reason
    assert max(scheduled) <= 0.05  # backoff alone would be 0.01 * 2**8 = 2.56 s by now
    node.unlink()  # the node goes: the next waits follow the backoff again
    n = len(calls)
    while len(calls) < n + 1 and time.monotonic() < deadline + 5:
        t.read(0.01)
    st = t.status
    assert st.next_attempt_s is not None
    assert st.next_attempt_s - time.monotonic() > 1.0
    t.close()
