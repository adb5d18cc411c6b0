"""`gaitmon ports`: list the serial ports a unit could be on (USB-serial, Bluetooth RFCOMM)."""

from __future__ import annotations

import argparse

from gaitmon.io.transport import list_ports


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = (
        "A Bluetooth unit appears once paired and bound to a serial port "
        "(Linux: `rfcomm bind`; Windows: an outgoing COM port)."
    )


def run(args: argparse.Namespace) -> int:
    ports = list_ports()
    if not ports:
        print("no serial ports found (is the unit switched on, paired and bound to a port?)")
        return 0
    for port in ports:
        print(port.friendly())
    return 0
