"""The Filters view of the review window: the widgets over :mod:`gaitmon.review.filters`.

Pick a segment tilt or a joint angle, any set of filters (parameters editable where a filter
has them) and a time range; the view overlays their curves and, where the session holds the
simulator's ground truth, tabulates each filter's RMSE against it. The computation
(:func:`gaitmon.review.filters.compute_filters`) runs on a :class:`gaitmon.ui.jobs.QtWorker`
(newest request wins).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, QTimer, Signal, Slot
from PySide6.QtGui import QCloseEvent, QColor
from PySide6.QtWidgets import (
    QComboBox,
    QDoubleSpinBox,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QPushButton,
    QSplitter,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from gaitmon.dsp.lab_filters import TILT_FILTERS
from gaitmon.finish import open_session
from gaitmon.io.session import SessionError
from gaitmon.jobs import Response, Ticket
from gaitmon.review.filters import (
    ALIGN_MOUNT,
    ALIGN_STANDING,
    ALIGNMENTS,
    DEFAULT_FILTERS,
    DEFAULT_STANDING_S,
    MAX_RANGE_S,
    PARAMS,
    TARGETS,
    FilterChoice,
    FiltersRequest,
    FiltersResult,
    compute_filters,
    default_params,
)
from gaitmon.ui.jobs import QtWorker
from gaitmon.ui.theme import Colours, current_colours


def filters_window(colours: Colours, on_failed: Callable[[str], None]) -> FiltersView:
    """The review window's Filters window (a top-level window of its own)."""
    fw = FiltersView(None, colours)
    fw.setWindowFlag(Qt.WindowType.Window, True)
    fw.setWindowTitle("gaitmon — filters")
    fw.resize(1100, 650)
    fw.failed.connect(on_failed)
    return fw


