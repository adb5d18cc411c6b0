"""The live monitor's plots: segment tilts, joint angles, FSR with gait phases; raw sensors.

Fed from an engine `Snapshot` ~30 times a second through the primitives of :mod:`.traces`.
Lost data (the engine's ``lost`` rows, NaN) breaks every line and is shaded in the review's
red in every plot; it carries no phase band and no event. The filters' settling time after a
long gap (strides there are not counted) is shaded faintly in the same red. The drifting gyro
integration is drawn only where it is on scale (never as a vertical line where it wraps), and a
note in the plot says when it is off scale.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import pyqtgraph as pg
from PySide6.QtGui import QColor, QPainterPath
from PySide6.QtWidgets import QWidget

from gaitmon.dsp.channels import SEGMENTS
from gaitmon.engine import Snapshot
from gaitmon.engine.display import (
    DisplayFrame,
    DisplayRequest,
    PlotRequest,
    prepare_display,
)
from gaitmon.ui.plots.traces import (
    FSR_RANGE,
    JOINTS,
    METHODS,
    TILT_RANGES_DEG,
    CountingPlotWidget,
    Label,
    Trace,
    TraceSet,
    style_plot,
)
from gaitmon.ui.theme import Colours, pen

CONTACT_STRIP_PX = 110  # the FSR / gait-phase plot's height in the clinical view
SHADING_TIP = (
    "Red shading: data lost (link outage). Faint red: the filters settle after a gap; strides "
    "there are not counted."
)


@dataclass
class _PlotInfo:
    plot: pg.PlotItem
    yrange: tuple[float, float]
    traces: TraceSet
    events_hs: Trace | None = None
    events_to: Trace | None = None
    markers: Trace | None = None
    lost: Trace | None = None  # red shading where data was lost
    settling: Trace | None = None  # faint red: the filters settle after a gap
    gyro_note: Label | None = None  # "gyro integration off scale"
    tip: str = ""  # the plot's tooltip


class LivePlots(CountingPlotWidget):
    """Tilt of body/thigh/shank/foot (left), hip/knee/ankle and FSR + gait phase (right)."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.window_s = 10.0
        self.methods_on = {"acc": True, "kalman": True, "gyro": True}
        self.engineering = True  # False: the clinical view (see set_engineering)
        self.four_phases = True
        self.curves: list[Trace] = []  # the data traces (series, column, method)
        self.plots: dict[str, _PlotInfo] = {}
        self._bands: list[tuple[Trace, tuple[int, ...]]] = []
        self._marker_labels: list[tuple[Label, str]] = []
        self._no_fsr_text: pg.TextItem | None = None
        self.angle_method = ""  # what makes the Kalman traces, named in the column titles
        self._titles: list[tuple[pg.LabelItem, str]] = []
        self.threshold: Trace | None = None  # the FSR contact threshold, dashed
        self.fsr_threshold = 1000.0
        self._request: DisplayRequest | None = None  # what is shown (request())
        # the gyro-integration series and the plots of their columns (the off-scale notes)
        self._gyro_plots = (
            ("tilt_gyro_deg", tuple(SEGMENTS)),
            ("joint_gyro_deg", tuple(key for key, _label, _yr in JOINTS)),
        )
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
        p = self.addPlot(row=row, col=col, axisItems=self.axes())
        style_plot(p, self.colours, ylabel, yr, bottom=bottom)
        p.setToolTip(f"{tip} {SHADING_TIP}")
        ts = self.adopt(TraceSet((-self.window_s, 0.0), yr))
        p.addItem(ts)
        info = _PlotInfo(p, yr, ts, tip=f"{tip} {SHADING_TIP}")
        lost = QColor(self.colours.alert)
        lost.setAlpha(70)  # the review's gap shading
        info.lost = ts.add(Trace(brush=lost, fill_level=yr[0]))
        settling = QColor(self.colours.alert)
        settling.setAlpha(22)
        info.settling = ts.add(Trace(brush=settling, fill_level=yr[0]))
        self.plots[name] = info
        return info

    def _add_gyro_note(self, info: _PlotInfo) -> None:
        info.gyro_note = info.traces.add_label(self.colours.gyro, z=10.0)  # over the markers

    def _build(self) -> None:
        c = self.colours
        method_pen = {"acc": pen(c.acc), "kalman": pen(c.kalman), "gyro": pen(c.gyro)}
        for col, title in enumerate(("Segment tilt", "Joint angles and foot contact")):
            label = self.addLabel(title, row=0, col=col, size="9pt", bold=True)
            self._titles.append((label, title))
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
            self._add_gyro_note(info)
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
            self._add_gyro_note(info)
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
        # over the traces and the bands, as a line item of the plot would be
        self.threshold = info.traces.add(Trace(pen(c.event, dashed=True)))
        p = info.plot
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
        self._changed()
        for info in self.plots.values():
            info.plot.setXRange(-self.window_s, 0.0, padding=0)
            info.traces.nominal[0] = (-self.window_s, 0.0)
            if info.gyro_note is not None:
                info.gyro_note.x, info.gyro_note.y = -self.window_s, info.yrange[1]
        if self._no_fsr_text is not None:
            self._no_fsr_text.setPos(-self.window_s / 2, sum(FSR_RANGE) / 2)
        self._draw_threshold()

    def set_angle_method(self, label: str) -> None:
        """Name what makes the Kalman (green) traces in the column titles ("" names none)."""
        if label == self.angle_method:
            return
        self.angle_method = label
        green = self.colours.kalman.name()
        for item, title in self._titles:
            kalman = f" · <span style='color:{green}'>■</span> {label}" if label else ""
            item.setText(title + kalman, size="9pt", bold=True)

    def title_text(self, column: int) -> str:
        """A column title as shown, without markup (what the tests look at)."""
        plain = re.sub(r"<[^>]+>", "", self._titles[column][0].text).replace("■", "")
        return " ".join(plain.split())

    def set_method(self, method: str, on: bool) -> None:
        self.methods_on[method] = bool(on)
        self._set_trace_visibility()

    def set_engineering(self, on: bool) -> None:
        """The engineering view (all three methods, the segment tilts, full-height FSR) or the
        clinical one: the joint angles of the chosen filter only (green), large, above a
        compact foot-contact strip. ``methods_on`` is kept for when engineering returns."""
        self.engineering = bool(on)
        for name in SEGMENTS:
            self.plots[name].plot.setVisible(self.engineering)
        self._titles[0][0].setVisible(self.engineering)
        fsr = self.plots["fsr"].plot
        row = len(JOINTS) + 1
        height = 1e6 if self.engineering else CONTACT_STRIP_PX  # the rows above get the rest
        fsr.setMaximumHeight(height)
        self.ci.layout.setRowMaximumHeight(row, height)
        left = fsr.getAxis("left")
        left.setLabel("FSR (ADC counts)" if self.engineering else "contact")
        left.setStyle(showValues=self.engineering)
        self._set_trace_visibility()

    def shown_plots(self) -> list[str]:
        """The plots the view shows (what the tests look at)."""
        return [name for name, info in self.plots.items() if info.plot.isVisible()]

    def _set_trace_visibility(self) -> None:
        for tr in self.curves:
            if tr.method:
                clinical = tr.method == "kalman" and tr.series.startswith("joint_")
                tr.visible = self.methods_on[tr.method] if self.engineering else clinical
        self._changed()
        self._commit()

    def set_four_phases(self, four: bool) -> None:
        self.four_phases = bool(four)
        self._set_phase_visibility()
        self._commit()

    def _set_phase_visibility(self) -> None:
        for tr, phases in self._bands:
            tr.visible = (len(phases) == 1) == self.four_phases
        self._changed()

    def set_fsr_threshold(self, counts: float) -> None:
        self.fsr_threshold = float(counts)
        self._draw_threshold()
        info = self.plots["fsr"]
        info.plot.setToolTip(
            f"{info.tip} Dashed line: contact threshold, {counts:g} counts (Settings)."
        )
        info.traces.commit()

    def _draw_threshold(self) -> None:
        if self.threshold is not None:
            c = self.fsr_threshold
            self.threshold.set(np.array([-self.window_s, 0.0]), np.array([c, c]))

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
        for label, _ in self._marker_labels:
            label.hide()
        self._draw_threshold()
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

    def request(self) -> DisplayRequest:
        """What this view shows, for :func:`prepare_display` (kept until an option changes)."""
        if self._request is None:
            shown = {name for name, info in self.plots.items() if info.plot.isVisible()}
            series = tuple(dict.fromkeys(tr.series for tr in self.curves if tr.visible))
            gyro_on = self.methods_on.get("gyro", True) and self.engineering
            self._request = DisplayRequest(
                window_s=self.window_s,
                series=series,
                plots=tuple(PlotRequest(name, info.yrange, info.events_hs is not None)
                            for name, info in self.plots.items() if name in shown),
                gyro=tuple((name, tuple(self.plots[p].yrange for p in plots))
                           for name, plots in self._gyro_plots if gyro_on),
                bands=tuple(phases for tr, phases in self._bands if tr.visible),
                band_range=FSR_RANGE,
            )  # fmt: skip
        return self._request

    def _changed(self) -> None:
        self._request = None

    def update_from(self, snap: Snapshot) -> None:
        """Prepare and show ``snap`` here (the GUI thread): what the window does only when no
        frame comes from the engine thread (the display paused, tests)."""
        self.show_frame(prepare_display(snap, self.request()))

    def show_frame(self, frame: DisplayFrame) -> None:
        """Hand a prepared frame's arrays to the traces (no numpy work on whole series here)."""
        if frame.empty:
            return
        for tr in self.curves:
            if not tr.visible:
                continue
            got = frame.curves.get(tr.series)
            if got is not None and got.any_finite[tr.column]:
                tr.set(got.x, got.y[:, tr.column], bool(got.all_finite[tr.column]))
            else:  # all NaN, or a frame prepared before this trace was shown
                tr.clear()
        for series, names in self._gyro_plots:
            last_off = frame.gyro_off.get(series)
            for j, name in enumerate(names):
                note = self.plots[name].gyro_note
                if note is None:
                    continue
                if last_off is not None and np.isfinite(last_off[j]):
                    note.set(f"gyro integration off scale ({last_off[j]:+.0f}°)", note.x, note.y)
                else:
                    note.hide()
        bands = dict(zip(frame.request.bands, frame.bands, strict=True))
        for tr, phases in self._bands:
            band = bands.get(phases)
            if tr.visible and band is not None:
                tr.set(*band)
        for name, info in self.plots.items():
            pf = frame.plots.get(name)
            if pf is None:  # not shown: drawn again when it is
                continue
            for trace, xy in ((info.lost, pf.lost), (info.settling, pf.settling)):
                if trace is not None:
                    if xy is not None:
                        trace.set(*xy)
                    else:
                        trace.clear()
            for trace, xy in ((info.events_hs, pf.heel_strikes), (info.events_to, pf.toe_offs),
                              (info.markers, pf.markers)):  # fmt: skip
                if trace is not None and xy is not None:
                    trace.set(*xy, connect="pairs")
            info.traces.commit()
        self._update_marker_labels(frame.snap.markers, frame.t_now)
        if self._no_fsr_text is not None and self._no_fsr_text.isVisible() != frame.fsr_missing:
            self._no_fsr_text.setVisible(frame.fsr_missing)
        self.mark_new_data(frame.newest_idx)

    def gyro_note(self, plot: str) -> str:
        """The off-scale note shown on ``plot`` ("" when none): what the tests look at."""
        note = self.plots[plot].gyro_note
        return note.text if note is not None and note.visible else ""

    def marker_labels(self) -> list[str]:
        """The marker labels shown now, oldest first (one per column: each twice)."""
        return [label.text for label, _ in self._marker_labels if label.visible]

    def lost_path(self, plot: str) -> QPainterPath | None:
        info = self.plots[plot]
        return None if info.lost is None else info.lost.path

    def band_paths(self) -> list[QPainterPath]:
        """The gait-phase shading drawn now (visible bands only)."""
        return [tr.path for tr, _ in self._bands if tr.visible and tr.path is not None]

    def _update_marker_labels(self, markers: Iterable[tuple[float, str]], t_now: float) -> None:
        shown = [(t - t_now, label) for t, label in markers if t - t_now >= -self.window_s]
        need = 2 * len(shown)  # one label on the top plot of each column
        while len(self._marker_labels) < need:
            name = "body" if len(self._marker_labels) % 2 == 0 else "hip"
            item = self.plots[name].traces.add_label(self.colours.marker)
            self._marker_labels.append((item, name))
        for i, (item, name) in enumerate(self._marker_labels):
            k = i // 2
            if k < len(shown):
                x, label = shown[k]
                # ending by "now" (the right edge): one dropped a moment ago is drawn whole
                item.set(label or "marker", x, self.plots[name].yrange[1], right=0.0)
            else:
                item.hide()


