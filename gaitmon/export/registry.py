"""The export formats: one plugin a line, imported plainly (each plugin module is cheap to
import; its writer's numpy, scipy and analysis are imported when it writes).

The command line (``gaitmon export --format``) and the review window's export dialog list
:data:`FORMATS`. A new format is its module (a :class:`~.base.Format` subclass and its
instance) and one line here.
"""

from __future__ import annotations

from gaitmon.export.base import Format
from gaitmon.export.bids import BIDS
from gaitmon.export.c3d import C3D
from gaitmon.export.csv import CSV
from gaitmon.export.mat import MAT
from gaitmon.export.strides import STRIDES

PLUGINS: tuple[Format, ...] = (CSV, MAT, C3D, STRIDES, BIDS)
FORMATS: dict[str, Format] = {f.name: f for f in PLUGINS}
