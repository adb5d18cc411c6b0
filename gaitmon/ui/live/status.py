"""What one snapshot says, shown: the status bar, the link banner, recording status, gait panel.

:class:`StatusView` owns the status bar's permanent labels (link state pill, link health,
recording, zeroing, the tilt filter in force, samples) and the three banners above the plots
(link, recorder, force sensors); the grading itself is Qt-free in :mod:`gaitmon.live.health`.
:class:`GaitPanel` is the gait dock's content: cadence, stride, stance, stride count, where the
gait events come from and the gait-cycle plots. Both only display; what to do
about a snapshot (stop a recording the recorder gave up on) is the window's business.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QGridLayout, QLabel, QStatusBar, QVBoxLayout, QWidget

from gaitmon.engine import RecordingStatus, Snapshot
from gaitmon.engine.live_gait import RecordingStart
from gaitmon.engine.snapshot import EVENTS_FSR, EVENTS_GYRO, EVENTS_UNIT, FsrFaultNotice
from gaitmon.live.health import (
    Health,
    HealthTracker,
    no_data_text,
    snapshot_health,
    snapshot_link_view,
)
from gaitmon.text import count, no_gait_events
from gaitmon.ui.live.bar import FittingLabel
from gaitmon.ui.plots import CyclePlots
from gaitmon.ui.theme import Colours


def fmt_bytes(n: int) -> str:
    if n < 1_000_000:
        return f"{n / 1000:.0f} kB"
    if n < 1_000_000_000:
        return f"{n / 1e6:.1f} MB"
    return f"{n / 1e9:.2f} GB"


def fmt_elapsed(s: float) -> str:
    s = max(0, int(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m:02d}:{sec:02d}"


def angles_text(snap: Snapshot) -> str:
    """"angles: M · zero: Z": what made a unit's angles and where their zero comes from
    (gaitmon.dsp.calibration.zero_source, in the engine's snapshot), as the status bar and
    each leg of the both-legs view show it ("" before the engine says)."""
    text = f"angles: {snap.angle_method}" if snap.angle_method else ""
    if text and snap.zero_source:
        text += f" · zero: {snap.zero_source}"
    return text


def angles_texts(snap: Snapshot) -> tuple[str, ...]:
    """:func:`angles_text`, then shorter for a narrow status bar (the zero's source first)."""
    full = angles_text(snap)
    if not snap.zero_source:
        return (full,)
    short = snap.zero_source.split(" (")[0]
    return full, f"zero: {snap.zero_source}", f"zero: {short}", short


def rec_texts(rec: RecordingStatus, fs_hz: float, dot: str, what: str = "") -> tuple[str, ...]:
    """The REC line, from the most said to the least: the time since Record and the file.
    No file size: the HDF5 file grows in steps at its flushes (60 kB at 28 s, 279 kB at
    Stop), while every frame is in the journal at once; the tooltip says how much is saved
    (:func:`rec_tooltip`)."""
    rec_dot = f"<span style='color:{dot}'>●</span> REC"
    if what:
        rec_dot += f" {what}"
    t = fmt_elapsed(rec.elapsed_s)
    # the frames (not the engine's blocks, of any size) the recorder refused, and why
    lost = (f" · {count(rec.dropped_frames, 'frame')} NOT saved (recorder queue full)"
            if rec.dropped_frames else "")  # fmt: skip
    return (f"{rec_dot} {t} · {Path(rec.path).name}{lost}", f"{rec_dot} {t}{lost}")


def rec_tooltip(rec: RecordingStatus, fs_hz: float) -> str:
    """What is safely recorded: the frames the recorder has written (journal and file)."""
    saved = rec.rows / fs_hz if fs_hz > 0 else 0.0
    return (f"Recording into {rec.path}\n{fmt_elapsed(rec.elapsed_s)} since Record; "
            f"{rec.rows:,} frames ({saved:.1f} s of data) saved: a crash loses none of "
            "them")  # fmt: skip


def show_health(label: QLabel, h: Health, colours: Colours, text: str) -> None:
    """A link's health in ``label``: ``text``, coloured by its grade, the details in the
    tooltip (one unit's status bar, or one leg's header)."""
    if label.property("grade") != h.grade:  # re-styling is not free
        colour = {"ok": "palette(window-text)", "lossy": colours.warn}.get(h.grade, colours.alert)
        weight = "normal" if h.grade == "ok" else "bold"
        label.setStyleSheet(f"color: {colour}; font-weight: {weight}")
        label.setProperty("grade", h.grade)
    if isinstance(label, FittingLabel):  # narrow: its last figures go first
        parts = text.split(" · ")
        label.set_texts(*(" · ".join(parts[:k]) for k in range(len(parts), 0, -1)),
                        tooltip=h.tooltip)  # fmt: skip
        return
    if label.text() != text:
        label.setText(text)
    label.setToolTip(h.tooltip)


def banner_style(colours: Colours, grade: str) -> str:
    colour = {"ok": colours.ok, "warn": colours.warn}.get(grade, colours.alert)
    return f"background: {colour}; color: white; padding: 4px 8px; border-radius: 3px;"


class StatusView:
    """The status bar's labels and the banners; ``colours`` follows the theme."""

    def __init__(self, status_bar: QStatusBar, colours: Colours) -> None:
        self.colours = colours
        self.health = HealthTracker()
        self.link_banner = QLabel()
        self.link_banner.setWordWrap(True)
        self.link_banner.setVisible(False)
        self.link_banner.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.record_banner = QLabel()
        self.record_banner.setWordWrap(True)
        self.record_banner.setVisible(False)
        self.record_banner.setStyleSheet(banner_style(colours, "alert"))
        self.fsr_banner = QLabel()  # a force sensor found faulty: stays for the connection
        self.fsr_banner.setWordWrap(True)
        self.fsr_banner.setVisible(False)
        self.fsr_banner.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.fsr_banner.setStyleSheet(banner_style(colours, "warn"))
        self._fsr_shown: tuple[FsrFaultNotice, ...] = ()

        self.state_label = QLabel()
        self.state_label.setToolTip("Link state")
        # the permanent labels shorten, word by word, in a narrow window (ui/live/bar.py); where
        # the angles' zero comes from is said once, by the method label ("zero: ...")
        self.health_label = FittingLabel()
        self.rec_label = FittingLabel(
            "Recording: the time since Record, the file; every frame received is in its "
            "journal at once, so a crash loses none"
        )
        self.samples_label = FittingLabel("Samples received since connecting")
        self.method_label = FittingLabel(
            "What makes the Kalman (green) angles: the PC's tilt filter (Device ▸ Tilt filter) "
            "or, in the unit's modes, the unit's own; where their zero comes from (Zero, Ctrl+0)"
        )
        for w in (self.rec_label, self.method_label, self.health_label, self.samples_label):
            status_bar.addPermanentWidget(w)
        status_bar.addPermanentWidget(self.state_label)
        self.set_state_pill("Disconnected", "ok")

    @property
    def state_text(self) -> str:
        return str(self.state_label.property("state_text") or "")

    def set_state_pill(self, text: str, grade: str) -> None:
        c = self.colours
        colour = {"ok": c.ok, "warn": c.warn}.get(grade, c.alert)
        if text == "Disconnected":
            colour = "gray"
        self.state_label.setText(f"<span style='color:{colour}'>●</span> {text}")
        self.state_label.setProperty("state_text", text)

    def connected(self) -> None:
        """A new connection: link health and the force-sensor check start from scratch."""
        self.health.reset()
        self._show_fsr_faults(())

    def disconnected(self) -> None:
        self.link_banner.setVisible(False)
        self._show_fsr_faults(())
        self.method_label.set_texts("")
        self.set_state_pill("Disconnected", "ok")
        self.health_label.set_texts("")
        self.rec_label.set_texts("")

    def show_banner(self, text: str, grade: str, tip: str) -> None:
        """The link banner as given (both legs: a line per leg; "": hidden)."""
        banner = self.link_banner
        if not text:
            if banner.isVisible():
                banner.setVisible(False)
            return
        if banner.text() != text:
            banner.setText(text)
        banner.setToolTip(tip)
        if banner.property("grade") != grade:
            banner.setStyleSheet(banner_style(self.colours, grade))
            banner.setProperty("grade", grade)
        banner.setVisible(True)

    def show_link(self, snap: Snapshot, port: str) -> None:
        """Link state, health, sample count and zeroing of one snapshot (``port``: as named in
        the banner)."""
        view = snapshot_link_view(snap, port)
        self.show_banner(view.banner, view.grade, view.tooltip)
        self.set_state_pill(view.pill, view.grade)
        self.state_label.setToolTip(view.tooltip or "Link state")

        h = snapshot_health(self.health, snap, time.monotonic())
        if h is not None:
            show_health(self.health_label, h, self.colours, h.text)
        self.samples_label.set_texts(f"{snap.samples_total:,} samples", f"{snap.samples_total:,}")
        self.samples_label.setProperty("samples", snap.samples_total)

    def show_checks(self, snap: Snapshot) -> None:
        """The tilt filter in force and the force sensors found faulty (kept until the next
        connection: a sensor does not mend itself)."""
        self.method_label.set_texts(*angles_texts(snap))
        if snap.fsr_faults != self._fsr_shown:
            self._show_fsr_faults(snap.fsr_faults)

    def _show_fsr_faults(self, faults: tuple[FsrFaultNotice, ...]) -> None:
        self._fsr_shown = faults
        if not faults:
            self.fsr_banner.setVisible(False)
            self.fsr_banner.setText("")
            return
        lines = [
            f"⚠ {f.message[0].upper()}{f.message[1:]} (found {fmt_elapsed(f.t_s)} after connecting)"
            for f in faults
        ]
        self.fsr_banner.setText("<br>".join(lines))
        self.fsr_banner.setStyleSheet(banner_style(self.colours, "warn"))  # theme may change
        self.fsr_banner.setToolTip(
            "Each force sensor is checked against the strides the foot gyro sees; three failing "
            "strides in a row flag it. Heel strikes, toe offs and strides then come from the "
            "foot gyro. Check the sensor and its cable; the flag stays until you reconnect."
        )
        self.fsr_banner.setVisible(True)

    def show_recording(self, rec: RecordingStatus, fs_hz: float, what: str = "") -> None:
        """The running recording (``what``: "both legs" or ""): its time and file, and the
        blocks the recorder could not keep (:func:`rec_texts`)."""
        self.rec_label.set_texts(*rec_texts(rec, fs_hz, self.colours.alert, what),
                                 tooltip=rec_tooltip(rec, fs_hz))  # fmt: skip

    def show_recorder_stopped(self, message: str) -> None:
        self.record_banner.setText(message)
        self.record_banner.setVisible(True)
        self.rec_label.set_texts("")


GAIT_ROWS = (
    ("cadence", "Cadence (derived)", "steps/min: 120 / mean stride time of the last "
     "strides. Derived: one unit measures one leg."),
    ("speed", "Gait speed", "m/s: stride length / stride time, mean of the last strides; "
     "stride length from the foot IMU (straight, level walking assumed)"),
    ("stride", "Last stride", "time from one heel strike to the next (s)"),
    ("stance", "Stance", "stance time as % of the last stride (normal ≈ 60 %)"),
    ("strides", "Strides", "strides completed: while recording, those of this recording (as "
     "its file has them, counted or not: info and review leave out its first and last "
     "strides and those at gaps); otherwise since connecting"),
)  # fmt: skip
STALE_STRIDES = 2.0  # no stride completed for this many mean stride times: the figures are old
STALE_KEYS = ("cadence", "speed", "stride", "stance")  # greyed when stale


def value_rows(
    grid: QGridLayout, rows: tuple[tuple[str, str, str], ...] | list[tuple[str, str, str]],
    widget: QWidget, *, scale: float,
) -> dict[str, QLabel]:  # fmt: skip
    """A name / large bold value row per ``(key, label, tooltip)`` in ``grid``; the value
    labels by key (they show "—" until set)."""
    grid.setHorizontalSpacing(10)
    big = widget.font()
    big.setPointSizeF(big.pointSizeF() * scale)
    big.setBold(True)
    values: dict[str, QLabel] = {}
    for r, (key, label, tip) in enumerate(rows):
        name = QLabel(label)
        name.setToolTip(tip)
        # a narrow window (854 px) wraps "Strides (this recording)" rather than cut it or the
        # figure beside it (the values keep their one line)
        name.setWordWrap(True)
        value = QLabel("—")
        value.setFont(big)
        value.setToolTip(tip)
        value.setAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
        grid.addWidget(name, r, 0)
        grid.addWidget(value, r, 1)
        values[key] = value
    return values


class GaitPanel(QWidget):
    """The gait dock: the latest stride's figures and the mean ± SD gait cycle."""

    def __init__(self, colours: Colours, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._colours = colours
        g = QVBoxLayout(self)
        g.setContentsMargins(4, 4, 4, 4)
        grid = QGridLayout()
        self.values = value_rows(grid, GAIT_ROWS, self, scale=1.5)
        g.addLayout(grid)
        row = [k for k, _label, _tip in GAIT_ROWS].index("strides")
        item = grid.itemAtPosition(row, 0)
        name = item.widget() if item is not None else None
        assert isinstance(name, QLabel)
        self.strides_name = name  # "Strides (this recording)" / "(since connect)"
        self.stale_label = QLabel()  # "stale: last stride 12 s ago"
        self.stale_label.setWordWrap(True)
        self.stale_label.setToolTip(
            "Cadence, speed, the last stride and stance are the last strides' figures: greyed "
            f"when no stride has completed for {STALE_STRIDES:g} stride times (standing) or no "
            "data arrives (link down)"
        )
        self.stale_label.setVisible(False)
        g.addWidget(self.stale_label)
        # set on each connect (the window's): where the running recording began
        self.recording_start: RecordingStart | None = None
        self.events_label = QLabel()  # where the gait events come from
        self.events_label.setWordWrap(True)
        self.events_label.setToolTip(
            "Heel strikes and toe offs come from the force sensors (FSR) unless one is found "
            "faulty: then from the foot gyro"
        )
        g.addWidget(self.events_label)
        self._events_source: str | None = None
        self.cycle_title = QLabel("Gait cycle: mean ± SD of the last strides, current stride")
        self.cycle_title.setWordWrap(True)
        g.addWidget(self.cycle_title)
        self.cycles = CyclePlots(colours)
        self.cycles.setMinimumHeight(300)
        g.addWidget(self.cycles, 1)
        self._layout = g
        self._shown_strides = -1

    def clear(self) -> None:
        self._shown_strides = -1
        self.stale_label.setText("")
        self.stale_label.setVisible(False)
        for key in STALE_KEYS:
            self.values[key].setEnabled(True)
        self._events_source = None
        self.events_label.setText("")
        self.cycles.clear_data()

    def _show_event_source(self, source: str) -> None:
        text = {
            EVENTS_FSR: "Gait events: force sensors",
            EVENTS_GYRO: "⚠ Gait events: foot gyro (sensor fault)",
            EVENTS_UNIT: "Gait events: the unit's foot contacts",
        }.get(source, "")
        self.events_label.setText(text)
        self.events_label.setStyleSheet(
            f"color: {self._colours.warn}; font-weight: bold" if source == EVENTS_GYRO else ""
        )

    def _show_stride_count(self, snap: Snapshot) -> None:
        """While recording, the recording's strides (from its row 0 on: the file's); else
        those since connecting. The row's name says which."""
        n: int | None = None
        if snap.recording.active:
            start = self.recording_start
            n = (start.strides(snap.gait) if start is not None else None) or 0
        name = "Strides (since connect)" if n is None else "Strides (this recording)"
        if self.strides_name.text() != name:
            self.strides_name.setText(name)
        self.values["strides"].setText(str(snap.gait.n_strides if n is None else n))

    def _show_stale(self, snap: Snapshot) -> None:
        """Grey the last strides' figures and say so when they are old: no stride completed
        for :data:`STALE_STRIDES` mean stride times (the subject stands) or no data comes."""
        g = snap.gait
        t = snap.series["t_s"]
        text = ""
        if len(t) and math.isfinite(g.last_stride_end_t_s):
            no_data_s = max(0.0, snap.last_data_age_s)
            age = max(0.0, float(t[-1]) - g.last_stride_end_t_s) + no_data_s
            cadence = g.cadence_derived_steps_per_min
            stride = 120.0 / cadence if math.isfinite(cadence) else g.last_stride_time_s
            ago = f"last stride {age:.0f} s ago"
            if snap.stalled_s > 0:  # the engine's rule: no frame for a second or more
                text = f"⚠ stale: {no_data_text(snap.stalled_s)} ({ago})"
            elif math.isfinite(stride) and age > STALE_STRIDES * stride:
                text = f"⚠ stale: {ago}"
        stale = bool(text)
        for key in STALE_KEYS:
            if self.values[key].isEnabled() == stale:
                self.values[key].setEnabled(not stale)  # greyed (the palette's disabled text)
        if self.stale_label.text() != text:
            self.stale_label.setText(text)
        if self.stale_label.isVisibleTo(self) != stale:
            self.stale_label.setVisible(stale)

    def stale_text(self) -> str:
        """What the panel says of its figures' age ("" when current): what the tests read."""
        return self.stale_label.text() if not self.stale_label.isHidden() else ""

    def set_colours(self, colours: Colours) -> None:
        """Curves are created once per theme: a new plot widget with the new shades."""
        self._colours = colours
        if self._events_source is not None:
            self._show_event_source(self._events_source)
        old = self.cycles
        self.cycles = CyclePlots(colours)
        self.cycles.setMinimumHeight(300)
        self._layout.replaceWidget(old, self.cycles)
        old.deleteLater()
        self._shown_strides = -1

    def show_snapshot(
        self, snap: Snapshot, mean_sd: tuple[np.ndarray, np.ndarray] | None = None
    ) -> None:
        """The panel for ``snap``; ``mean_sd``: the cycles' mean and SD prepared off the GUI
        thread (``DisplayFrame.cycle_mean_sd``)."""
        g = snap.gait
        v = self.values

        def fmt(x: float, spec: str, unit: str) -> str:
            return f"{x:{spec}} {unit}" if math.isfinite(x) else "—"

        v["cadence"].setText(fmt(g.cadence_derived_steps_per_min, ".0f", "steps/min"))
        v["speed"].setText(fmt(g.speed_mean_m_s, ".2f", "m/s"))
        v["stride"].setText(fmt(g.last_stride_time_s, ".2f", "s"))
        v["stance"].setText(fmt(g.last_stance_pct, ".0f", "%"))
        self._show_stride_count(snap)
        self._show_stale(snap)
        if snap.event_source != self._events_source:
            self._events_source = snap.event_source
            self._show_event_source(snap.event_source)
        if g.n_strides != self._shown_strides:
            self._shown_strides = g.n_strides
            k = len(g.cycles_deg)
            none = no_gait_events(str(snap.mode))  # tilt mode: no foot sensors, no strides
            self.cycle_title.setText(
                f"Gait cycle: mean ± SD of the last {count(k, 'stride')} (band), current "
                "stride (line)" if k > 1
                # one stride has no SD (no band): said so, not "the last 1 strides"
                else "Gait cycle: the one stride so far (no SD yet), current stride (line)"
                if k == 1
                else f"No gait events: {none}." if none
                else "Gait cycle: waiting for complete strides…"
            )  # fmt: skip
        self.cycles.update_from(snap, mean_sd)
