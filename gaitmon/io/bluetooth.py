"""A paired unit reached by its Bluetooth address: ``bt://AA:BB:CC:DD:EE:FF[/CHANNEL]``.

This module owns the RFCOMM socket link (Linux; the standard library's ``socket.AF_BLUETOOTH``,
``BTPROTO_RFCOMM``). It needs no ``rfcomm bind`` and so no root: pair the unit once, then connect
by address. The unit's serial port service is on RFCOMM channel 1 unless ``/CHANNEL`` says
otherwise.

:class:`BluetoothTransport` is a :class:`~gaitmon.io.transport.SerialTransport` whose "port" is a
socket: the same watchdog, reconnection (a socket has no device node to watch, so a failed
connect is retried at most ``present_max_s`` apart unless the link flaps) and one-line reasons,
so the Device, the engine and the window cannot tell the two apart. The socket is made by an
injectable ``connect(address, channel, timeout_s)`` so tests can stand a local socket pair in
for the radio.
"""

from __future__ import annotations

import errno
import re
import select
import socket
from collections.abc import Callable
from typing import Any

from gaitmon.io.transport import ReconnectPolicy, SerialTransport

BT_SCHEME = "bt://"
RFCOMM_CHANNEL_DEFAULT = 1
_ADDRESS = re.compile(r"^[0-9A-F]{2}(:[0-9A-F]{2}){5}$", re.IGNORECASE)
_USAGE = "use bt://AA:BB:CC:DD:EE:FF or bt://AA:BB:CC:DD:EE:FF/CHANNEL (channel 1-30)"

SocketConnect = Callable[[str, int, float], Any]  # (address, channel, timeout_s) -> socket


class BluetoothUnavailable(OSError):
    """This Python or this computer has no Bluetooth sockets."""


def parse_bt_url(url: str) -> tuple[str, int]:
    """``bt://AA:BB:CC:DD:EE:FF[/CHANNEL]`` -> (address, channel); ValueError saying what is
    wrong and what to type."""
    rest = url[len(BT_SCHEME) :] if url.lower().startswith(BT_SCHEME) else url
    address, _, channel_text = rest.partition("/")
    address = address.strip()
    if not _ADDRESS.match(address):
        raise ValueError(f"{address!r} is not a Bluetooth address: {_USAGE}")
    channel = RFCOMM_CHANNEL_DEFAULT
    if channel_text:
        if not channel_text.isdigit() or not 1 <= int(channel_text) <= 30:
            raise ValueError(f"{channel_text!r} is not an RFCOMM channel: {_USAGE}")
        channel = int(channel_text)
    return address.upper(), channel


def rfcomm_connect(address: str, channel: int, timeout_s: float) -> socket.socket:
    """An RFCOMM socket connected to ``address`` on ``channel`` (the standard library's)."""
    family = getattr(socket, "AF_BLUETOOTH", None)
    proto = getattr(socket, "BTPROTO_RFCOMM", None)
    if family is None or proto is None:
        raise BluetoothUnavailable(errno.EAFNOSUPPORT, "no Bluetooth sockets in this Python")
    sock = socket.socket(family, socket.SOCK_STREAM, proto)
    try:
        sock.settimeout(timeout_s)
        sock.connect((address, channel))
    except BaseException:
        sock.close()
        raise
    return sock


