"""Byte transports between the PC and a unit: one interface, a serial one and an in-process one.

This module owns moving bytes and keeping a link alive; it knows nothing about frames.

The `Transport` interface (duck-typed, `typing.Protocol`)::

    open()              connect; raises PortOpenError (one-line message) if the first open fails
    close()             idempotent; wakes a blocked read()
    read(timeout_s)     -> bytes received so far (b"" on timeout, while reconnecting or closed);
                        never raises for a lost link: the transport handles it and shows it in
                        `status`
    write(data)         send bytes; raises LinkError if the link is down right now
    status              -> TransportStatus snapshot (state, one-line reason, reconnect timing)
    arm_watchdog(bool)  while armed, `silence_timeout_s` without a byte means the link is lost
                        (arm it while the unit is streaming; a polled or idle unit is silent)

`SerialTransport` (pyserial) detects a lost link by an exception (port vanished: SerialException,
OSError EIO, path gone) or by silence while armed, then closes the port and reopens it, sleeping
between attempts so a vanished port never makes it spin. The unit keeps sending while the link
is down, so every second spent waiting after it returns is data lost: while the port's device
node is missing the transport looks for it every `presence_poll_s` (an `os.path.exists`, cheap)
and tries at once when it reappears; while the node exists, failed attempts are retried at most
`present_max_s` apart. Only a flapping link (it drops again within `stable_s` of opening) gets
the plain exponential backoff (initial, x factor, capped at `max_s`), whatever the node does.
`status.connections` counts link-ups, so a caller can notice a reconnect and re-send its setup.

`InProcessTransport` wraps a simulated unit object in the same process. The unit must provide::

    write(data: bytes) -> None      bytes from the PC to the unit (commands)
    read() -> bytes                 bytes the unit has produced since the last call; non-blocking
                                    (gaitmon.io.sim.unit.SimulatedUnit follows this)

and may provide ``wait_readable(timeout_s: float) -> bool`` (block until read() would return
bytes; otherwise the transport polls every `poll_interval_s`) and ``close()``.
"""

from __future__ import annotations

import contextlib
import enum
import errno
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from gaitmon.io.protocol import BAUD_DEFAULT


class LinkError(Exception):
    """The link is down or cannot be opened; the message is one line a user can act on."""


class PortOpenError(LinkError):
    """The port could not be opened at all (missing, busy, no permission)."""


class LinkState(enum.Enum):
    CONNECTED = "connected"
    RECONNECTING = "reconnecting"
    FAILED = "failed"
    CLOSED = "closed"


@dataclass(frozen=True)
class TransportStatus:
    """A snapshot of a transport's link state."""

    state: LinkState
    reason: str  # one line: why we are in this state
    port: str = ""
    next_attempt_s: float | None = None  # time.monotonic() of the next reopen attempt
    attempt: int = 0  # reopen attempts that failed in the current outage
    connections: int = 0  # times the link came up (first open + reconnects)
    link_losses: int = 0  # times a lost link was detected

    @property
    def reconnects(self) -> int:
        return max(self.connections - 1, 0)

    def seconds_to_next_attempt(self, now_s: float | None = None) -> float | None:
        if self.next_attempt_s is None:
            return None
        now_s = time.monotonic() if now_s is None else now_s
        return max(self.next_attempt_s - now_s, 0.0)

    def describe(self, now_s: float | None = None) -> str:
        """One line for a status bar, e.g. 'reconnecting to /dev/rfcomm0 in 1.6 s (...)'."""
        if self.state == LinkState.RECONNECTING:
            wait = self.seconds_to_next_attempt(now_s)
            when = f" in {wait:.1f} s" if wait is not None else ""
            return f"reconnecting to {self.port}{when} (attempt {self.attempt + 1}): {self.reason}"
        return f"{self.state.value}: {self.reason}"


@runtime_checkable
class Transport(Protocol):
    def open(self) -> None: ...
    def close(self) -> None: ...
    def read(self, timeout_s: float) -> bytes: ...
    def write(self, data: bytes) -> None: ...
    def arm_watchdog(self, armed: bool) -> None: ...
    @property
    def status(self) -> TransportStatus: ...


# --------------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------------