class RawPlots(CountingPlotWidget):
    """Optional: low-passed accelerometer x/z and gyro rate per segment."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.colours = colours
        self.curves: list[Trace] = []
        self.window_s = 10.0
        self.acc_plot = self.addPlot(row=0, col=0)
        style_plot(self.acc_plot, colours, "acceleration (m/s²)", (-25, 30), bottom=False)
        self.acc_plot.setToolTip(
            "Low-passed accelerometer per segment in m/s² (solid: x along the segment, "
            "faint: z forward). Raw-frame mode only."
        )
        self.gyro_plot = self.addPlot(row=1, col=0)
        style_plot(self.gyro_plot, colours, "gyro rate (rad/s)", (-9, 9), bottom=True)
        self.gyro_plot.setToolTip("Gyro rate per segment in rad/s (bias removed after Zero).")
        self.acc_traces = TraceSet((-self.window_s, 0.0), (-25, 30))
        self.gyro_traces = TraceSet((-self.window_s, 0.0), (-9, 9))
        # painted through the scene (not layered): its legend lies over the traces
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
        self.show_frame(prepare_display(snap, DisplayRequest(series=(), raw=True)))

    def show_frame(self, frame: DisplayFrame) -> None:
        """Hand a prepared frame's raw-sensor arrays (``DisplayRequest.raw``) to the traces."""
        if frame.empty:
            return
        if not frame.raw:  # prepared while this dock was hidden
            self.update_from(frame.snap)
            return
        for tr in self.curves:
            got = frame.raw[tr.series]
            if got.any_finite[tr.column]:
                tr.set(got.x, got.y[:, tr.column], bool(got.all_finite[tr.column]))
            else:
                tr.clear()
        self.acc_traces.commit()
        self.gyro_traces.commit()
        self.mark_new_data(frame.newest_idx)
