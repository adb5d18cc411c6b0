"""Naming the unit's port on each system (pyserial's own records for Linux, macOS and Windows),
and connecting by Bluetooth address (bt://) with a local socket pair standing in for the radio:
the real simulated unit on one end, the real Device on the other."""

from __future__ import annotations

import contextlib
import errno
import math
import select
import socket
import threading
import time

import numpy as np
import pytest
from serial.tools.list_ports_common import ListPortInfo

from gaitmon.cli import main
from gaitmon.io import protocol as p
from gaitmon.io.bluetooth import BluetoothTransport, parse_bt_url
from gaitmon.io.device import Device
from gaitmon.io.ports import PortInfo, classify_ports, make_transport
from gaitmon.io.sim.unit import SimulatedUnit
from gaitmon.io.transport import LinkState, PortOpenError, ReconnectPolicy, SerialTransport

pytestmark = pytest.mark.timeout(60)

ADDR = "00:11:22:AA:BB:CC"


def rec(device: str, description: str = "n/a", hwid: str = "n/a") -> ListPortInfo:
    r = ListPortInfo(device, skip_link_detection=True)
    r.description, r.hwid = description, hwid
    return r


# --- port names per system ---------------------------------------------------------------------


def test_linux_lists_rfcomm_first_as_bluetooth():
    ports = classify_ports(
        [rec("/dev/ttyUSB0", "CP2102", "USB VID:PID=10C4:EA60"), rec("/dev/rfcomm10"),
         rec("/dev/rfcomm2")],
        "linux",
    )  # fmt: skip
    assert [x.device for x in ports] == ["/dev/rfcomm2", "/dev/rfcomm10", "/dev/ttyUSB0"]
    assert ports[0].bluetooth and not ports[2].bluetooth
    assert ports[0].friendly() == "/dev/rfcomm2 - Bluetooth serial (RFCOMM)"
    assert ports[2].friendly() == "/dev/ttyUSB0 - CP2102 - USB VID:PID=10C4:EA60"


def test_macos_offers_cu_nodes_and_hides_incoming_and_tty_twins():
    records = [
        rec("/dev/cu.Bluetooth-Incoming-Port"), rec("/dev/tty.Bluetooth-Incoming-Port"),
        rec("/dev/cu.GaitUnit-SPP"), rec("/dev/tty.GaitUnit-SPP"),
        rec("/dev/cu.debug-console"), rec("/dev/tty.debug-console"),
        rec("/dev/cu.usbserial-A10K", "FT232R USB UART", "USB VID:PID=0403:6001 SER=A10K"),
        rec("/dev/tty.usbserial-A10K", "FT232R USB UART", "USB VID:PID=0403:6001 SER=A10K"),
    ]  # fmt: skip
    ports = classify_ports(records, "darwin")
    assert [x.device for x in ports] == ["/dev/cu.GaitUnit-SPP", "/dev/cu.usbserial-A10K"]
    assert ports[0].bluetooth and ports[0].friendly() == (
        "/dev/cu.GaitUnit-SPP - Bluetooth serial (GaitUnit-SPP)"
    )
    assert not ports[1].bluetooth


def test_windows_offers_the_outgoing_com_port_of_a_paired_unit():
    spp = "BTHENUM\\{00001101-0000-1000-8000-00805F9B34FB}_LOCALMFG&0002\\7&2B1C3A4&0&"
    records = [
        rec("COM4", "Standard Serial over Bluetooth link (COM4)", spp + "000000000000_00000000"),
        rec("COM5", "Standard Serial over Bluetooth link (COM5)", spp + "001122AABBCC_C00000000"),
        rec("COM10", "USB Serial Device (COM10)", "USB VID:PID=2341:0043 SER=7543"),
        rec("COM3", "Communications Port (COM3)", "ACPI\\PNP0501\\1"),
    ]  # fmt: skip
    ports = classify_ports(records, "win32")
    assert [x.device for x in ports] == ["COM5", "COM3", "COM10"]  # incoming COM4 hidden
    assert ports[0].bluetooth
    assert ports[0].friendly() == f"COM5 - Bluetooth serial to {ADDR}"  # no enumerator path
    assert ports[2].friendly() == (
        "COM10 - USB Serial Device (COM10) - USB VID:PID=2341:0043 SER=7543"
    )


def test_port_info_without_bluetooth_flag_reads_as_before():
    assert PortInfo("/dev/rfcomm0", "n/a", "n/a").friendly() == (
        "/dev/rfcomm0 - Bluetooth serial (RFCOMM)"
    )