def describe_bt_error(url: str, channel: int, exc: BaseException) -> str:
    """A one-line, actionable message for a failed Bluetooth connect."""
    code = getattr(exc, "errno", None)
    head = f"cannot connect to {url}"
    if isinstance(exc, BluetoothUnavailable) or code in (
        errno.EAFNOSUPPORT, errno.EPROTONOSUPPORT, errno.ESOCKTNOSUPPORT
    ):  # fmt: skip
        return (
            f"{head}: Bluetooth is not available here (connecting by address needs Linux "
            "with BlueZ); pair the unit and pick its serial port instead (`gaitmon ports`)"
        )
    if code in (errno.ENETDOWN, errno.ENETUNREACH, errno.EHOSTUNREACH, errno.ENODEV):
        return f"{head}: the Bluetooth adapter is off or missing (switch Bluetooth on)"
    if code in (errno.EHOSTDOWN, errno.ETIMEDOUT) or isinstance(exc, TimeoutError):
        return f"{head}: the unit does not answer (is it switched on, within range and paired?)"
    if code == errno.ECONNREFUSED:
        return (
            f"{head}: the unit refused the connection on channel {channel} (is it paired with "
            "this computer, and is that its serial channel?)"
        )
    if code in (errno.EBUSY, errno.EALREADY, errno.EISCONN):
        return f"{head}: the unit is busy (another program or computer is connected to it)"
    if code in (errno.EACCES, errno.EPERM):
        return f"{head}: permission denied (is Bluetooth allowed for your user?)"
    if isinstance(exc, ValueError):
        return f"{head}: {exc}"
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return f"{head}: {text}"


class SocketPort:
    """A connected stream socket with the part of pyserial's ``Serial`` the transport uses.

    ``read`` waits at most ``timeout_s`` for data and returns what has arrived (possibly more
    than asked: the transport feeds a decoder, not a fixed-size record); a socket closed by the
    unit raises, as a vanished serial port does.
    """

    in_waiting = 0  # read() returns everything that is there anyway

    def __init__(self, sock: Any, timeout_s: float, write_timeout_s: float = 1.0) -> None:
        self._sock = sock
        self._timeout_s = timeout_s
        sock.settimeout(write_timeout_s)  # bounds sendall(); reads wait in select()

    def read(self, n: int) -> bytes:
        ready, _, _ = select.select([self._sock], [], [], self._timeout_s)
        if not ready:
            return b""
        data: bytes = self._sock.recv(max(n, 4096))
        if not data:
            raise ConnectionResetError("the unit closed the connection")
        return data

    def write(self, data: bytes) -> None:
        self._sock.sendall(data)

    def cancel_read(self) -> None:
        """Reads wait at most the poll interval: nothing to cancel."""

    def close(self) -> None:
        self._sock.close()


class BluetoothTransport(SerialTransport):
    """A unit by address over RFCOMM, with SerialTransport's reconnection and messages."""

    def __init__(
        self,
        url: str,
        *,
        silence_timeout_s: float = 2.0,
        reconnect: ReconnectPolicy | None = None,
        poll_s: float = 0.05,
        connect_timeout_s: float = 10.0,
        socket_connect: SocketConnect | None = None,
    ) -> None:
        super().__init__(
            url,
            silence_timeout_s=silence_timeout_s,
            reconnect=reconnect,
            poll_s=poll_s,
            serial_factory=self._no_serial,
        )
        self.connect_timeout_s = connect_timeout_s
        self._socket_connect = socket_connect or rfcomm_connect
        try:
            self.address, self.channel = parse_bt_url(url)
            self._bad_url: str | None = None
        except ValueError as exc:
            self.address, self.channel = "", RFCOMM_CHANNEL_DEFAULT
            self._bad_url = str(exc)

    @staticmethod
    def _no_serial(**kw: Any) -> Any:
        raise AssertionError("a Bluetooth transport opens sockets, not serial ports")

    def _open_port(self) -> Any:
        if self._bad_url is not None:
            raise ValueError(self._bad_url)
        sock = self._socket_connect(self.address, self.channel, self.connect_timeout_s)
        return SocketPort(sock, self._poll_s)

    def _present(self) -> bool | None:
        return None  # no device node: whether the unit is there shows only by connecting

    def _describe_open_error(self, exc: BaseException) -> str:
        return describe_bt_error(self.port, self.channel, exc)

    def _connected_text(self) -> str:
        return f"connected to {self.port} (RFCOMM channel {self.channel})"
