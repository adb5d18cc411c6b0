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
from gaitmon.ui.plots.traces import (
    FSR_RANGE,
    JOINTS,
    MAX_POINTS,
    METHODS,
    TILT_RANGES_DEG,
    CountingPlotWidget,
    Label,
    Trace,
    TraceSet,
    decimate_peak,
    newest_idx,
    on_scale,
    step_band,
    style_plot,
    vertical_lines,
)
from gaitmon.ui.theme import Colours, pen

CONTACT_STRIP_PX = 110  # the FSR / gait-phase plot's height in the clinical view
STALE_S = 0.3  # no new data for longer than this: the link is down, time runs on
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
        self._commit()

    def set_four_phases(self, four: bool) -> None:
        self.four_phases = bool(four)
        self._set_phase_visibility()
        self._commit()

    def _set_phase_visibility(self) -> None:
        for tr, phases in self._bands:
            tr.visible = (len(phases) == 1) == self.four_phases

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

    def update_from(self, snap: Snapshot) -> None:
        s = snap.series
        t = s["t_s"]
        if len(t) == 0:
            return
        # while no data arrives (a cut link) the traces keep scrolling with the clock and the
        # time without data is shaded as lost, instead of freezing as if nothing had happened
        stale_s = snap.last_data_age_s if snap.last_data_age_s > STALE_S else 0.0
        t_now = float(t[-1]) + stale_s
        x_full = t - t_now
        gyro_off = self._gyro_on_scale(s)
        cache: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
        for tr in self.curves:
            if not tr.visible:
                continue
            got = cache.get(tr.series)
            if got is None:
                x, y = decimate_peak(x_full, gyro_off.get(tr.series, s[tr.series]), MAX_POINTS)
                fin = np.isfinite(y)
                got = (x, y, fin.all(axis=0), fin.any(axis=0))
                cache[tr.series] = got
            x, y, all_finite, any_finite = got
            if any_finite[tr.column]:
                tr.set(x, y[:, tr.column], bool(all_finite[tr.column]))
            else:
                tr.clear()

        self._update_phases(x_full, s["phase"])
        lost = s["lost"] > 0
        x_lost = x_full
        if stale_s:
            x_lost = np.append(x_full, [x_full[-1] + 1e-6, 0.0])
            lost = np.append(lost, [True, True])
        settling = s["settling"] > 0
        for info in self.plots.values():
            lo, hi = info.yrange
            shades: tuple[tuple[Trace | None, np.ndarray, np.ndarray], ...] = (
                (info.lost, x_lost, lost),
                (info.settling, x_full, settling),
            )
            for shade, xb, mask in shades:
                if shade is not None:
                    if mask.any():
                        shade.set(*step_band(xb, mask, hi, lo))
                    else:
                        shade.clear()
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
        self.mark_new_data(newest_idx(s))

    def _gyro_on_scale(self, s: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The gyro-integration series as drawn (see :func:`on_scale`), and each plot's note."""
        out: dict[str, np.ndarray] = {}
        on = self.methods_on.get("gyro", True) and self.engineering
        for series, names in (
            ("tilt_gyro_deg", list(SEGMENTS)),
            ("joint_gyro_deg", [key for key, _label, _yr in JOINTS]),
        ):
            y, last_off = on_scale(s[series], [self.plots[n].yrange for n in names])
            out[series] = y
            for j, name in enumerate(names):
                note = self.plots[name].gyro_note
                if note is None:
                    continue
                show = on and bool(np.isfinite(last_off[j]))
                if show:
                    note.set(f"gyro integration off scale ({last_off[j]:+.0f}°)", note.x, note.y)
                else:
                    note.hide()
        return out

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
        self.mark_new_data(newest_idx(s))
