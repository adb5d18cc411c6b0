"""Writing C3D files with ezc3d, in this process or in a recycled child process.

A C3D part is built (gaitmon.io.export.c3d) as :class:`C3dSpec`, plain picklable data, so it
can be written here or handed to a child. ezc3d 1.7 keeps about the data size of every file
it writes until the process exits, so long exports write their parts in a child process that
is replaced every few files (:class:`C3dWorker`). The child is
``python -m gaitmon.io.export.c3d_worker``: length-prefixed pickles of (spec, path) on stdin,
one pickled error text ("" for success) per file on stdout.

This module imports only numpy (and ezc3d when writing), so the child starts light.
"""

from __future__ import annotations

import contextlib
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gaitmon.io.export.errors import ExportError


@dataclass
class C3dSpec:
    """One C3D file as plain, picklable data: the parameters to set and the arrays."""

    values: list[tuple[str, str, Any]] = field(default_factory=list)  # set existing param
    params: list[tuple[str, str, Any, str]] = field(default_factory=list)  # add_parameter
    int_params: list[tuple[str, str, list[int], str]] = field(default_factory=list)
    points: np.ndarray = field(default_factory=lambda: np.zeros((4, 0, 0)))
    residuals: np.ndarray = field(default_factory=lambda: np.zeros((1, 0, 0)))
    analogs: np.ndarray = field(default_factory=lambda: np.zeros((1, 0, 0)))

    def set_value(self, group: str, name: str, value: Any) -> None:
        self.values.append((group, name, value))

    def add_parameter(self, group: str, name: str, value: Any, desc: str = "") -> None:
        self.params.append((group, name, value, desc))

    def add_int_parameter(self, group: str, name: str, values: list[int],
                          desc: str = "") -> None:
        self.int_params.append((group, name, [int(v) for v in values], desc))


def write_spec(spec: C3dSpec, out: str) -> None:
    """Write one C3D file with ezc3d (in a worker process for long exports: ezc3d 1.7 keeps
    about the data size of every c3d it writes, so the worker is replaced every few parts)."""
    import ezc3d

    c = ezc3d.c3d()
    for group, name, value in spec.values:
        c["parameters"][group][name]["value"] = value
    c["data"]["points"] = spec.points
    c["data"]["meta_points"] = {"residuals": spec.residuals}
    c["data"]["analogs"] = spec.analogs
    for group, name, value, desc in spec.params:
        c.add_parameter(group, name, value, desc)
    for group, name, ints, desc in spec.int_params:
        # ezc3d's add_parameter turns Python int lists into FLOAT parameters; the C3D spec
        # wants INTEGER for TRIAL fields, counts and ids, so build the parameter directly.
        p = ezc3d.ezc3d.Parameter(name, desc)
        p.set(ezc3d.ezc3d.VecInt([int(v) for v in ints]), [len(ints)])
        c._storage["parameters"].add_parameter(group, p)
    c.write(out)


class C3dWorker:
    """`python -m gaitmon.io.export.c3d_worker`: pickled (spec, path) in, error text out,
    replaced after ``files_per_process`` files.

    A plain child process (not multiprocessing): nothing of the caller (its __main__, its
    threads, an open HDF5 file) is re-run or inherited beyond the pipes."""

    def __init__(self, files_per_process: int) -> None:
        self.files_per_process = files_per_process
        self.proc: Any = None
        self.done = 0

    def _start(self) -> None:
        import subprocess

        env = dict(os.environ)
        root = str(Path(__file__).resolve().parents[3])  # so the child imports this gaitmon
        env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH")) if p)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "gaitmon.io.export.c3d_worker"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env,
        )
        self.done = 0

    def write(self, spec: C3dSpec, path: Path) -> None:
        import pickle

        if self.proc is None or self.done >= self.files_per_process:
            self.close()
            self._start()
        _send(self.proc.stdin, pickle.dumps((spec, str(path)), protocol=5))
        reply = _recv(self.proc.stdout)
        if reply is None:
            raise ExportError(f"the C3D writer process stopped while writing {path.name}")
        error = pickle.loads(reply)
        if error:
            raise ExportError(f"cannot write {path.name}: {error}")
        self.done += 1

    def close(self) -> None:
        if self.proc is None:
            return
        with contextlib.suppress(OSError):
            self.proc.stdin.close()  # EOF: the worker's loop ends
        try:
            self.proc.wait(timeout=30)
        except Exception:
            self.proc.kill()
            self.proc.wait()
        finally:
            self.proc.stdout.close()
            self.proc = None


def _send(f: Any, payload: bytes) -> None:
    f.write(len(payload).to_bytes(8, "little"))
    f.write(payload)
    f.flush()


def _recv(f: Any) -> bytes | None:
    head = f.read(8)
    if len(head) < 8:
        return None
    n = int.from_bytes(head, "little")
    data = f.read(n)
    return data if len(data) == n else None


def _serve() -> None:
    """The child's loop: until EOF on stdin, write each file and answer with its error."""
    import pickle

    inp, out = sys.stdin.buffer, sys.stdout.buffer
    while (msg := _recv(inp)) is not None:
        spec, path = pickle.loads(msg)
        try:
            write_spec(spec, path)
            error = ""
        except Exception as exc:  # reported to the parent as one line
            error = f"{type(exc).__name__}: {exc}".splitlines()[0]
        _send(out, pickle.dumps(error))


if __name__ == "__main__":
    _serve()
