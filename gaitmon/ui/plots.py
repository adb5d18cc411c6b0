"""The live plots: segment tilts, joint angles, FSR with gait phases, raw sensors, cycle overlay.

Everything here is built once and then fed numpy arrays from an engine `Snapshot` ~30 times a
second. What keeps that cheap (budget: < 30 % of one core for the GUI thread):

* each plot's traces drawn by one `TraceSet` item (one paint call per plot, paths built by
  ``pg.arrayToQPath``), pen width 1, no antialiasing, fixed axis ranges (no autorange pass);
* axes (which draw the grid) cached as pixmaps, major grid lines only;
* the x axis is "seconds before now" with a fixed range, so the axes never re-render while the
  traces scroll;
* series known to be finite skip pyqtgraph's finite check; series with gaps (device modes leave
  some series NaN) are drawn with ``connect='finite'`` and all-NaN ones are hidden;
* windows longer than ``MAX_POINTS`` are min/max decimated once per series (all columns in one
  numpy call) instead of per curve, so peaks stay visible;
* gait phases are drawn as step polygons through the phase changes only (a few dozen points),
  and events / markers as one ``connect='pairs'`` path per plot.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QRectF
from PySide6.QtGui import QBrush, QColor, QFont, QPainter, QPainterPath, QPaintEvent, QPen
from PySide6.QtWidgets import QGraphicsItem, QGraphicsObject, QGraphicsView, QWidget

from gaitmon.dsp.gait import cycle_mean_sd
from gaitmon.engine import Snapshot
from gaitmon.ui.theme import Colours, pen

SEGMENTS = ("body", "thigh", "shank", "foot")
# y ranges cover normal and pathological walking with a calibrated (zeroed) unit
TILT_RANGES_DEG = {"body": (-25, 25), "thigh": (-45, 50), "shank": (-75, 50), "foot": (-80, 60)}
JOINTS = (
    ("hip", "hip flexion", (-25, 55)),
    ("knee", "knee flexion", (-10, 80)),
    ("ankle", "ankle dorsiflexion", (-35, 35)),
)
FSR_RANGE = (-150.0, 4250.0)  # 12-bit ADC counts
# (key, label, tilt series, joint series); drawn in this order, Kalman on top
METHODS = (
    ("gyro", "Gyro integration", "tilt_gyro_deg", "joint_gyro_deg"),
    ("acc", "Accelerometer", "tilt_acc_deg", "joint_acc_deg"),
    ("kalman", "Kalman filter", "tilt_kalman_deg", "joint_kalman_deg"),
)
METHOD_LABELS = {k: label for k, label, _, _ in METHODS}
PHASE_NAMES = ("swing", "loading", "foot flat", "push-off")
MAX_POINTS = 1400  # per trace; beyond this a window is min/max decimated
AXIS_WIDTH_PX = 58

if TYPE_CHECKING:
    # pyqtgraph has no type information. Its bases are typed here as the Qt classes they
    # derive from; what pyqtgraph adds to a layout widget (addPlot, ci, ...) is Any.
    _GraphicsObject = QGraphicsObject

    class _GraphicsLayoutWidget(QGraphicsView):
        def __getattr__(self, name: str) -> Any: ...

else:
    _GraphicsObject = pg.GraphicsObject
    _GraphicsLayoutWidget = pg.GraphicsLayoutWidget


def decimate_peak(x: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Min/max decimation of (N,) x and (N, ...) y to at most ``max_points`` rows.

    Each group of f consecutive samples becomes two rows (its min and max), so short peaks
    survive; the oldest N mod f samples are dropped. Returns the inputs when no decimation
    is needed.
    """
    n = len(x)
    if n <= max_points or max_points < 2:
        return x, y
    f = math.ceil(n / (max_points // 2))
    if n < 2 * f:
        return x, y
    m = n // f
    start = n - m * f
    xs = x[start:].reshape(m, f)
    ys = y[start:].reshape(m, f, *y.shape[1:])
    out_x = np.empty(2 * m)
    out_x[0::2] = xs[:, 0]
    out_x[1::2] = xs[:, -1]
    out_y = np.empty((2 * m, *y.shape[1:]))
    out_y[0::2] = ys.min(axis=1)
    out_y[1::2] = ys.max(axis=1)
    return out_x, out_y


def step_band(
    x: np.ndarray, mask: np.ndarray, top: float, bottom: float
) -> tuple[np.ndarray, np.ndarray]:
    """A step outline that is ``top`` where ``mask`` holds and ``bottom`` elsewhere.

    Only the runs' ends become points, so a 10 s window of phases is a few dozen points.
    """
    if len(x) == 0:
        return np.empty(0), np.empty(0)
    m = np.asarray(mask, dtype=np.int8)
    change = np.flatnonzero(np.diff(m)) + 1
    starts = np.concatenate([[0], change])
    ends_x = np.concatenate([x[change], x[-1:]])
    out_x = np.empty(2 * len(starts))
    out_x[0::2] = x[starts]
    out_x[1::2] = ends_x
    out_y = np.repeat(np.where(m[starts] > 0, top, bottom), 2)
    return out_x, out_y


def vertical_lines(xs: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Points for a ``connect='pairs'`` curve drawing one vertical line per x."""
    return np.repeat(xs, 2), np.tile(np.array([lo, hi]), len(xs))


class Trace:
    """One line (or filled band) inside a `TraceSet`: its path, style and what it shows."""

    __slots__ = ("brush", "column", "fill_level", "method", "n_points", "path", "pen", "series",
                 "visible")  # fmt: skip

    def __init__(
        self,
        pen: QPen | None = None,
        brush: QColor | None = None,
        fill_level: float | None = None,
        series: str = "",
        column: int = -1,
        method: str = "",
    ) -> None:
        self.pen = pen
        self.brush = QBrush(brush) if brush is not None else None
        self.fill_level = fill_level
        self.series = series
        self.column = column
        self.method = method
        self.path: QPainterPath | None = None
        self.n_points = 0
        self.visible = True

    def set(self, x: np.ndarray, y: np.ndarray, finite: bool = True, connect: str = "") -> None:
        """New points; ``finite=False`` breaks the line at NaNs (device modes have gaps)."""
        if len(x) == 0:
            self.clear()
            return
        if self.fill_level is not None:  # close the outline down to the fill level
            x = np.concatenate([x[:1], x, x[-1:]])
            y = np.concatenate([[self.fill_level], y, [self.fill_level]])
        mode = connect or ("all" if finite else "finite")
        self.path = pg.arrayToQPath(
            np.ascontiguousarray(x, dtype=np.float64),
            np.ascontiguousarray(y, dtype=np.float64),
            connect=mode,
            finiteCheck=not finite,
        )
        self.n_points = len(x)

    def clear(self) -> None:
        self.path = None
        self.n_points = 0


class TraceSet(_GraphicsObject):
    """All the traces of one plot, drawn by a single item in list order.

    One ``paint`` per plot instead of one per curve: with ~50 PlotCurveItems the per-item
    overhead (Python paint logic, bounds, scene bookkeeping) cost ~130 us each per frame. The
    bounding rect is a constant (the plot clips to its view), so no per-frame bounds pass.
    ``dataBounds`` reports the plot's nominal range, so "View all" in the menu stays sane.
    """

    _BIG = QRectF(-1e5, -1e7, 2e5, 2e7)

    def __init__(self, nominal_x: tuple[float, float], nominal_y: tuple[float, float]) -> None:
        super().__init__()
        self.traces: list[Trace] = []
        self.nominal = [nominal_x, nominal_y]
        self.antialias = False  # measured: antialiased live traces redraw far slower

    def add(self, trace: Trace) -> Trace:
        self.traces.append(trace)
        return trace

    def commit(self) -> None:
        """Schedule a repaint after the traces changed."""
        self.update()

    def boundingRect(self) -> QRectF:
        return self._BIG

    def dataBounds(
        self, ax: int, frac: float = 1.0, orthoRange: object = None
    ) -> tuple[float, float]:
        return self.nominal[ax]

    def paint(self, p: QPainter, *args: object) -> None:
        p.setRenderHint(QPainter.RenderHint.Antialiasing, self.antialias)
        for tr in self.traces:
            if tr.path is None or not tr.visible:
                continue
            if tr.brush is not None:
                p.fillPath(tr.path, tr.brush)
            else:
                p.setPen(tr.pen)
                p.drawPath(tr.path)


class CountingPlotWidget(_GraphicsLayoutWidget):
    """A GraphicsLayoutWidget that counts its repaints and the latency of the data it shows.

    Latency = time the paint finished - host receive time of the newest sample drawn; measured
    on the first paint after new data (what `benchmarks/bench_gui.py` reports).
    """

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.paints = 0
        self.latencies_s: deque[float] = deque(maxlen=4096)
        self._shown_host_time_s: float | None = None

    def mark_new_data(self, newest_host_time_s: float) -> None:
        self._shown_host_time_s = newest_host_time_s

    def paintEvent(self, ev: QPaintEvent) -> None:
        super().paintEvent(ev)
        self.paints += 1
        if self._shown_host_time_s is not None:
            self.latencies_s.append(time.monotonic() - self._shown_host_time_s)
            self._shown_host_time_s = None


def _style_plot(
    plot: pg.PlotItem, colours: Colours, ylabel: str, yrange: tuple[float, float], bottom: bool
) -> None:
    plot.setMenuEnabled(True)
    plot.setMouseEnabled(x=False, y=True)  # y zoom to inspect; x follows the clock
    plot.hideButtons()
    plot.showGrid(x=True, y=True, alpha=colours.grid_alpha)
    vb = plot.getViewBox()
    vb.disableAutoRange()
    vb.setDefaultPadding(0.0)
    plot.setYRange(*yrange, padding=0)
    left = plot.getAxis("left")
    left.setWidth(AXIS_WIDTH_PX)
    left.setLabel(ylabel)
    left.enableAutoSIPrefix(False)
    ax = plot.getAxis("bottom")
    if bottom:
        ax.setLabel("time before now (s)")
    else:
        ax.setStyle(showValues=False)
        ax.setHeight(6)
    font = QFont()
    font.setPointSizeF(8.0)
    for a in (left, ax):
        a.setTickFont(font)
        # The axes draw the grid; replaying it on every frame was ~80 % of the paint time
        # (17 ms -> 3 ms per frame measured): keep major ticks only and cache the axes as
        # pixmaps (they only change when the y range or the window size does).
        a.setStyle(maxTickLevel=0)
        a.setCacheMode(QGraphicsItem.CacheMode.DeviceCoordinateCache)


@dataclass
class _PlotInfo:
    plot: pg.PlotItem
    yrange: tuple[float, float]
    traces: TraceSet
    events_hs: Trace | None = None
    events_to: Trace | None = None
    markers: Trace | None = None


class LivePlots(CountingPlotWidget):
    """Tilt of body/thigh/shank/foot (left), hip/knee/ankle and FSR + gait phase (right)."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.window_s = 10.0
        self.methods_on = {"acc": True, "kalman": True, "gyro": True}
        self.four_phases = True
        self.curves: list[Trace] = []  # the data traces (series, column, method)
        self.plots: dict[str, _PlotInfo] = {}
        self._bands: list[tuple[Trace, tuple[int, ...]]] = []
        self._marker_labels: list[tuple[pg.TextItem, str]] = []
        self._no_fsr_text: pg.TextItem | None = None
        self.threshold_line: pg.InfiniteLine | None = None
        self.ci.setContentsMargins(2, 2, 8, 2)
        self.ci.layout.setHorizontalSpacing(10)
        self.ci.layout.setVerticalSpacing(3)
        self._build()
        self.set_window(self.window_s)

    # -- construction ----------------------------------------------------------------------

    def _new_plot(
        self,
        name: str,
        row: int,
        col: int,
        ylabel: str,
        yr: tuple[float, float],
        bottom: bool,
        tip: str,
    ) -> _PlotInfo:
        p = self.addPlot(row=row, col=col)
        _style_plot(p, self.colours, ylabel, yr, bottom=bottom)
        p.setToolTip(tip)
        ts = TraceSet((-self.window_s, 0.0), yr)
        p.addItem(ts)
        info = _PlotInfo(p, yr, ts)
        self.plots[name] = info
        return info

    def _build(self) -> None:
        c = self.colours
        method_pen = {"acc": pen(c.acc), "kalman": pen(c.kalman), "gyro": pen(c.gyro)}
        self.addLabel("Segment tilt", row=0, col=0, size="9pt", bold=True)
        self.addLabel("Joint angles and foot contact", row=0, col=1, size="9pt", bold=True)
        for i, seg in enumerate(SEGMENTS):
            info = self._new_plot(
                seg, i + 1, 0, f"{seg} tilt (deg)", TILT_RANGES_DEG[seg],
                i == len(SEGMENTS) - 1,
                f"{seg.capitalize()} tilt in degrees (sagittal, 0 = standing pose after Zero). "
                "Red: accelerometer, green: Kalman filter, blue: gyro integration.",
            )  # fmt: skip
            for key, _label, tilt_series, _joint in METHODS:
                tr = Trace(method_pen[key], series=tilt_series, column=i, method=key)
                self.curves.append(info.traces.add(tr))
            info.markers = info.traces.add(Trace(pen(c.marker)))
        for j, (key, label, yr) in enumerate(JOINTS):
            sign = "dorsiflexion" if key == "ankle" else "flexion"
            info = self._new_plot(
                key, j + 1, 1, f"{label} (deg)", yr, False,
                f"{key.capitalize()} angle in degrees, {sign} positive (clinical convention), "
                "0 = standing pose. Grey lines: heel strike (solid), toe off (dashed).",
            )  # fmt: skip
            self._add_events(info)
            for mkey, _label, _tilt, joint_series in METHODS:
                tr = Trace(method_pen[mkey], series=joint_series, column=j, method=mkey)
                self.curves.append(info.traces.add(tr))
            info.markers = info.traces.add(Trace(pen(c.marker)))
        # FSR and gait phase: bands under the events under the traces
        info = self._new_plot(
            "fsr", len(JOINTS) + 1, 1, "FSR (ADC counts)", FSR_RANGE, True,
            "Force-sensing resistors in ADC counts (12 bit): heel red, toe green. Shading: gait "
            "phase from the contacts; lines: heel strike (solid) and toe off (dashed).",
        )  # fmt: skip
        lo = FSR_RANGE[0]
        for k, colour in enumerate(c.phases, start=1):
            self._bands.append((info.traces.add(Trace(brush=colour, fill_level=lo)), (k,)))
        self._bands.append((info.traces.add(Trace(brush=c.stance, fill_level=lo)), (1, 2, 3)))
        self._add_events(info, heel_toe=True)
        for k, colour in enumerate((c.heel, c.toe)):
            self.curves.append(info.traces.add(Trace(pen(colour), series="fsr_counts", column=k)))
        info.markers = info.traces.add(Trace(pen(c.marker)))
        p = info.plot
        self.threshold_line = pg.InfiniteLine(
            pos=1000.0, angle=0, pen=pen(c.event, dashed=True), movable=False
        )
        p.addItem(self.threshold_line)
        self._no_fsr_text = pg.TextItem(
            "no foot-contact data in the unit's tilt mode", color=c.foreground, anchor=(0.5, 0.5)
        )
        self._no_fsr_text.setVisible(False)
        p.addItem(self._no_fsr_text)
        self._set_phase_visibility()

    def _add_events(self, info: _PlotInfo, heel_toe: bool = False) -> None:
        c = self.colours
        info.events_hs = info.traces.add(Trace(pen(c.heel if heel_toe else c.event)))
        info.events_to = info.traces.add(Trace(pen(c.toe if heel_toe else c.event, dashed=True)))

    # -- options -----------------------------------------------------------------------------

    def set_window(self, window_s: float) -> None:
        self.window_s = float(window_s)
        for info in self.plots.values():
            info.plot.setXRange(-self.window_s, 0.0, padding=0)
            info.traces.nominal[0] = (-self.window_s, 0.0)
        if self._no_fsr_text is not None:
            self._no_fsr_text.setPos(-self.window_s / 2, sum(FSR_RANGE) / 2)

    def set_method(self, method: str, on: bool) -> None:
        self.methods_on[method] = bool(on)
        for tr in self.curves:
            if tr.method == method:
                tr.visible = bool(on)
        self._commit()

    def set_four_phases(self, four: bool) -> None:
        self.four_phases = bool(four)
        self._set_phase_visibility()
        self._commit()

    def _set_phase_visibility(self) -> None:
        for tr, phases in self._bands:
            tr.visible = (len(phases) == 1) == self.four_phases

    def set_fsr_threshold(self, counts: float) -> None:
        if self.threshold_line is not None:
            self.threshold_line.setValue(counts)
            self.threshold_line.setToolTip(f"contact threshold: {counts:g} counts (Settings)")

    def reset_y_ranges(self) -> None:
        for info in self.plots.values():
            info.plot.setYRange(*info.yrange, padding=0)

    def _commit(self) -> None:
        for info in self.plots.values():
            info.traces.commit()

    def clear_data(self) -> None:
        for info in self.plots.values():
            for tr in info.traces.traces:
                tr.clear()
        for item, _ in self._marker_labels:
            item.setVisible(False)
        self._commit()

    def _find(self, series: str, column: int, method: str = "") -> Trace:
        for tr in self.curves:
            if tr.series == series and tr.column == column and tr.method == method:
                return tr
        raise KeyError(f"no trace for {series}[{column}] {method}")

    def curve_points(self, series: str, column: int, method: str = "") -> int:
        """Points the trace of (series, column, method) holds now (what the tests look at)."""
        return self._find(series, column, method).n_points

    def curve_path(self, series: str, column: int, method: str = "") -> QPainterPath | None:
        return self._find(series, column, method).path

    # -- the per-frame update ------------------------------------------------------------------

    def update_from(self, snap: Snapshot) -> None:
        s = snap.series
        t = s["t_s"]
        if len(t) == 0:
            return
        t_now = float(t[-1])
        x_full = t - t_now
        cache: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
        for tr in self.curves:
            if not tr.visible:
                continue
            got = cache.get(tr.series)
            if got is None:
                x, y = decimate_peak(x_full, s[tr.series], MAX_POINTS)
                fin = np.isfinite(y)
                got = (x, y, fin.all(axis=0), fin.any(axis=0))
                cache[tr.series] = got
            x, y, all_finite, any_finite = got
            if any_finite[tr.column]:
                tr.set(x, y[:, tr.column], bool(all_finite[tr.column]))
            else:
                tr.clear()

        self._update_phases(x_full, s["phase"])
        hs = snap.heel_strike_t_s - t_now
        to = snap.toe_off_t_s - t_now
        marker_x = np.array([m[0] - t_now for m in snap.markers], dtype=float)
        for info in self.plots.values():
            lo, hi = info.yrange
            if info.events_hs is not None and info.events_to is not None:
                info.events_hs.set(*vertical_lines(hs, lo, hi), connect="pairs")
                info.events_to.set(*vertical_lines(to, lo, hi), connect="pairs")
            if info.markers is not None:
                info.markers.set(*vertical_lines(marker_x, lo, hi), connect="pairs")
            info.traces.commit()
        self._update_marker_labels(snap.markers, t_now)
        fsr_missing = not np.isfinite(s["fsr_counts"]).any()
        if self._no_fsr_text is not None and self._no_fsr_text.isVisible() != fsr_missing:
            self._no_fsr_text.setVisible(fsr_missing)
        self.mark_new_data(float(s["host_time_s"][-1]))

    def _update_phases(self, x: np.ndarray, phase: np.ndarray) -> None:
        lo, hi = FSR_RANGE
        ph = np.nan_to_num(phase, nan=0.0)
        for tr, phases in self._bands:
            if not tr.visible:
                continue
            mask = ph == phases[0] if len(phases) == 1 else ph > 0
            tr.set(*step_band(x, mask, hi, lo))

    def _update_marker_labels(self, markers: Iterable[tuple[float, str]], t_now: float) -> None:
        shown = [(t - t_now, label) for t, label in markers if t - t_now >= -self.window_s]
        need = 2 * len(shown)  # one label on the top plot of each column
        while len(self._marker_labels) < need:
            name = "body" if len(self._marker_labels) % 2 == 0 else "hip"
            item = pg.TextItem(color=self.colours.marker, anchor=(0, 0))
            self.plots[name].plot.addItem(item)
            self._marker_labels.append((item, name))
        for i, (item, name) in enumerate(self._marker_labels):
            k = i // 2
            if k < len(shown):
                x, label = shown[k]
                item.setText(label or "marker")
                item.setPos(x, self.plots[name].yrange[1])
                if not item.isVisible():
                    item.setVisible(True)
            elif item.isVisible():
                item.setVisible(False)


class RawPlots(CountingPlotWidget):
    """Optional: low-passed accelerometer x/z and gyro rate per segment."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.curves: list[Trace] = []
        self.window_s = 10.0
        self.acc_plot = self.addPlot(row=0, col=0)
        _style_plot(self.acc_plot, colours, "acceleration (m/s²)", (-25, 30), bottom=False)
        self.acc_plot.setToolTip(
            "Low-passed accelerometer per segment in m/s² (solid: x along the segment, "
            "faint: z forward). Raw-frame mode only."
        )
        self.gyro_plot = self.addPlot(row=1, col=0)
        _style_plot(self.gyro_plot, colours, "gyro rate (rad/s)", (-9, 9), bottom=True)
        self.gyro_plot.setToolTip("Gyro rate per segment in rad/s (bias removed after Zero).")
        self.acc_traces = TraceSet((-self.window_s, 0.0), (-25, 30))
        self.gyro_traces = TraceSet((-self.window_s, 0.0), (-9, 9))
        self.acc_plot.addItem(self.acc_traces)
        self.gyro_plot.addItem(self.gyro_traces)
        legend = self.acc_plot.addLegend(colCount=4, offset=(4, 2), labelTextSize="8pt")
        for i, seg in enumerate(SEGMENTS):
            col = colours.segments[i]
            faint = QColor(col)
            faint.setAlpha(110)
            for axis, colour in ((0, col), (1, faint)):
                tr = Trace(pen(colour), series="acc_ms2", column=i * 2 + axis)
                self.curves.append(self.acc_traces.add(tr))
            self.curves.append(self.gyro_traces.add(Trace(pen(col), series="gyro_rad_s", column=i)))
            # legend entries only (the traces are drawn by the TraceSet)
            legend.addItem(pg.PlotDataItem(pen=pen(col)), seg)
        self.set_window(self.window_s)

    def set_window(self, window_s: float) -> None:
        self.window_s = float(window_s)
        for p, ts in ((self.acc_plot, self.acc_traces), (self.gyro_plot, self.gyro_traces)):
            p.setXRange(-self.window_s, 0.0, padding=0)
            ts.nominal[0] = (-self.window_s, 0.0)

    def clear_data(self) -> None:
        for tr in self.curves:
            tr.clear()
        self.acc_traces.commit()
        self.gyro_traces.commit()

    def update_from(self, snap: Snapshot) -> None:
        s = snap.series
        t = s["t_s"]
        if len(t) == 0:
            return
        x_full = t - t[-1]
        acc = s["acc_ms2"].reshape(len(t), -1)
        for name, arr in (("acc_ms2", acc), ("gyro_rad_s", s["gyro_rad_s"])):
            x, y = decimate_peak(x_full, arr, MAX_POINTS)
            fin = np.isfinite(y)
            finite, some = fin.all(axis=0), fin.any(axis=0)
            for tr in self.curves:
                if tr.series != name:
                    continue
                if some[tr.column]:
                    tr.set(x, y[:, tr.column], bool(finite[tr.column]))
                else:
                    tr.clear()
        self.acc_traces.commit()
        self.gyro_traces.commit()
        self.mark_new_data(float(s["host_time_s"][-1]))


class CyclePlots(CountingPlotWidget):
    """Hip, knee and ankle over the gait cycle: mean ± SD of the last strides + current stride."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.ci.setContentsMargins(2, 2, 8, 2)
        self.pct = np.linspace(0.0, 100.0, 101)
        self.mean_curves: list[pg.PlotCurveItem] = []
        self.upper: list[pg.PlotCurveItem] = []
        # hides QWidget.lower() (window stacking), which nothing calls on a plot widget
        self.lower: list[pg.PlotCurveItem] = []  # type: ignore[assignment]
        self.current: list[pg.PlotCurveItem] = []
        self.toe_off_lines: list[pg.InfiniteLine] = []
        self._shown_strides = -1
        # the cycles are Kalman joint angles: the paper's Kalman green, band translucent
        band_colour = QColor(colours.kalman)
        band_colour.setAlpha(60)
        band_pen = pen(band_colour)
        cur_pen = pg.mkPen(colours.current, width=2)
        for j, (key, label, yr) in enumerate(JOINTS):
            p = self.addPlot(row=j, col=0)
            _style_plot(p, colours, f"{label} (deg)", yr, bottom=False)
            p.setMouseEnabled(x=False, y=False)
            p.setXRange(0, 100, padding=0)
            ax = p.getAxis("bottom")
            if j == len(JOINTS) - 1:
                ax.setStyle(showValues=True)
                ax.setHeight(None)
                ax.setLabel("gait cycle (% of stride, from heel strike)")
            p.setToolTip(
                f"{key.capitalize()} over the gait cycle in degrees: band = mean ± SD of the last "
                "strides, line = the current stride so far, dashed = mean toe off."
            )
            lower = pg.PlotCurveItem(pen=band_pen)
            upper = pg.PlotCurveItem(pen=band_pen)
            fill = pg.FillBetweenItem(lower, upper, brush=band_colour)
            mean = pg.PlotCurveItem(pen=pen(colours.kalman))
            cur = pg.PlotCurveItem(pen=cur_pen)
            toe = pg.InfiniteLine(pos=60, angle=90, pen=pen(colours.event, dashed=True))
            toe.setVisible(False)
            for item in (lower, upper, fill, mean, toe, cur):
                p.addItem(item)
            self.lower.append(lower)
            self.upper.append(upper)
            self.mean_curves.append(mean)
            self.current.append(cur)
            self.toe_off_lines.append(toe)

    def clear_data(self) -> None:
        self._shown_strides = -1
        for items in (self.lower, self.upper, self.mean_curves, self.current):
            for it in items:
                it.setData(np.empty(0), np.empty(0))
        for line in self.toe_off_lines:
            line.setVisible(False)

    def update_from(self, snap: Snapshot) -> None:
        g = snap.gait
        if g.n_strides != self._shown_strides:
            self._shown_strides = g.n_strides
            cyc = g.cycles_deg
            if len(cyc):
                # the sample SD, as in the review window and the report; one stride has none
                mean, sd = cycle_mean_sd(cyc)
                band = bool(np.isfinite(sd).all())
                for j in range(len(JOINTS)):
                    self.mean_curves[j].setData(self.pct, mean[:, j])
                    for curve, y in ((self.lower[j], -sd[:, j]), (self.upper[j], sd[:, j])):
                        if band:
                            curve.setData(self.pct, mean[:, j] + y)
                        else:
                            curve.setData(np.empty(0), np.empty(0))
            stance = g.last_stance_pct
            for line in self.toe_off_lines:
                ok = math.isfinite(stance)
                line.setVisible(ok)
                if ok:
                    line.setValue(stance)
        pct = g.current_pct
        if len(pct):
            keep = pct <= 100.0
            for j in range(len(JOINTS)):
                y = g.current_deg[keep, j]
                if np.isfinite(y).all():
                    self.current[j].setData(pct[keep], y, skipFiniteCheck=True)
                else:
                    self.current[j].setData(pct[keep], y, connect="finite")
        self.mark_new_data(float(time.monotonic()))


__all__ = [
    "CountingPlotWidget",
    "CyclePlots",
    "LivePlots",
    "RawPlots",
    "decimate_peak",
    "step_band",
    "vertical_lines",
]