class FiltersView(QWidget):
    """Controls on the left, the overlay plot and the RMSE table on the right."""

    computed = Signal(object)  # FiltersResult, on the GUI thread
    failed = Signal(str)  # one-line message

    def __init__(self, parent: QWidget | None = None, colours: Colours | None = None) -> None:
        super().__init__(parent)
        self._path: Path | None = None
        self._side: str | None = None  # the leg of a bilateral file, None for one unit
        self._fs_hz = 100.0
        self._n_rows = 0
        self._t_s = np.empty(0)
        self._duration_s = 0.0
        self._has_truth = False
        self._has_mount = False
        self._zeroed = False
        self._params: dict[str, dict[str, float]] = {n: default_params(n) for n in TILT_FILTERS}
        self._worker: QtWorker | None = None  # started on the first request, stopped on close
        self.result: FiltersResult | None = None
        self._colours = colours if colours is not None else current_colours()
        self._debounce = QTimer(self)
        self._debounce.setSingleShot(True)
        self._debounce.setInterval(250)
        self._debounce.timeout.connect(self.compute_now)
        self._build()
        self._set_enabled(False)

    # -- layout -----------------------------------------------------------------------------

    def _build(self) -> None:
        controls = QWidget()
        cl = QVBoxLayout(controls)
        cl.setContentsMargins(0, 0, 0, 0)
        form = QFormLayout()
        self.target_combo = QComboBox()
        for label, _, _ in TARGETS:
            self.target_combo.addItem(label)
        # knee flexion: what clinicians look at first
        self.target_combo.setCurrentIndex([t[0] for t in TARGETS].index("knee flexion (deg)"))
        self.target_combo.currentIndexChanged.connect(self._changed)
        form.addRow("Show", self.target_combo)
        self.align_combo = QComboBox()
        for a in ALIGNMENTS:
            self.align_combo.addItem(a)
        self.align_combo.currentIndexChanged.connect(self._changed)
        self.align_combo.setToolTip(
            "How the boards' mounting offsets are removed before comparing with the truth:\n"
            "mounting offset: the simulator's own offsets (exact; simulated sessions only);\n"
            "standing mean: the mean accelerometer tilt over the first seconds (as a standing\n"
            "calibration does), the truth's own mean taken off the truth;\n"
            "recorded calibration: the session's zeroing; none: sensor-frame tilts."
        )
        form.addRow("Align", self.align_combo)
        self.standing_spin = _spin(0.1, 60.0, DEFAULT_STANDING_S, 1, " s")
        self.standing_spin.valueChanged.connect(self._changed)
        form.addRow("Standing", self.standing_spin)
        self.start_spin = _spin(0.0, 1e6, 0.0, 2, " s")
        self.stop_spin = _spin(0.0, 1e6, 0.0, 2, " s")
        self.start_spin.valueChanged.connect(self._changed)
        self.stop_spin.valueChanged.connect(self._changed)
        rng = QHBoxLayout()
        rng.addWidget(self.start_spin)
        rng.addWidget(QLabel("to"))
        rng.addWidget(self.stop_spin)
        form.addRow("Range", rng)
        cl.addLayout(form)

        cl.addWidget(QLabel("Filters (tick to overlay; select one to edit it)"))
        self.filter_list = QListWidget()
        for name in TILT_FILTERS:
            item = QListWidgetItem(name)
            item.setFlags(item.flags() | Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(
                Qt.CheckState.Checked if name in DEFAULT_FILTERS else Qt.CheckState.Unchecked
            )
            self.filter_list.addItem(item)
        self.filter_list.itemChanged.connect(self._changed)
        self.filter_list.currentItemChanged.connect(self._show_params)
        cl.addWidget(self.filter_list, 1)
        self.params_box = QGroupBox("Parameters")
        self.params_form = QFormLayout(self.params_box)
        cl.addWidget(self.params_box)
        buttons = QHBoxLayout()
        self.defaults_button = QPushButton("Defaults")
        self.defaults_button.clicked.connect(self._reset_params)
        self.update_button = QPushButton("Update")
        self.update_button.clicked.connect(self.compute_now)
        buttons.addWidget(self.defaults_button)
        buttons.addStretch(1)
        buttons.addWidget(self.update_button)
        cl.addLayout(buttons)
        self.status_label = QLabel("Open a session recorded in mode raw.")
        self.status_label.setWordWrap(True)
        cl.addWidget(self.status_label)

        right = QWidget()
        rl = QVBoxLayout(right)
        rl.setContentsMargins(0, 0, 0, 0)
        self.plot = pg.PlotWidget(background=self._colours.background)
        self.plot.showGrid(x=True, y=True, alpha=0.25)
        self.plot.setLabel("bottom", "time (s)")
        self.plot.addLegend(offset=(10, 10))
        rl.addWidget(self.plot, 3)
        self.table = QTableWidget(0, 4)
        self.table.setHorizontalHeaderLabels(
            ["filter", "RMSE (deg)", "mean error (deg)", "max |error| (deg)"]
        )
        self.table.verticalHeader().setVisible(False)
        header = self.table.horizontalHeader()
        header.setSectionResizeMode(0, QHeaderView.ResizeMode.Stretch)
        for c in (1, 2, 3):
            header.setSectionResizeMode(c, QHeaderView.ResizeMode.ResizeToContents)
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        rl.addWidget(self.table, 1)

        split = QSplitter(Qt.Orientation.Horizontal)
        split.addWidget(controls)
        split.addWidget(right)
        split.setStretchFactor(1, 1)
        split.setSizes([280, 720])
        lay = QVBoxLayout(self)
        lay.setContentsMargins(4, 4, 4, 4)
        lay.addWidget(split)

    def _set_enabled(self, on: bool) -> None:
        for w in (
            self.target_combo,
            self.align_combo,
            self.standing_spin,
            self.start_spin,
            self.stop_spin,
            self.filter_list,
            self.params_box,
            self.update_button,
            self.defaults_button,
        ):
            w.setEnabled(on)

    # -- session ------------------------------------------------------------------------------

    @property
    def source(self) -> tuple[Path | None, str | None]:
        """(file, leg) shown: the leg is None for a one-unit file."""
        return self._path, self._side

    def load_session(self, path: str | os.PathLike[str], side: str | None = None) -> None:
        """Show a session (opened read-only here; the review window keeps its own handle); of
        a bilateral file, the leg ``side`` ("L" | "R")."""
        self._path, self._side = Path(path), side
        try:
            with open_session(self._path, recover=False, side=side) as s:
                self._fs_hz = s.sample_rate_hz
                self._n_rows = s.n_samples
                self._t_s = s.read("timeline/t_s")
                self._duration_s = float(self._t_s[-1]) if s.n_samples else 0.0
                raw = "processed/acc_ms2" in s.dataset_names
                self._zeroed = bool(np.any(s.calibration.tilt_offset_rad))
                mode = s.mode
                try:
                    truth, mount = s.truth(0, 1)
                except SessionError:
                    truth, mount = None, None
        except SessionError as exc:
            self._set_enabled(False)
            self._fail(str(exc))
            return
        if not raw:
            self._set_enabled(False)
            self._fail(
                f"this session (mode {mode}) holds the unit's own angles, not the sensor "
                "signals the filters need; record in mode raw to compare filters"
            )
            return
        self._has_truth, self._has_mount = truth is not None, mount is not None
        self._set_enabled(True)
        for spin in (self.start_spin, self.stop_spin):
            spin.blockSignals(True)
            spin.setMaximum(max(self._duration_s, 0.01))
        self.start_spin.setValue(0.0)
        self.stop_spin.setValue(min(self._duration_s, MAX_RANGE_S))
        for spin in (self.start_spin, self.stop_spin):
            spin.blockSignals(False)
        self.align_combo.blockSignals(True)
        self.align_combo.setCurrentText(ALIGN_MOUNT if self._has_mount else ALIGN_STANDING)
        self.align_combo.blockSignals(False)
        self.compute_now()

    def set_range(self, start_s: float, stop_s: float) -> None:
        """Show the range the review window has selected (clipped to MAX_RANGE_S)."""
        start_s = max(0.0, float(start_s))
        stop_s = min(max(start_s, float(stop_s)), start_s + MAX_RANGE_S)
        for spin, v in ((self.start_spin, start_s), (self.stop_spin, stop_s)):
            spin.blockSignals(True)
            spin.setValue(v)
            spin.blockSignals(False)
        self._changed()

    # -- filters and parameters --------------------------------------------------------------

    def filter_names(self) -> list[str]:
        return [self.filter_list.item(i).text() for i in range(self.filter_list.count())]

    def checked_filters(self) -> list[str]:
        return [
            self.filter_list.item(i).text()
            for i in range(self.filter_list.count())
            if self.filter_list.item(i).checkState() == Qt.CheckState.Checked
        ]

    def set_checked(self, names: Sequence[str]) -> None:
        self.filter_list.blockSignals(True)
        for i in range(self.filter_list.count()):
            item = self.filter_list.item(i)
            item.setCheckState(
                Qt.CheckState.Checked if item.text() in names else Qt.CheckState.Unchecked
            )
        self.filter_list.blockSignals(False)
        self._changed()

    def set_param(self, name: str, key: str, value: float) -> None:
        if key not in self._params.get(name, {}):
            raise KeyError(f"{name!r} has no parameter {key!r}")
        self._params[name][key] = float(value)
        current = self.filter_list.currentItem()
        if current is not None and current.text() == name:
            self._show_params(current, None)
        self._changed()

    @Slot(object, object)
    def _show_params(self, current: QListWidgetItem | None, _previous: object) -> None:
        while self.params_form.rowCount():
            self.params_form.removeRow(0)
        name = current.text() if current is not None else ""
        specs = PARAMS.get(name, ())
        self.params_box.setTitle(f"Parameters: {name}" if name else "Parameters")
        if not specs:
            self.params_form.addRow(QLabel("no parameters" if name else "select a filter"))
            return
        for spec in specs:
            spin = _spin(spec.minimum, spec.maximum, self._params[name][spec.key], spec.decimals)
            spin.setObjectName(f"param:{spec.key}")

            def apply(v: float, n: str = name, k: str = spec.key) -> None:
                self._params[n][k] = float(v)
                self._changed()

            spin.valueChanged.connect(apply)
            self.params_form.addRow(spec.label, spin)

    @Slot()
    def _reset_params(self) -> None:
        self._params = {n: default_params(n) for n in TILT_FILTERS}
        self._show_params(self.filter_list.currentItem(), None)
        self._changed()

    # -- computing ----------------------------------------------------------------------------

    def request(self) -> FiltersRequest | None:
        if self._path is None:
            return None
        # seconds -> rows through the true timeline (lost frames leave no row)
        a = int(np.searchsorted(self._t_s, self.start_spin.value() - 1e-9))
        b = int(np.searchsorted(self._t_s, self.stop_spin.value() + 1e-9, side="right"))
        b = min(b, a + int(MAX_RANGE_S * self._fs_hz))
        names = self.checked_filters()
        return FiltersRequest(
            path=self._path,
            side=self._side,
            start_row=a,
            stop_row=b,
            target=self.target_combo.currentIndex(),
            filters=tuple(
                FilterChoice(n, tuple(sorted(self._params.get(n, {}).items()))) for n in names
            ),
            alignment=self.align_combo.currentText(),
            standing_s=self.standing_spin.value(),
        )

    @Slot()
    def _changed(self, *_: object) -> None:
        if self._path is not None:
            self._debounce.start()

    @Slot()
    def compute_now(self) -> None:
        self._debounce.stop()
        req = self.request()
        if req is None:
            return
        self.status_label.setText("Computing…")
        if self._worker is None:
            self._worker = QtWorker("review-filters", latest=True, parent=self)

        def job(ticket: Ticket) -> FiltersResult:
            return compute_filters(req)

        self._worker.submit(job, self._on_result)

    @property
    def busy(self) -> bool:
        worker_busy = self._worker is not None and self._worker.busy
        return worker_busy or self._debounce.isActive()

    def wait_idle(self, timeout_s: float = 30.0) -> None:
        if self._worker is not None:
            self._worker.wait_idle(timeout_s)

    def _on_result(self, response: Response[FiltersResult]) -> None:
        exc = response.error
        if exc is not None:
            msg = (
                str(exc)
                if isinstance(exc, SessionError | ValueError)
                else (f"{type(exc).__name__}: {exc}")
            )
            self._fail(msg)
            return
        result = response.result()
        self.result = result
        self._draw(result)
        self._fill_table(result)
        n = len(result.t_s)
        truth = (
            f"RMSE against the simulator's truth, {result.alignment_used} alignment"
            if result.truth_deg is not None
            else "no ground truth in this session (only simulated recordings have /truth)"
        )
        self.status_label.setText(
            f"{n} samples, {len(result.curves_deg)} filters; {truth}."
            + (f" Note: {result.note}." if result.note else "")
        )
        self.computed.emit(result)

    def _fail(self, message: str) -> None:
        self.status_label.setText(message)
        self.failed.emit(message)

    def _colour(self, name: str, k: int) -> QColor:
        c = self._colours
        fixed = {"accelerometer": c.acc, "gyro": c.gyro, "kalman (paper 000)": c.kalman}
        palette = ("#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2", "#bcbd22")
        return fixed.get(name, QColor(palette[k % len(palette)]))

    def _draw(self, r: FiltersResult) -> None:
        self.plot.clear()
        legend = self.plot.plotItem.legend
        if legend is not None:
            legend.clear()
        label = TARGETS[r.request.target][0]
        self.plot.setLabel("left", label)
        if r.truth_deg is not None:
            fg = self._colours.foreground
            self.plot.plot(
                r.t_s,
                r.truth_deg,
                pen=pg.mkPen(fg, width=2, style=Qt.PenStyle.DashLine),
                name="truth (simulator)",
                connect="finite",
            )
        for k, (name, y) in enumerate(r.curves_deg.items()):
            item = self.plot.plot(r.t_s, y, pen=pg.mkPen(self._colour(name, k), width=1), name=name)
            item.setClipToView(True)
            item.setDownsampling(auto=True, method="peak")
        self.plot.enableAutoRange()

    def _fill_table(self, r: FiltersResult) -> None:
        self.table.setRowCount(len(r.curves_deg))
        for row, name in enumerate(r.curves_deg):
            cells = [name]
            for d in (r.rmse_deg, r.bias_deg, r.max_abs_deg):
                v = d.get(name)
                cells.append("–" if v is None or not np.isfinite(v) else f"{v:.2f}")
            for c, text in enumerate(cells):
                item = QTableWidgetItem(text)
                if c:
                    item.setTextAlignment(
                        Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter
                    )
                self.table.setItem(row, c, item)

    def table_values(self) -> dict[str, str]:
        """filter name -> the RMSE cell as shown (for tests and the window's status)."""
        out: dict[str, str] = {}
        for r in range(self.table.rowCount()):
            name, rmse = self.table.item(r, 0), self.table.item(r, 1)
            if name is not None and rmse is not None:
                out[name.text()] = rmse.text()
        return out

    def closeEvent(self, event: QCloseEvent) -> None:
        self._debounce.stop()
        if self._worker is not None:
            # the result of a running request is not wanted any more; the thread ends here
            self._worker.stop()
            self._worker = None
        super().closeEvent(event)


def _spin(lo: float, hi: float, value: float, decimals: int, suffix: str = "") -> QDoubleSpinBox:
    s = QDoubleSpinBox()
    s.setDecimals(decimals)
    s.setRange(lo, hi)
    s.setValue(value)
    s.setSuffix(suffix)
    s.setKeyboardTracking(False)
    return s