def describe_open_error(port: str, exc: BaseException) -> str:
    """A one-line, actionable message for a failed open."""
    code = getattr(exc, "errno", None)
    text = str(exc).lower()
    if code == errno.ENOENT or "no such file" in text or not os.path.exists(port):
        return (
            f"cannot open {port}: no such port (is the unit switched on and paired? "
            "`gaitmon ports` lists the ports)"
        )
    if code in (errno.EBUSY, errno.EAGAIN, errno.EWOULDBLOCK) or "lock" in text or "busy" in text:
        return f"cannot open {port}: port busy (another program is using it; close it and retry)"
    if code == errno.EACCES or "permission" in text:
        return (
            f"cannot open {port}: permission denied (on Linux add your user to the "
            "'dialout' group and log in again)"
        )
    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return f"cannot open {port}: {first}"


def port_present(port: str) -> bool | None:
    """Whether a port's device node exists right now; None when that cannot be told cheaply (a
    Windows COM name). A dangling symlink (a pty or RFCOMM node that went away) is missing."""
    if port.startswith("/"):
        return os.path.exists(port)
    return None


def _one_line(exc: BaseException) -> str:
    s = str(exc).strip()
    return s.splitlines()[0] if s else type(exc).__name__


# --------------------------------------------------------------------------------------------
# Serial
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ReconnectPolicy:
    """Exponential backoff for reopening a lost port."""

    initial_s: float = 0.25  # wait before the first reopen attempt
    factor: float = 2.0
    max_s: float = 5.0  # cap on the wait between attempts
    max_attempts: int | None = None  # None: keep trying until closed
    # a connection that drops within this time counts as a failed attempt, so a flapping link
    # (opens, then fails at once, or stays silent for the watchdog's 2 s) backs off instead of
    # retrying every initial_s forever
    stable_s: float = 3.0
    # while the port's node exists (and the link is not flapping) retry at least this often: the
    # unit is back or about to be, and it streams into the void until we reopen
    present_max_s: float = 0.5
    # how often a missing port's node is looked for (an os.path.exists): the unit streams into
    # the void until we reopen, so this bounds the loss beyond an outage (0.05 s gave up to 5
    # frames and 0.058 s in one 8-s cut; 0.02 s: at most 2 frames of it)
    presence_poll_s: float = 0.02

    def delay_s(self, failed_attempts: int) -> float:
        return min(self.initial_s * self.factor**failed_attempts, self.max_s)


