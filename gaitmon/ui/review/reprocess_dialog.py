"""The review's Reprocess dialog: the processing settings
(:class:`gaitmon.ui.dialogs.SettingsDialog`) plus the live tilt filter to replay with, one of
the app's tilt methods (the registry, gaitmon.dsp.methods: gait-aware or the paper's).

As ``gaitmon process`` refuses ``--q-angle``, ``--q-gyro`` and ``--r`` without ``--method paper``
(they tune the paper's Kalman filter only and would silently change nothing), the dialog enables
a setting only for the methods that read it (``TiltMethod.reads_settings``) and keeps the
recorded value otherwise.
"""

from __future__ import annotations

from PySide6.QtWidgets import QComboBox, QFormLayout, QLabel, QVBoxLayout, QWidget

from gaitmon.dsp.methods import get_method, methods
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.reprocessing import method_only_settings
from gaitmon.ui.dialogs import SettingsDialog


def review_notes(smoothed: bool, bilateral: bool) -> tuple[str, str]:
    """(note, angles note) of the dialog as review opens it: with the smoothed angles shown or
    not, for a one-unit file or one leg of a bilateral file (which cannot be saved yet)."""
    keep = ("a file that records both legs cannot be saved reprocessed yet: the result is "
            "shown until the file is closed." if bilateral else
            "use File ▸ Save reprocessed as… to keep the result.")  # fmt: skip
    note = ("Recomputes the live filter's angles, the gait events, the foot sensors and the gait "
            "phases from the recorded raw counts (the whole session, standing calibrations "
            f"replayed). The recording is not modified; {keep}")  # fmt: skip
    angles_note = ("<i>Shown now: the smoothed angles (zero-lag, offline). They depend on the "
                   "raw counts and the calibration only, not on these settings, so they stay as "
                   "recorded; the events, foot sensors and phases come from the reprocessing. "
                   "View ▸ Angles ▸ Live shows the reprocessed filter's angles.</i>")  # fmt: skip
    return note, angles_note if smoothed else ""


class ReprocessDialog(SettingsDialog):
    """Settings and live filter of a reprocessing; :attr:`config` once accepted."""

    def __init__(
        self, parent: QWidget | None, config: PipelineConfig, *, note: str = "",
        angles_note: str = "",
    ) -> None:  # fmt: skip
        super().__init__(parent, config, note=note)
        self.setWindowTitle("Reprocess with settings")
        self.method_combo = QComboBox()
        for m in methods(live=True):  # the app's tilt methods, the default first
            self.method_combo.addItem(m.label, m.name)
        self.method_combo.setCurrentIndex(max(0, self.method_combo.findData(config.tilt_method)))
        self.method_combo.setToolTip(
            "The causal tilt filter replayed over the raw counts: its angles are the live ones "
            "(View ▸ Angles ▸ Live). Q_angle, Q_gyro and R tune the paper's filter only."
        )
        lay = self.layout()
        assert isinstance(lay, QVBoxLayout)
        item = lay.itemAt(0)  # the settings' form: the method is its first row
        form = item.layout() if item is not None else None
        assert isinstance(form, QFormLayout)
        form.insertRow(0, "Live tilt filter", self.method_combo)
        self.angles_note = QLabel(angles_note)
        self.angles_note.setWordWrap(True)
        self.angles_note.setVisible(bool(angles_note))
        lay.insertWidget(lay.count() - 2, self.angles_note)  # above the error line and buttons
        self._only = method_only_settings()  # settings some methods read, by method
        self._tips = {name: self.edits[name].toolTip() for name in self._only}
        self.method_combo.currentIndexChanged.connect(self._method_changed)
        self._method_changed()

    @property
    def method(self) -> str:
        return str(self.method_combo.currentData())

    def _method_changed(self, *_args: object) -> None:
        for name, readers in self._only.items():
            reads = self.method in readers
            edit = self.edits[name]
            edit.setEnabled(reads)
            edit.setToolTip(self._tips[name] if reads else
                            f"Tunes {get_method(readers[0]).noun_phrase} only: choose it above "
                            "to change it")  # fmt: skip
            if not reads:  # the recorded value: this filter does not read it
                edit.setText(f"{getattr(self.base, name):g}")

    def _defaults(self) -> None:
        super()._defaults()
        self._method_changed()

    def parsed(self) -> PipelineConfig:
        return super().parsed().replace(tilt_method=self.method)
