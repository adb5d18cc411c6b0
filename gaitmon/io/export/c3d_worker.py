"""One C3D file as plain data (:class:`C3dSpec`), built by gaitmon.io.export.c3d and written
by gaitmon.io.export.c3d_file.

(Formerly also a recycled child process around ezc3d, whose writer kept the data of every file
it wrote; the numpy writer needs neither.)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class C3dSpec:
    """One C3D file as plain data: the parameters to set and the arrays."""

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
    """Write one C3D file."""
    from gaitmon.io.export.c3d_file import write_c3d

    write_c3d(spec, out)