def test_make_transport_by_name():
    assert type(make_transport("/dev/rfcomm0")) is SerialTransport
    assert make_transport("/dev/ttyUSB0", 57600).baudrate == 57600
    bt = make_transport(f"bt://{ADDR.lower()}/3")
    assert isinstance(bt, BluetoothTransport) and (bt.address, bt.channel) == (ADDR, 3)


# --- bt:// addresses and errors ----------------------------------------------------------------


def test_parse_bt_url():
    assert parse_bt_url(f"bt://{ADDR}") == (ADDR, 1)
    assert parse_bt_url(f"BT://{ADDR.lower()}/5") == (ADDR, 5)
    for bad, what in (("bt://00:11:22", "not a Bluetooth address"),
                      ("bt://00:11:22:AA:BB:GG", "not a Bluetooth address"),
                      (f"bt://{ADDR}/0", "not an RFCOMM channel"),
                      (f"bt://{ADDR}/x", "not an RFCOMM channel")):  # fmt: skip
        with pytest.raises(ValueError, match=what):
            parse_bt_url(bad)


def _open_error(transport: BluetoothTransport) -> str:
    with pytest.raises(PortOpenError) as err:
        transport.open()
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"cannot connect to {transport.port}")
    assert transport.status.state == LinkState.FAILED
    return msg


def test_bluetooth_unavailable_is_one_clear_line(monkeypatch):
    monkeypatch.delattr(socket, "AF_BLUETOOTH", raising=False)  # Python without BlueZ
    msg = _open_error(BluetoothTransport(f"bt://{ADDR}"))
    assert "Bluetooth is not available here" in msg and "gaitmon ports" in msg


@pytest.mark.parametrize(
    ("code", "words"),
    [
        (errno.ENETDOWN, "adapter is off"),
        (errno.EHOSTUNREACH, "adapter is off"),
        (errno.EHOSTDOWN, "does not answer"),
        (errno.ECONNREFUSED, "refused the connection on channel 1"),
        (errno.EAFNOSUPPORT, "Bluetooth is not available"),
    ],
)
def test_bluetooth_connect_errors_are_one_clear_line(code, words):
    def refuse(address, channel, timeout_s):
        raise OSError(code, f"[Errno {code}] {errno.errorcode[code]} (raw (nested) text)")

    msg = _open_error(BluetoothTransport(f"bt://{ADDR}", socket_connect=refuse))
    assert words in msg and "Errno" not in msg