class SerialTransport:
    """A serial port (USB-serial, Bluetooth RFCOMM, pty) that reconnects by itself."""

    def __init__(
        self,
        port: str,
        baudrate: int = BAUD_DEFAULT,
        *,
        silence_timeout_s: float = 2.0,
        reconnect: ReconnectPolicy | None = None,
        poll_s: float = 0.05,
        serial_factory: Callable[..., Any] | None = None,
    ) -> None:
        self.port = port
        self.baudrate = baudrate
        self.silence_timeout_s = silence_timeout_s
        self.policy = reconnect or ReconnectPolicy()
        self._poll_s = poll_s  # longest a read blocks inside pyserial; bounds close() latency
        if serial_factory is None:
            import serial

            serial_factory = serial.Serial
        self._factory = serial_factory
        self._lock = threading.RLock()
        self._wake = threading.Event()
        self._ser: Any = None
        self._gen = 0  # bumped on every port (re)open, so a stale error cannot kill a new port
        self._state = LinkState.CLOSED
        self._reason = "not opened"
        self._next_attempt_s: float | None = None
        self._attempt = 0
        self._flaps = 0  # consecutive connections that dropped within policy.stable_s
        self._absent = False  # the port's node was missing when the next attempt was scheduled
        self._hold_until_s = 0.0  # no attempt before this, even if the node reappears
        self._connected_s = 0.0
        self._opening = False  # a reopen is in progress outside the lock
        self._connections = 0
        self._losses = 0
        self._armed = False
        self._last_rx_s = 0.0
        self._loss_reason = ""

    # -- lifecycle ------------------------------------------------------------------------

    def _open_port(self) -> Any:
        return self._factory(
            port=self.port, baudrate=self.baudrate, timeout=self._poll_s, write_timeout=1.0,
            exclusive=True,
        )  # fmt: skip

    def open(self) -> None:
        with self._lock:
            if self._state == LinkState.CONNECTED:
                return
            self._wake.clear()
            try:
                ser = self._open_port()
            except Exception as exc:
                msg = self._describe_open_error(exc)
                self._state, self._reason = LinkState.FAILED, msg
                raise PortOpenError(msg) from None
            self._connected(ser, self._connected_text())

    def _describe_open_error(self, exc: BaseException) -> str:
        return describe_open_error(self.port, exc)

    def _connected_text(self) -> str:
        return f"connected to {self.port} at {self.baudrate} baud"

    def _connected(self, ser: Any, reason: str) -> None:
        self._ser = ser
        self._gen += 1
        self._state, self._reason = LinkState.CONNECTED, reason
        self._next_attempt_s = None
        self._attempt = 0
        self._connections += 1
        self._last_rx_s = self._connected_s = time.monotonic()

    def close(self) -> None:
        with self._lock:
            self._state, self._reason = LinkState.CLOSED, "closed"
            self._next_attempt_s = None
            self._close_port()
            self._wake.set()

    def _close_port(self) -> None:
        ser, self._ser = self._ser, None
        if ser is not None:
            # the port may already be gone: closing is best effort
            with contextlib.suppress(Exception):
                ser.cancel_read()
            with contextlib.suppress(Exception):
                ser.close()

    def arm_watchdog(self, armed: bool) -> None:
        with self._lock:
            if armed and not self._armed:
                self._last_rx_s = time.monotonic()  # silence counts from now
            self._armed = armed

    @property
    def status(self) -> TransportStatus:
        with self._lock:
            return TransportStatus(
                state=self._state,
                reason=self._reason,
                port=self.port,
                next_attempt_s=self._next_attempt_s,
                attempt=self._attempt,
                connections=self._connections,
                link_losses=self._losses,
            )

    # -- loss and reconnection ------------------------------------------------------------

    def _lost(self, gen: int, reason: str) -> None:
        with self._lock:
            if gen != self._gen or self._state != LinkState.CONNECTED:
                return  # already handled, or the port was reopened meanwhile
            self._close_port()
            now = time.monotonic()
            self._flaps = self._flaps + 1 if now - self._connected_s < self.policy.stable_s else 0
            self._losses += 1
            self._loss_reason = f"link lost: {reason}"
            self._state, self._reason = LinkState.RECONNECTING, self._loss_reason
            self._attempt = 0
            # a flapping link waits out its backoff even if the node comes back sooner
            self._hold_until_s = now + (self.policy.delay_s(self._flaps) if self._flaps else 0.0)
            self._schedule(now, self._flaps)

    def _present(self) -> bool | None:
        """Whether the port could be there (None: cannot tell cheaply); see `port_present`."""
        return port_present(self.port)

    def _schedule(self, now: float, failures: int) -> None:
        """Set the next reopen attempt after `failures` failed attempts (lock held)."""
        delay = self.policy.delay_s(failures)
        present = self._present()
        # read() looks for a missing node and tries as soon as it appears (after a flapping
        # link's hold): a node coming back is the one sign worth reacting to at once
        self._absent = present is False
        if present is not False and self._flaps == 0:
            delay = min(delay, self.policy.present_max_s)
        self._next_attempt_s = now + delay

    def _try_reopen(self) -> None:
        # Opening can block for seconds (an RFCOMM connect): do it outside the lock, so status
        # (read by the window ~30 times a second) and close() never wait for it.
        with self._lock:
            if self._state != LinkState.RECONNECTING or self._opening:
                return
            self._opening = True
        try:
            ser = self._open_port()
            error: Exception | None = None
        except Exception as exc:
            ser, error = None, exc
        with self._lock:
            self._opening = False
            if self._state != LinkState.RECONNECTING:  # closed meanwhile: drop the new port
                if ser is not None:
                    with contextlib.suppress(Exception):
                        ser.close()
                return
            if ser is not None:
                self._connected(ser, f"reconnected to {self.port}")
                return
            assert error is not None
            self._attempt += 1
            why = self._describe_open_error(error)
            limit = self.policy.max_attempts
            if limit is not None and self._attempt >= limit:
                self._state = LinkState.FAILED
                self._reason = f"gave up after {self._attempt} attempts: {why}"
                self._next_attempt_s = None
                return
            self._reason = f"{self._loss_reason}; {why}"
            self._schedule(time.monotonic(), self._attempt + self._flaps)

    # -- I/O --------------------------------------------------------------------------------

    def read(self, timeout_s: float) -> bytes:
        deadline = time.monotonic() + max(timeout_s, 0.0)
        while True:
            with self._lock:
                state, ser, gen = self._state, self._ser, self._gen
                next_attempt, absent = self._next_attempt_s, self._absent
            now = time.monotonic()
            if state == LinkState.CLOSED:
                return b""
            if state == LinkState.FAILED:
                # nothing will change by itself; sleep instead of letting a caller spin
                self._wake.wait(max(deadline - now, 0.0))
                return b""
            if state == LinkState.RECONNECTING:
                assert next_attempt is not None
                if now >= next_attempt:
                    self._try_reopen()
                    continue
                if absent and now >= self._hold_until_s and self._present():
                    with self._lock:  # the node is back: try now instead of at the backoff time
                        if self._state == LinkState.RECONNECTING and self._gen == gen:
                            self._absent = False
                            self._next_attempt_s = now
                    continue
                if now >= deadline:
                    return b""
                wake_at = min(next_attempt, deadline)
                if absent:
                    wake_at = min(wake_at, now + self.policy.presence_poll_s)
                self._wake.wait(wake_at - now)
                continue
            try:
                waiting = ser.in_waiting
                data = ser.read(waiting if waiting > 0 else 1)
            except Exception as exc:  # SerialException, OSError (EIO), closed fd, ...
                self._lost(gen, _one_line(exc))
                continue
            now = time.monotonic()
            if data:
                with self._lock:
                    self._last_rx_s = now
                return data
            with self._lock:
                silent_s = now - self._last_rx_s
                armed = self._armed
            if armed and silent_s > self.silence_timeout_s:
                self._lost(gen, f"no data for {self.silence_timeout_s:g} s")
                continue
            if now >= deadline:
                return b""

    def write(self, data: bytes) -> None:
        with self._lock:
            if self._state != LinkState.CONNECTED:
                raise LinkError(f"cannot send to {self.port}: {self._state.value} ({self._reason})")
            ser, gen = self._ser, self._gen
        try:
            ser.write(data)
        except Exception as exc:
            self._lost(gen, _one_line(exc))
            raise LinkError(f"cannot send to {self.port}: {_one_line(exc)}") from None


