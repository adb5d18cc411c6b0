"""`gaitmon ports`: list the serial ports a unit could be on (USB-serial, Bluetooth RFCOMM)."""

from __future__ import annotations

import argparse

from gaitmon.io.ports import list_ports


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = (
        "Bluetooth ports are listed first, named as each system shows a paired unit: Linux "
        "/dev/rfcommN (or connect by address without a port: --port bt://AA:BB:CC:DD:EE:FF), "
        "macOS /dev/cu.NAME, Windows the outgoing COM port. The README has the pairing steps."
    )


def run(args: argparse.Namespace) -> int:
    ports = list_ports()
    if not ports:
        print(
            "no serial ports found (is the unit switched on and paired? On Linux connect by "
            "address: --port bt://AA:BB:CC:DD:EE:FF)"
        )
        return 0
    for port in ports:
        print(port.friendly())
    return 0