def test_invalid_address_is_one_clear_line_from_the_command_line(tmp_path, capsys):
    rc = main(["record", "--port", "bt://12:34", "--duration", "1", "-o", str(tmp_path / "a.h5")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert "'12:34' is not a Bluetooth address" in err and "bt://AA:BB:CC:DD:EE:FF" in err
    assert not (tmp_path / "a.h5").exists()


# --- the transport over a socket pair ----------------------------------------------------------


class SocketRadio:
    """The radio: `connect` hands the transport one end of a socket pair and serves the
    simulated unit on the other; `cut` drops the connection and refuses new ones until
    `restore`, while the unit keeps producing frames (lost, logged in its ledger)."""

    def __init__(self, unit: SimulatedUnit) -> None:
        self.unit = unit
        self.down = False
        self.connects: list[tuple[str, int]] = []
        self._far: socket.socket | None = None
        self._threads: list[threading.Thread] = []
        self._stop = threading.Event()

    def connect(self, address: str, channel: int, timeout_s: float) -> socket.socket:
        self.connects.append((address, channel))
        if self.down:
            raise OSError(errno.EHOSTDOWN, "Host is down")
        near, far = socket.socketpair()
        self._far = far
        t = threading.Thread(target=self._serve, args=(far,), daemon=True)
        t.start()
        self._threads.append(t)
        return near

    def _serve(self, far: socket.socket) -> None:
        unit = self.unit
        with contextlib.suppress(OSError):
            while not self._stop.is_set() and far.fileno() >= 0:
                due = 0.0 if math.isinf(unit.speed) else unit.seconds_until_next_sample()
                wait = min(due, 0.02)
                ready, _, _ = select.select([far], [], [], wait)
                if ready:
                    data = far.recv(4096)
                    if not data:
                        return
                    unit.write(data)
                out = unit.read(8192)
                if out:
                    far.sendall(out)

    def cut(self) -> None:
        self.down = True
        self.unit.set_link_down(True)
        if self._far is not None:
            with contextlib.suppress(OSError):
                self._far.shutdown(socket.SHUT_RDWR)
            self._far.close()

    def restore(self) -> None:
        self.unit.set_link_down(False)
        self.down = False

    def stop(self) -> None:
        self._stop.set()
        if self._far is not None:
            self._far.close()
        for t in self._threads:
            t.join(5)
        assert not any(t.is_alive() for t in self._threads)


def collect(dev: Device, n_frames: int, timeout_s: float = 20.0) -> list:
    blocks: list = []
    deadline = time.monotonic() + timeout_s
    while sum(len(b) for b in blocks) < n_frames and time.monotonic() < deadline:
        b = dev.read_block(0.2)
        if b is not None:
            blocks.append(b)
    return blocks


def test_bt_transport_framing_is_exact_over_the_socket():
    unit = SimulatedUnit(speed=math.inf, serial=42)
    radio = SocketRadio(unit)
    transport = BluetoothTransport(f"bt://{ADDR}/2", socket_connect=radio.connect)
    try:
        with Device(transport) as dev:
            assert dev.identify().serial == 42
            assert transport.status.reason == f"connected to bt://{ADDR}/2 (RFCOMM channel 2)"
            dev.select_kind(p.FrameKind.RAW)
            dev.start_stream()
            blocks = collect(dev, 3000)
            dev.stop_stream()
            while (b := dev.read_block(0.0)) is not None:
                blocks.append(b)
            st = dev.stats.decoder
    finally:
        radio.stop()
    assert radio.connects == [(ADDR, 2)]
    seq = np.concatenate([b.seq for b in blocks])
    assert len(seq) == unit.ledger.data_frames_produced and np.all(np.diff(seq) == 1)
    assert (st.frames_lost, st.crc_failures, st.bytes_skipped) == (0, 0, 0)
    assert st.frames_ok == unit.ledger.frames_produced
    assert st.bytes_received == unit.ledger.bytes_queued


def test_bt_transport_reconnects_like_the_serial_one():
    unit = SimulatedUnit(speed=1.0)
    radio = SocketRadio(unit)
    policy = ReconnectPolicy(stable_s=0.2)  # the link held longer than that: not flapping
    transport = BluetoothTransport(f"bt://{ADDR}", socket_connect=radio.connect, reconnect=policy)
    try:
        with Device(transport) as dev:
            dev.select_kind(p.FrameKind.RAW)
            dev.start_stream()
            before = collect(dev, 30)
            radio.cut()
            deadline = time.monotonic() + 30
            while transport.status.state == LinkState.CONNECTED and time.monotonic() < deadline:
                time.sleep(0.005)
            st = transport.status
            assert st.state == LinkState.RECONNECTING
            assert st.reason.startswith("link lost: ") and "closed the connection" in st.reason
            # refused attempts: the reason says why in the serial transport's words
            while len(radio.connects) < 3 and time.monotonic() < deadline:
                time.sleep(0.01)
            st = transport.status
            assert "the unit does not answer" in st.reason and "\n" not in st.reason
            # no node to watch: a failed connect is retried at the short interval
            assert st.next_attempt_s is not None
            assert st.next_attempt_s - time.monotonic() <= policy.present_max_s
            while (b := dev.read_block(0.0)) is not None:
                before.append(b)
            radio.restore()
            after = collect(dev, 30, timeout_s=10)
            stats = dev.stats
    finally:
        radio.stop()
    assert sum(len(b) for b in after) >= 30
    assert stats.transport.reconnects == 1 and stats.transport.link_losses == 1
    link_down = len(unit.ledger.dropped_frame_nos("link_down"))
    gap = int(after[0].seq[0]) - int(before[-1].seq[-1]) - 1
    assert link_down > 0 and 0 <= gap - link_down <= 50  # the setup was re-sent at once


def test_linux_lists_paired_serial_units_by_address():
    """BlueZ's answers (bluetoothctl) -> bt:// entries for devices with the serial profile."""
    from gaitmon.io.ports import paired_serial_units

    answers = {
        ("devices", "Paired"): "Device 00:11:22:AA:BB:CC GaitUnit 7\n"
        "Device 11:22:33:44:55:66 Headphones\n[bluetooth]# \n",
        ("info", ADDR): "Device 00:11:22:AA:BB:CC (public)\n\tName: GaitUnit 7\n\tPaired: yes\n"
        "\tUUID: Serial Port               (00001101-0000-1000-8000-00805f9b34fb)\n",
        ("info", "11:22:33:44:55:66"): "\tUUID: Audio Sink (0000110b-0000-1000-8000-...)\n",
    }
    units = paired_serial_units(lambda argv: answers[tuple(argv[1:])])
    assert [(u.device, u.friendly()) for u in units] == [
        (f"bt://{ADDR}", f"bt://{ADDR} - GaitUnit 7 (paired)")
    ]
    assert units[0].bluetooth

    def broken(argv):
        raise OSError("bluetoothd is not running")

    assert paired_serial_units(broken) == []
