"""How the review timeline's plots are built: the whole-session overview strip and the detail
lanes (hip, knee, ankle, segment tilt, foot sensors, raw counts), each with its traces, shading
and cursor line (:func:`build_plots`); the :class:`~gaitmon.ui.review.timeline.Timeline` that
owns them connects them to its slots."""

from __future__ import annotations

from dataclasses import dataclass, field

import pyqtgraph as pg
from PySide6.QtGui import QColor

from gaitmon.dsp.channels import CHANNELS, SEGMENTS
from gaitmon.dsp.gait import PHASE_NAMES
from gaitmon.review.model import JOINT
from gaitmon.ui.plots import FSR_RANGE, JOINTS, TILT_RANGES_DEG, Trace, TraceSet
from gaitmon.ui.review.lanes import Lane, LaneLegend, TraceSpec, lane_plot, line_pen
from gaitmon.ui.review.overview_plot import OverviewPlot
from gaitmon.ui.theme import Colours, pen

RAW_RANGE = (-100.0, 4200.0)
# the legend's names of the comparison traces (the drifting one says so: never read as a
# measurement); "{method}" is the angles' method, "{segment}" the segment drawn
GYRO_LABEL = "gyro integration (°), drifts: not a measurement"
RECORDED_LABEL = "recorded, before reprocessing"


@dataclass
class Plots:
    """The plots of one timeline, as built (not yet connected)."""

    glw: pg.GraphicsLayoutWidget
    colours: Colours
    lanes: dict[str, Lane] = field(default_factory=dict)  # x-linked, in order from the top
    strip: OverviewPlot | None = None
    overview_cursor: pg.InfiniteLine | None = None
    threshold_line: pg.InfiniteLine | None = None  # the FSR lane's contact threshold


def _plot(tl: Plots, row: int) -> pg.PlotItem:
    p = lane_plot(tl.colours)
    tl.glw.addItem(p, row=row, col=0)
    return p


def _lane(tl: Plots, key: str, title: str, yrange: tuple[float, float], tip: str) -> Lane:
    row = len(tl.lanes) + 1
    p = _plot(tl, row)
    p.setMouseEnabled(x=True, y=False)
    p.setYRange(*yrange, padding=0)
    p.getAxis("left").setLabel(title)
    p.setToolTip(tip)
    ts = TraceSet((0.0, 1.0), yrange)
    lane = Lane(key, title, yrange, p, ts)
    p.addItem(lane.shade, ignoreBounds=True)
    p.addItem(ts, ignoreBounds=True)
    if tl.lanes:
        p.setXLink(next(iter(tl.lanes.values())).plot)
    lane.cursor = cursor_line(tl, p)
    tl.lanes[key] = lane
    return lane


def cursor_line(tl: Plots, p: pg.PlotItem) -> pg.InfiniteLine:
    line = pg.InfiniteLine(
        pos=0.0, angle=90, movable=True, pen=pg.mkPen(tl.colours.current, width=1)
    )
    line.setHoverPen(pg.mkPen(tl.colours.marker, width=2))
    line.setZValue(20)
    line.setVisible(False)
    p.addItem(line, ignoreBounds=True)
    return line


def _add(tl: Plots, lane: Lane, spec: TraceSpec, dashed: bool = False) -> None:
    spec.dashed = dashed
    colour = QColor(spec.colour)
    if spec.before:
        colour = QColor(tl.colours.foreground)
        colour.setAlpha(110)
    tr = lane.traces.add(Trace(line_pen(colour, dashed=dashed), series=spec.series,
                               column=spec.column, method=spec.method))  # fmt: skip
    lane.specs.append((spec, tr))


