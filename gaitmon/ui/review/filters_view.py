"""The Filters view of the review window: any of gaitmon's tilt filters replayed on a recording.

Pick a segment tilt or a joint angle, any set of filters from
``gaitmon.dsp.lab_filters.TILT_FILTERS`` (parameters editable where a filter has them) and a
time range; the view overlays their curves and, where the session holds the simulator's ground
truth (``/truth``), tabulates each filter's RMSE against it.

Inputs. The filters get exactly what the recording's own Kalman filter got: the accelerometer
tilt atan2(a_z, a_x) of the low-passed accelerometer ``/processed/acc_ms2`` and the
bias-corrected gyro rate ``/processed/gyro_rad_s`` (mode ``raw`` only; the unit's own tilt and
joint modes record no sensor signals). Each run starts ``WARMUP_S`` before the range shown, so
filters that learn (Kalman bias, adaptive cut-off) are not scored on their start-up transient.

Mounting offsets. A filter's tilt is in the sensor's frame: true tilt + the board's mounting
offset. The truth has no offset. The alignment choices:

* ``mounting offset (simulator)``: subtract the offsets the simulator used (``/truth``
  attribute ``mount_offset_deg``), exact, so the RMSE is the filter's error alone;
* ``standing mean``: subtract the mean accelerometer tilt over the first seconds of the session
  (what a standing calibration does) from every filter, and the truth's own mean over the same
  rows from the truth: what a clinician's zeroed angles would show;
* ``recorded calibration``: the session's ``/calibration`` offsets (when it was zeroed);
* ``none``: raw sensor-frame tilts (the offsets stay in the error).

Computation runs in a worker thread (request -> response, the newest request wins), on at most
``MAX_RANGE_S`` of data, so an 8-hour recording stays responsive.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, QTimer, Signal, Slot
from PySide6.QtGui import QColor
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

from gaitmon.dsp.angles import accel_tilt, joint_angles, wrap_angle
from gaitmon.dsp.channels import SEGMENTS
from gaitmon.dsp.complementary import AdaptiveCutoff, ComplementaryFilter
from gaitmon.dsp.kalman import TiltKalman
from gaitmon.dsp.lab_filters import TILT_FILTERS, ConstantRateTilt, TiltFilter, make_tilt_filter
from gaitmon.io.session import SessionError, open_session
from gaitmon.io.session.truth import read_truth
from gaitmon.ui.tasks import TaskRunner
from gaitmon.ui.theme import Colours, current_colours

WARMUP_S = 10.0
MAX_RANGE_S = 600.0  # ten minutes per view: ~60 000 rows x filters, a second or two
DEFAULT_STANDING_S = 1.5
TARGETS: tuple[tuple[str, str, int], ...] = (  # (label, kind, column)
    *((f"{s} tilt (deg)", "tilt", k) for k, s in enumerate(SEGMENTS)),
    ("hip flexion (deg)", "joint", 0),
    ("knee flexion (deg)", "joint", 1),
    ("ankle dorsiflexion (deg)", "joint", 2),
)
ALIGN_MOUNT = "mounting offset (simulator)"
ALIGN_STANDING = "standing mean"
ALIGN_CALIBRATION = "recorded calibration"
ALIGN_NONE = "none (sensor frame)"
ALIGNMENTS = (ALIGN_MOUNT, ALIGN_STANDING, ALIGN_CALIBRATION, ALIGN_NONE)
DEFAULT_FILTERS = ("accelerometer", "gyro", "kalman (paper 000)")


# --------------------------------------------------------------------------------------------
# filter parameters (Qt-free)


@dataclass(frozen=True)
class Param:
    key: str
    label: str
    default: float
    minimum: float
    maximum: float
    decimals: int = 4


# Parameters the view lets the user edit, with the registry's defaults. Filters not listed here
# (and any added to the registry later) run with their registry defaults.
PARAMS: dict[str, tuple[Param, ...]] = {
    "complementary": (Param("cutoff_hz", "cut-off (Hz)", 3.0, 0.01, 45.0, 3),),
    "complementary (adaptive)": (Param("cutoff_hz", "initial cut-off (Hz)", 3.0, 0.2, 10.0, 3),),
    "kalman (paper 000)": (
        Param("q_angle", "Q angle", 0.001, 1e-7, 10.0, 6),
        Param("q_gyro", "Q gyro", 0.003, 0.0, 10.0, 6),
        Param("r", "R (rad²)", 0.3, 1e-6, 100.0, 4),
    ),
    "kalman constant-rate (paper 001)": (
        Param("q", "q (spectral density)", 1.0, 1e-6, 1e6, 4),
        Param("r_rad2", "R (rad²)", 0.3, 1e-6, 100.0, 4),
    ),
}

_BUILDERS: dict[str, Callable[[float, Mapping[str, float]], TiltFilter]] = {
    "complementary": lambda dt, p: ComplementaryFilter(dt, cutoff_hz=p["cutoff_hz"]),
    "complementary (adaptive)": lambda dt, p: ComplementaryFilter(
        dt, cutoff_hz=p["cutoff_hz"], adaptive=AdaptiveCutoff()
    ),
    "kalman (paper 000)": lambda dt, p: TiltKalman(dt, p["q_angle"], p["q_gyro"], p["r"]),
    "kalman constant-rate (paper 001)": lambda dt, p: ConstantRateTilt(dt, p["q"], p["r_rad2"]),
}


def default_params(name: str) -> dict[str, float]:
    return {p.key: p.default for p in PARAMS.get(name, ())}


def build_filter(name: str, dt_s: float, params: Mapping[str, float] | None = None) -> TiltFilter:
    """A fresh filter: the registry's own when the parameters are the defaults (or none)."""
    if not params or name not in _BUILDERS or dict(params) == default_params(name):
        return make_tilt_filter(name, dt_s)
    merged = {**default_params(name), **params}
    return _BUILDERS[name](dt_s, merged)


