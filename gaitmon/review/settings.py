"""Every settings name the windows use, named once, without Qt.

* :data:`PIPELINE_SETTINGS` - the processing settings a person may change (the Settings and
  Reprocess dialogs, the review's "cut-off 4 → 6 Hz" summary of a reprocessing, the live
  window's stored preferences): each a :class:`PipelineSetting`, the
  :class:`gaitmon.dsp.pipeline.PipelineConfig` field it sets and how it is shown;
* :class:`ReviewKey` - the review window's QSettings keys, with their types and defaults
  (:func:`gaitmon.ui.review.prefs` reads and writes them).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from pathlib import Path


@dataclass(frozen=True)
class PipelineSetting:
    name: str  # the PipelineConfig field
    label: str  # in a settings dialog
    tip: str  # the dialog field's tooltip
    short: str  # in a one-line summary of a change ("cut-off 4 → 6 Hz")
    unit: str = ""  # after the value in that summary, with its leading space

    @property
    def key(self) -> str:
        """Its QSettings key in the live window's preferences."""
        return f"pipeline/{self.name}"


PIPELINE_SETTINGS: tuple[PipelineSetting, ...] = (
    PipelineSetting("cutoff_hz", "Low-pass cut-off (Hz)",
                    "Butterworth cut-off frequency in Hz (paper: 4 Hz)", "cut-off", " Hz"),
    PipelineSetting("q_angle", "Kalman Q_angle",
                    "Process noise of the angle, rad² per s (paper: 0.001)", "Q_angle"),
    PipelineSetting("q_gyro", "Kalman Q_gyro",
                    "Process noise of the gyro bias, (rad/s)² per s (paper: 0.003)", "Q_gyro"),
    PipelineSetting("r", "Kalman R",
                    "Accelerometer-tilt measurement noise, rad² (paper: 0.3)", "R"),
    PipelineSetting("fsr_threshold", "FSR contact threshold (counts)",
                    "A foot sensor is loaded above this many ADC counts (paper: 1000)",
                    "FSR threshold"),
)  # fmt: skip


class ReviewKey(Enum):
    """A QSettings key of the review window: (key, type, default)."""

    LAST_FOLDER = ("review/last_folder", str, "~")  # the folder of the last file opened
    NORMATIVE_FOLDER = ("review/normative_folder", str, "~")  # of the last normative band
    RECENT = ("review/recent", list, ())  # Open recent: full paths, newest first

    def __init__(self, key: str, kind: type, default: object) -> None:
        self.key = key
        self.kind = kind
        self._default = default

    @property
    def default(self) -> object:
        """Its value when nothing is stored ("~": the user's home folder, read when asked)."""
        if self._default == "~":
            return str(Path.home())
        return list(self._default) if isinstance(self._default, tuple) else self._default
