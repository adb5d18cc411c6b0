"""The simulated unit on a pseudo-terminal, so the real pyserial code path can be exercised.

``PtySimulator(unit, link_path=None)`` opens a pty in raw mode, runs the unit on the master side
in one thread (commands in, due bytes out) and exposes the slave through a stable symlink
(``link_path``; by default ``<tmp>/gaitmon-sim-XXXX/ttyGAIT0``). A client opens ``link_path`` with
``serial.Serial(link_path)`` as it would a Bluetooth SPP port.

Link failures behave like a Bluetooth port that vanishes: ``cut()`` (or a scheduled link drop in
the unit's ``FaultConfig``) closes the pty and removes the symlink, so a client that has the port
open gets an error (EIO / "device disconnected") and reopening fails with "no such file";
``restore()`` (or the end of the scheduled drop) opens a new pty and re-points the symlink, so
the client can reopen the same path. The unit keeps running meanwhile; the frames it produces
while the link is down are recorded as ``link_down`` in ``unit.ledger``.

The thread sleeps in ``select`` until the next sample is due, a command arrives, the pty can take
more bytes or someone calls cut/restore/stop: no busy loop, and the pacing comes from the unit's
clock, not from the sleeps.
"""

from __future__ import annotations

import contextlib
import os
import select
import shutil
import tempfile
import threading
import tty
from pathlib import Path
from types import TracebackType

from gaitmon.io.sim.unit import SimulatedUnit

DEFAULT_LINK_NAME = "ttyGAIT0"
_MAX_WAIT_S = 0.05  # how stale a scheduled link drop may be noticed
_READ_CHUNK = 4096
_PENDING_LIMIT_BYTES = 64 * 1024  # bytes waiting for a client that does not read; then dropped


class PtySimulator:
    """Serve ``unit`` on a pty until ``stop()``. Also a context manager."""

    def __init__(self, unit: SimulatedUnit, link_path: str | os.PathLike[str] | None = None):
        # the unit's first samples need scipy's interpolator (io.sim.kinematics imports it on
        # first use: ~1 s, more on a busy machine): imported here, before the port exists, not
        # in the thread that must answer the client's first command (3 attempts of 0.5 s)
        import scipy.interpolate  # noqa: F401

        self.unit = unit
        self._tmpdir: str | None = None
        if link_path is None:
            self._tmpdir = tempfile.mkdtemp(prefix="gaitmon-sim-")
            link_path = Path(self._tmpdir) / DEFAULT_LINK_NAME
        self.link_path = Path(link_path)
        if self.link_path.exists() and not self.link_path.is_symlink():
            raise FileExistsError(f"{self.link_path} exists and is not a symlink; choose another")
        self._master: int | None = None
        self._slave: int | None = None
        self.slave_path: str | None = None
        self._pending = bytearray()
        self.dropped_bytes = 0  # bytes thrown away because the client did not read
        self._manual_cut = False
        self._want: str | None = None  # "cut" | "restore", handed to the thread
        self._done = threading.Event()
        self._stop = threading.Event()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)
        self._cond = threading.Lock()
        self._open_pty()
        self._thread = threading.Thread(target=self._run, name="gaitmon-pty-sim", daemon=True)
        self._thread.start()

    # ---- public -----------------------------------------------------------------------------
    @property
    def is_up(self) -> bool:
        return self._master is not None

    def cut(self, timeout_s: float = 5.0) -> None:
        """Close the pty: the port vanishes until ``restore()``."""
        self._request("cut", timeout_s)

    def restore(self, timeout_s: float = 5.0) -> None:
        """Open a fresh pty and re-point ``link_path`` at it."""
        self._request("restore", timeout_s)

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop the thread, close the pty and remove the symlink (and the temp dir we made)."""
        if not self._thread.is_alive() and self._wake_w < 0:
            return
        self._stop.set()
        self._wake()
        self._thread.join(timeout_s)
        if self._thread.is_alive():
            raise RuntimeError("the pty simulator thread did not stop")
        self._close_pty()
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._wake_r = self._wake_w = -1
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)

    def __enter__(self) -> PtySimulator:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()

    # ---- thread -----------------------------------------------------------------------------
    def _request(self, what: str, timeout_s: float) -> None:
        with self._cond:
            self._done.clear()
            self._want = what
            self._wake()
            if not self._done.wait(timeout_s):
                raise RuntimeError(f"the pty simulator did not {what} in time")

    def _wake(self) -> None:
        with contextlib.suppress(OSError):
            os.write(self._wake_w, b"\0")

    def _run(self) -> None:
        unit = self.unit
        while not self._stop.is_set():
            want, self._want = self._want, None
            if want == "cut":
                self._manual_cut = True
                unit.set_link_down(True)
                self._close_pty()
                self._done.set()
            elif want == "restore":
                self._manual_cut = False
                unit.set_link_down(False)
                if self._master is None and not unit.link_is_down():
                    self._open_pty()
                self._done.set()
            scheduled_down = unit.link_is_down()
            if scheduled_down and self._master is not None:
                self._close_pty()
            elif not scheduled_down and self._master is None and not self._manual_cut:
                self._open_pty()

            master = self._master
            if master is None:
                unit.read()  # the device keeps running; its frames are lost (and logged)
                self._sleep([], [], _MAX_WAIT_S)
                continue
            if len(self._pending) < _READ_CHUNK:
                self._pending += unit.read(_READ_CHUNK)
            wait_s = min(unit.seconds_until_next_sample(), _MAX_WAIT_S)
            wlist = [master] if self._pending else []
            if self._pending and wait_s == 0.0:
                wait_s = _MAX_WAIT_S  # flat out: let the client's reading pace us
            readable, writable = self._sleep([master], wlist, wait_s)
            if master in readable:
                try:
                    data = os.read(master, _READ_CHUNK)
                except OSError:
                    data = b""
                if data:
                    unit.write(data)
            if master in writable and self._pending:
                try:
                    n = os.write(master, self._pending)
                except (BlockingIOError, InterruptedError):
                    n = 0
                except OSError:
                    n = len(self._pending)  # nobody on the other side: the bytes are gone
                    self.dropped_bytes += n
                del self._pending[:n]
            excess = len(self._pending) - _PENDING_LIMIT_BYTES
            if excess > 0:
                del self._pending[:excess]
                self.dropped_bytes += excess

    def _sleep(
        self, rlist: list[int], wlist: list[int], timeout_s: float
    ) -> tuple[list[int], list[int]]:
        try:
            r, w, _ = select.select([*rlist, self._wake_r], wlist, [], timeout_s)
        except (OSError, ValueError):
            return [], []
        if self._wake_r in r:
            with contextlib.suppress(OSError):
                os.read(self._wake_r, 512)
        return r, w

    def _open_pty(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no line editing, no CR/LF translation: a binary link
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self.slave_path = os.ttyname(slave)
        # Atomic re-point: a client never sees a half-made link.
        tmp = self.link_path.with_name(self.link_path.name + ".new")
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        os.symlink(self.slave_path, tmp)
        os.replace(tmp, self.link_path)

    def _close_pty(self) -> None:
        self._pending.clear()
        with contextlib.suppress(FileNotFoundError):
            self.link_path.unlink()
        for fd in (self._master, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = None
        self.slave_path = None