# --------------------------------------------------------------------------------------------
# In-process (simulated unit)
# --------------------------------------------------------------------------------------------


class InProcessTransport:
    """Talks to a simulated unit object in this process (see the module docstring)."""

    def __init__(self, unit: Any, *, name: str = "simulator", poll_interval_s: float = 0.005):
        self.unit = unit
        self.name = name
        self.poll_interval_s = poll_interval_s
        self._state = LinkState.CLOSED
        self._connections = 0
        self._wake = threading.Event()

    def open(self) -> None:
        if self._state != LinkState.CONNECTED:
            self._state = LinkState.CONNECTED
            self._connections += 1
            self._wake.clear()

    def close(self) -> None:
        self._state = LinkState.CLOSED
        self._wake.set()
        closer = getattr(self.unit, "close", None)
        if callable(closer):
            closer()

    def arm_watchdog(self, armed: bool) -> None:
        """In-process links cannot be lost; nothing to watch."""

    @property
    def status(self) -> TransportStatus:
        reason = f"connected to {self.name}" if self._state == LinkState.CONNECTED else "closed"
        return TransportStatus(self._state, reason, self.name, connections=self._connections)

    def read(self, timeout_s: float) -> bytes:
        if self._state != LinkState.CONNECTED:
            return b""
        deadline = time.monotonic() + max(timeout_s, 0.0)
        waiter = getattr(self.unit, "wait_readable", None)
        while True:
            data = self.unit.read()
            if data:
                return bytes(data)
            now = time.monotonic()
            if now >= deadline or self._state != LinkState.CONNECTED:
                return b""
            if callable(waiter):
                waiter(deadline - now)
            else:
                self._wake.wait(min(self.poll_interval_s, deadline - now))

    def write(self, data: bytes) -> None:
        if self._state != LinkState.CONNECTED:
            raise LinkError(f"cannot send to {self.name}: closed")
        self.unit.write(bytes(data))