# --------------------------------------------------------------------------------------------
# the computation (Qt-free: request in, result out; runs in the worker)


@dataclass(frozen=True)
class FilterChoice:
    name: str
    params: tuple[tuple[str, float], ...] = ()


@dataclass(frozen=True)
class FiltersRequest:
    path: Path
    start_row: int
    stop_row: int
    target: int  # index into TARGETS
    filters: tuple[FilterChoice, ...]
    alignment: str = ALIGN_MOUNT
    standing_s: float = DEFAULT_STANDING_S
    warmup_s: float = WARMUP_S


@dataclass(frozen=True, eq=False)
class FiltersResult:
    request: FiltersRequest
    t_s: np.ndarray  # (n,) true times of the rows shown
    curves_deg: dict[str, np.ndarray]  # filter name -> (n,)
    truth_deg: np.ndarray | None  # (n,) or None when the session has no ground truth
    rmse_deg: dict[str, float] = field(default_factory=dict)
    bias_deg: dict[str, float] = field(default_factory=dict)
    max_abs_deg: dict[str, float] = field(default_factory=dict)
    alignment_used: str = ""
    note: str = ""


def _wrapped_mean(x: np.ndarray) -> np.ndarray:
    """Column means of angles (rad) that may straddle +-pi."""
    ref = x[0]
    return wrap_angle(ref + np.mean(wrap_angle(x - ref), axis=0))


def compute_filters(req: FiltersRequest) -> FiltersResult:
    """Run the chosen filters over the request's rows (plus warm-up) and score them."""
    _, kind, col = TARGETS[req.target]
    with open_session(req.path, recover=False) as s:
        if (
            "processed/acc_ms2" not in s.dataset_names
            or "processed/gyro_rad_s" not in s.dataset_names
        ):
            raise SessionError(
                f"{s.path.name} is a mode '{s.mode}' recording: it holds the unit's own angles, "
                "not the sensor signals the filters need (record in mode raw)"
            )
        fs = s.sample_rate_hz
        n = s.n_samples
        start = max(0, min(req.start_row, n))
        stop = max(start, min(req.stop_row, n))
        if stop - start < 2:
            raise SessionError("the range is too short: choose at least two samples")
        warm = round(req.warmup_s * fs)
        a0 = max(0, start - warm)
        d = s.read_range(a0, stop, ["processed/acc_ms2", "processed/gyro_rad_s", "timeline/t_s"])
        acc = d["processed/acc_ms2"].astype(np.float64)
        gyro = d["processed/gyro_rad_s"].astype(np.float64)
        t_s = d["timeline/t_s"][start - a0 :]
        z = accel_tilt(acc[:, :, 0], acc[:, :, 1])
        truth_tilt, mount = read_truth(req.path, start, stop)
        alignment = req.alignment
        note = ""
        truth_offset = np.zeros(len(SEGMENTS))
        if alignment == ALIGN_MOUNT and mount is None:
            alignment = ALIGN_STANDING
            note = "no simulator mounting offsets in this file: aligned on the standing mean"
        if alignment == ALIGN_CALIBRATION and not np.any(s.calibration.tilt_offset_rad):
            alignment = ALIGN_STANDING
            note = "the session was not zeroed: aligned on the standing mean"
        if alignment == ALIGN_MOUNT:
            offset = mount
        elif alignment == ALIGN_CALIBRATION:
            offset = np.asarray(s.calibration.tilt_offset_rad, dtype=np.float64)
        elif alignment == ALIGN_STANDING:
            k = max(1, min(n, round(req.standing_s * fs)))
            st = s.read_range(0, k, ["processed/acc_ms2"])["processed/acc_ms2"].astype(np.float64)
            offset = _wrapped_mean(accel_tilt(st[:, :, 0], st[:, :, 1]))
            tt, _ = read_truth(req.path, 0, k)
            if tt is not None:
                ok = np.all(np.isfinite(tt), axis=1)
                if ok.any():
                    truth_offset = _wrapped_mean(tt[ok])
        else:
            offset = np.zeros(len(SEGMENTS))
    dt_s = 1.0 / fs
    curves: dict[str, np.ndarray] = {}
    for choice in req.filters:
        flt = build_filter(choice.name, dt_s, dict(choice.params))
        tilt = wrap_angle(flt.process(z, gyro)[start - a0 :] - offset)
        curves[choice.name] = _target_deg(tilt, kind, col)
    truth = None
    if truth_tilt is not None:
        truth = _target_deg(wrap_angle(truth_tilt - truth_offset), kind, col)
    result = FiltersResult(req, t_s, curves, truth, alignment_used=alignment, note=note)
    if truth is not None:
        ok = np.isfinite(truth)
        for name, curve in curves.items():
            err = wrap_angle(np.radians(curve[ok] - truth[ok]))
            err_deg = np.degrees(err)
            result.rmse_deg[name] = float(np.sqrt(np.mean(err_deg**2))) if err_deg.size else np.nan
            result.bias_deg[name] = float(np.mean(err_deg)) if err_deg.size else np.nan
            result.max_abs_deg[name] = float(np.max(np.abs(err_deg))) if err_deg.size else np.nan
    return result


