"""Plots of the desktop interface (pyqtgraph), built once and fed numpy arrays.

* ``traces`` -- drawing primitives shared with the review window (`TraceSet`, `Trace`,
  decimation, step bands, event lines, the plot style) and the clinical y ranges;
* ``live``   -- the live monitor's plots (`LivePlots`) and raw-sensor plots (`RawPlots`);
* ``cycles`` -- the live gait-cycle overlay (`CyclePlots`).
"""

from gaitmon.ui.plots.cycles import CyclePlots
from gaitmon.ui.plots.live import LivePlots, RawPlots
from gaitmon.ui.plots.traces import (
    AXIS_WIDTH_PX,
    FSR_RANGE,
    JOINTS,
    MAX_POINTS,
    METHOD_LABELS,
    METHODS,
    TILT_RANGES_DEG,
    CountingPlotWidget,
    Trace,
    TraceSet,
    decimate_peak,
    step_band,
    step_runs,
    style_plot,
    vertical_lines,
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
    "step_band",
    "step_runs",
    "style_plot",
    "vertical_lines",
]