def build_plots(glw: pg.GraphicsLayoutWidget, colours: Colours) -> Plots:
    """The overview strip (row 0 of ``glw``) and the lanes under it."""
    tl = Plots(glw, colours)
    c = tl.colours
    # overview: the knee over the whole session, the detail range as a draggable region
    tl.strip = OverviewPlot(_plot(tl, 0), c)
    tl.overview_cursor = cursor_line(tl, tl.strip.plot)

    for j, (key, _label, yr) in enumerate(JOINTS):
        sign = "dorsiflexion" if key == "ankle" else "flexion"
        lane = _lane(tl,
            key, f"{key} (°)", yr,
            f"{key.capitalize()} angle, {sign} positive (clinical convention). Green: Kalman; "
            "red/blue (View menu): accelerometer / gyro integration. Grey lines: heel strike "
            "(solid) and toe off (dashed).",
        )  # fmt: skip
        lane.events_hs = lane.traces.add(Trace(line_pen(c.event)))
        lane.events_to = lane.traces.add(Trace(line_pen(c.event, dashed=True)))
        _add(tl, lane, TraceSpec(JOINT, j, c.kalman, before=True,
                                 label=f"{key} (°), {RECORDED_LABEL}"), dashed=True)
        _add(tl, lane, TraceSpec("processed/joint_gyro_deg", j, c.gyro, "gyro",
                                 label=GYRO_LABEL, reference=True))
        _add(tl, lane, TraceSpec("processed/joint_acc_deg", j, c.acc, "acc",
                                 label="accelerometer (°)", reference=True))
        _add(tl, lane, TraceSpec(JOINT, j, c.kalman, "kalman", label=f"{key} (°), {{method}}"))
        lane.markers = lane.traces.add(Trace(line_pen(c.marker)))
    lane = _lane(tl,
        "tilt", "thigh tilt (°)", TILT_RANGES_DEG["thigh"],
        "Segment tilt (choose the segment above): green the angles' method, red accelerometer, "
        "blue gyro integration (the papers' colours). The y range is the green tilt's: the gyro "
        "integration drifts (a reference, not a measurement) and is clipped at the edges.",
    )  # fmt: skip
    _add(tl, lane, TraceSpec("processed/tilt_deg", 1, c.kalman, before=True,
                             label=f"{{segment}} tilt (°), {RECORDED_LABEL}"), dashed=True)
    _add(tl, lane, TraceSpec("processed/tilt_gyro_deg", 1, c.gyro, label=GYRO_LABEL,
                             reference=True))
    _add(tl, lane, TraceSpec("processed/tilt_acc_deg", 1, c.acc,
                             label="accelerometer tilt (°)", reference=True))
    _add(tl, lane, TraceSpec("processed/tilt_deg", 1, c.kalman,
                             label="{segment} tilt (°), {method}"))
    lane.markers = lane.traces.add(Trace(line_pen(c.marker)))
    lane = _lane(tl,
        "fsr", "FSR (counts)", FSR_RANGE,
        "Foot sensors (low-passed ADC counts): heel red, toe green. Shading: gait phase "
        f"({', '.join(PHASE_NAMES[1:])}); lines: heel strike (red) and toe off (green).",
    )  # fmt: skip
    for k, colour in enumerate(c.phases, start=1):
        lane.bands.append((lane.traces.add(Trace(brush=colour, fill_level=FSR_RANGE[0])), k))
    lane.band_names = PHASE_NAMES[1:]
    lane.events_hs = lane.traces.add(Trace(line_pen(c.heel)))
    lane.events_to = lane.traces.add(Trace(line_pen(c.toe, dashed=True)))
    for k, (name, colour) in enumerate((("heel", c.heel), ("toe", c.toe))):
        _add(tl, lane, TraceSpec("processed/fsr_counts", k, colour, before=True,
                                 label=f"{name} (counts), {RECORDED_LABEL}"), dashed=True)
    for k, (name, colour) in enumerate((("heel", c.heel), ("toe", c.toe))):
        _add(tl, lane, TraceSpec("processed/fsr_counts", k, colour, label=f"{name} (counts)"))
    lane.extra_legend.append((c.event, "╌╌", "contact threshold (counts)"))
    lane.markers = lane.traces.add(Trace(line_pen(c.marker)))
    tl.threshold_line = pg.InfiniteLine(
        pos=1000.0, angle=0, pen=pen(c.event, dashed=True), movable=False
    )
    lane.plot.addItem(tl.threshold_line, ignoreBounds=True)
    lane = _lane(tl,
        "raw", "raw (counts)", RAW_RANGE,
        "Raw ADC counts of the 14 channels (12 bit), coloured by segment; accelerometer x "
        "solid, z faint, gyro darker; heel red, toe green.",
    )  # fmt: skip
    for ch in CHANNELS:
        if ch.segment in SEGMENTS:
            col = QColor(c.segments[SEGMENTS.index(ch.segment)])
            col.setAlpha({"acc_x": 255, "acc_z": 110, "gyro": 190}.get(ch.kind, 255))
        else:
            col = c.heel if ch.segment == "heel" else c.toe
        # one entry a segment (its accelerometer x colour): the kinds are in the tooltip
        label = f"{ch.segment} (counts)" if ch.kind in ("acc_x", "fsr") else ""
        _add(tl, lane, TraceSpec("raw/adc", ch.index, col, label=label))
    lane.markers = lane.traces.add(Trace(line_pen(c.marker)))
    for lane in tl.lanes.values():
        lane.missing = pg.TextItem("", color=c.foreground, anchor=(0.5, 0.5))
        lane.missing.setVisible(False)
        lane.plot.addItem(lane.missing, ignoreBounds=True)
        lane.legend = LaneLegend(lane.plot.getViewBox(), c)
    return tl