def _target_deg(tilt_rad: np.ndarray, kind: str, col: int) -> np.ndarray:
    if kind == "tilt":
        return np.degrees(tilt_rad[:, col])
    return np.degrees(joint_angles(tilt_rad)[:, col])


# --------------------------------------------------------------------------------------------
# the widget


class FiltersView(QWidget):
    """Controls on the left, the overlay plot and the RMSE table on the right."""

    computed = Signal(object)  # FiltersResult, on the GUI thread
    failed = Signal(str)  # one-line message

    def __init__(self, parent: QWidget | None = None, colours: Colours | None = None) -> None:
        super().__init__(parent)
        self._path: Path | None = None
        self._fs_hz = 100.0
        self._n_rows = 0
        self._t_s = np.empty(0)
        self._duration_s = 0.0
        self._has_truth = False
        self._has_mount = False
        self._zeroed = False
        self._params: dict[str, dict[str, float]] = {n: default_params(n) for n in TILT_FILTERS}
        self._tasks = TaskRunner(self)
        self._gen = itertools.count(1)
        self._wanted = 0
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

    def load_session(self, path: str | os.PathLike[str]) -> None:
        """Show a session (opened read-only here; the review window keeps its own handle)."""
        self._path = Path(path)
        try:
            with open_session(self._path, recover=False) as s:
                self._fs_hz = s.sample_rate_hz
                self._n_rows = s.n_samples
                self._t_s = s.read("timeline/t_s")
                self._duration_s = float(self._t_s[-1]) if s.n_samples else 0.0
                raw = "processed/acc_ms2" in s.dataset_names
                self._zeroed = bool(np.any(s.calibration.tilt_offset_rad))
                mode = s.mode
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
        try:
            truth, mount = read_truth(self._path, 0, 1)
        except SessionError:
            truth, mount = None, None
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
        gen = next(self._gen)
        self._wanted = gen
        self.status_label.setText("Computing…")
        self._tasks.submit(
            lambda: compute_filters(req),
            lambda res, exc, g=gen: self._on_result(g, res, exc),
            name="filters",
        )

    @property
    def busy(self) -> bool:
        return self._tasks.busy or self._debounce.isActive()

    def wait_idle(self, timeout_s: float = 30.0) -> None:
        self._tasks.wait_all(timeout_s)

    def _on_result(self, gen: int, result: FiltersResult | None, exc: BaseException | None) -> None:
        if gen != self._wanted:
            return  # a newer request is on its way
        if exc is not None:
            msg = (
                str(exc)
                if isinstance(exc, SessionError | ValueError)
                else (f"{type(exc).__name__}: {exc}")
            )
            self._fail(msg)
            return
        assert result is not None
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
        return {
            self.table.item(r, 0).text(): self.table.item(r, 1).text()
            for r in range(self.table.rowCount())
        }

    def closeEvent(self, event) -> None:
        self._debounce.stop()
        self._tasks.wait_all()
        super().closeEvent(event)


def _spin(lo: float, hi: float, value: float, decimals: int, suffix: str = "") -> QDoubleSpinBox:
    s = QDoubleSpinBox()
    s.setDecimals(decimals)
    s.setRange(lo, hi)
    s.setValue(value)
    s.setSuffix(suffix)
    s.setKeyboardTracking(False)
    return s
