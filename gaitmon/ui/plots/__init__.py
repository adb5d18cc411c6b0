"""Plots of the desktop interface (pyqtgraph), built once and fed numpy arrays.

* ``traces`` -- drawing primitives shared with the review window (`TraceSet`, `Trace`, the
  plot style) and the clinical y ranges; the Qt-free geometry (decimation, step bands, event
  lines) is ``gaitmon.engine.display``'s, re-exported here;
* ``live``   -- the live monitor's plots (`LivePlots`) and raw-sensor plots (`RawPlots`);
* ``cycles`` -- the live gait-cycle overlay (`CyclePlots`).
"""

from gaitmon.engine.display import (
    MAX_POINTS,
    decimate_peak,
    on_scale,
    step_band,
    step_runs,
    vertical_lines,
)
from gaitmon.ui.plots.cycles import CyclePlots
from gaitmon.ui.plots.live import LivePlots, RawPlots
from gaitmon.ui.plots.traces import (
    AXIS_WIDTH_PX,
    FSR_RANGE,
    JOINTS,
    METHOD_LABELS,
    METHODS,
    TILT_RANGES_DEG,
    CountingPlotWidget,
    Trace,
    TraceSet,
    style_plot,
)

__all__ = [
    "AXIS_WIDTH_PX",
    "FSR_RANGE",
    "JOINTS",
    "MAX_POINTS",
    "METHODS",
    "METHOD_LABELS",
    "TILT_RANGES_DEG",
    "CountingPlotWidget",
    "CyclePlots",
    "LivePlots",
    "RawPlots",
    "Trace",
    "TraceSet",
    "decimate_peak",
    "on_scale",
    "step_band",
    "step_runs",
    "style_plot",
    "vertical_lines",
]
