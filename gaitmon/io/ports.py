"""What a port name means: listing the ports a unit could be on, and the transport for a name.

This module owns naming ports for people. The unit is a Bluetooth serial (SPP) device, and each
system shows a paired one differently:

* **Linux**: ``/dev/rfcommN`` once bound (``rfcomm bind``), or no port at all: gaitmon connects
  to a paired unit by address with ``bt://AA:BB:CC:DD:EE:FF`` (``gaitmon.io.bluetooth``), and
  lists the paired devices that offer a serial port that way (:func:`paired_serial_units`).
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
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterable
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


_BLUEZ_DEVICE = re.compile(r"^Device ([0-9A-F]{2}(?::[0-9A-F]{2}){5}) (.*)$", re.IGNORECASE)
SPP_UUID = "00001101-0000-1000-8000-00805f9b34fb"  # the Serial Port Profile


def parse_bluez_devices(text: str) -> list[tuple[str, str]]:
    """``bluetoothctl devices`` output -> [(address, name)]."""
    out = []
    for line in text.splitlines():
        m = _BLUEZ_DEVICE.match(line.strip())
        if m:
            out.append((m.group(1).upper(), m.group(2).strip()))
    return out


def paired_serial_units(
    run: Callable[[list[str]], str] | None = None,
) -> list[PortInfo]:
    """Linux: paired Bluetooth devices offering a serial port, as ``bt://ADDRESS`` entries, so
    the unit can be picked without ``rfcomm bind``. Asks BlueZ's ``bluetoothctl``; none when it
    is missing, slow or fails. ``run(argv) -> stdout`` is injectable for tests."""
    if run is None:
        if shutil.which("bluetoothctl") is None:
            return []
        run = _bluetoothctl
    try:
        paired = parse_bluez_devices(run(["bluetoothctl", "devices", "Paired"]))
        units = []
        for address, name in paired:
            if SPP_UUID in run(["bluetoothctl", "info", address]).lower():
                units.append(PortInfo(f"bt://{address}", f"{name} (paired)", "", bluetooth=True))
        return units
    except (OSError, subprocess.SubprocessError):
        return []


def _bluetoothctl(argv: list[str]) -> str:
    done = subprocess.run(argv, capture_output=True, text=True, timeout=2.0, check=False)
    return done.stdout


def list_ports(platform: str | None = None) -> list[PortInfo]:
    """The serial ports on this machine a unit could be on, named as this system shows them;
    on Linux also the paired Bluetooth serial devices to connect to by address."""
    from serial.tools import list_ports as lp

    platform = sys.platform if platform is None else platform
    ports = classify_ports(lp.comports(), platform)
    if platform.startswith("linux"):
        ports = paired_serial_units() + ports
    return ports


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
