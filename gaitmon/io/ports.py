"""What a port name means: listing the ports a unit could be on, and the transport for a name.

This module owns naming ports for people. The unit is a Bluetooth serial (SPP) device, and each
system shows a paired one differently:

* **Linux**: ``/dev/rfcommN`` once bound (``rfcomm bind``), or no port at all: gaitmon connects
  to a paired unit by address with ``bt://AA:BB:CC:DD:EE:FF`` (``gaitmon.io.bluetooth``).
* **macOS**: two nodes per paired device, ``/dev/tty.NAME`` (waits for carrier on open) and
  ``/dev/cu.NAME`` (the one to use for an outgoing connection); plus
  ``Bluetooth-Incoming-Port`` (for devices that connect to the Mac) and ``debug-console``, which
  are never the unit.
* **Windows**: two COM ports per paired SPP device, an outgoing one (the PC connects to the
  unit: its hardware id ends in the unit's 12-digit address) and an incoming one (address
  ``000000000000``: the unit would have to call the PC).

:func:`classify_ports` is the pure rule over pyserial ``ListPortInfo``-like records (``device``,
``description``, ``hwid``) for a given ``sys.platform`` value, so every system's rule is tested
on any system. :func:`make_transport` turns a port name into its transport: ``bt://…`` an RFCOMM
socket, anything else a serial port.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gaitmon.io.transport import SerialTransport

# BTHENUM\{service}_LOCALMFG&xxxx\7&1a2b3c4d&0&001122334455_C00000000 (outgoing),
# ...&0&000000000000_00000000 (incoming): the 12 hex digits before "_" are the remote address
_WIN_BT_ADDRESS = re.compile(r"&([0-9A-F]{12})_[0-9A-F]+$", re.IGNORECASE)
_MAC_HIDDEN = ("Bluetooth-Incoming-Port", "debug-console")


@dataclass(frozen=True)
class PortInfo:
    device: str
    description: str
    hwid: str
    bluetooth: bool = False  # a Bluetooth serial port (the unit's kind of link)

    def friendly(self) -> str:
        desc = self.description if self.description and self.description != "n/a" else ""
        if not desc and "rfcomm" in self.device:
            desc = "Bluetooth serial (RFCOMM)"
        # a Bluetooth port's hardware id is a long enumerator path that helps nobody
        hw = self.hwid if self.hwid and self.hwid != "n/a" and not self.bluetooth else ""
        return " - ".join(x for x in (self.device, desc, hw) if x)


def _colon_address(hex12: str) -> str:
    h = hex12.upper()
    return ":".join(h[i : i + 2] for i in range(0, 12, 2))


def _classify(device: str, description: str, hwid: str, platform: str) -> PortInfo | None:
    """One record as the user should see it, or None to hide it."""
    if platform == "darwin":
        name = device.rsplit("/", 1)[-1]
        if name.startswith("tty."):
            return None  # the cu. twin is the one to open for an outgoing connection
        if any(hidden in name for hidden in _MAC_HIDDEN):
            return None
        usb = hwid.upper().startswith("USB")
        if name.startswith("cu.") and not usb:
            return PortInfo(device, f"Bluetooth serial ({name[3:]})", hwid, bluetooth=True)
        return PortInfo(device, description, hwid)
    if platform == "win32":
        if not hwid.upper().startswith("BTHENUM"):
            return PortInfo(device, description, hwid)
        m = _WIN_BT_ADDRESS.search(hwid)
        if m is None or int(m.group(1), 16) == 0:
            return None  # incoming port: the unit never calls the PC
        return PortInfo(
            device, f"Bluetooth serial to {_colon_address(m.group(1))}", hwid, bluetooth=True
        )
    # Linux and the other POSIX systems
    if "rfcomm" in device:
        return PortInfo(device, "Bluetooth serial (RFCOMM)", hwid, bluetooth=True)
    return PortInfo(device, description, hwid)


def classify_ports(records: Iterable[Any], platform: str) -> list[PortInfo]:
    """pyserial ``ListPortInfo``-like records -> the ports to offer, Bluetooth ones first.

    ``platform`` is a ``sys.platform`` value (``linux``, ``darwin``, ``win32``).
    """
    out: list[PortInfo] = []
    for r in records:
        info = _classify(
            str(r.device), str(r.description or ""), str(r.hwid or ""), platform
        )  # fmt: skip
        if info is not None:
            out.append(info)
    return sorted(out, key=lambda p: (not p.bluetooth, _natural(p.device)))


def _natural(name: str) -> list[Any]:
    """COM10 after COM9, rfcomm10 after rfcomm2."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", name)]


def list_ports(platform: str | None = None) -> list[PortInfo]:
    """The serial ports on this machine a unit could be on, named as this system shows them."""
    from serial.tools import list_ports as lp

    return classify_ports(lp.comports(), sys.platform if platform is None else platform)


def make_transport(port: str, baudrate: int | None = None) -> SerialTransport:
    """The transport for a port name: ``bt://ADDR[/CHANNEL]`` an RFCOMM socket, else serial.

    Both reconnect by themselves and report problems in the same one-line form; a bad name is
    reported when ``open()`` is called (PortOpenError), like a missing port.
    """
    if port.lower().startswith("bt://"):
        from gaitmon.io.bluetooth import BluetoothTransport

        return BluetoothTransport(port)
    from gaitmon.io.transport import SerialTransport

    if baudrate is None:
        return SerialTransport(port)
    return SerialTransport(port, baudrate=baudrate)
