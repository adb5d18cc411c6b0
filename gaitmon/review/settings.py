"""Every settings name the windows use, named once, without Qt.

* :data:`PIPELINE_SETTINGS` - the processing settings a person may change (the Settings and
  Reprocess dialogs, the review's "cut-off 4 → 6 Hz" summary of a reprocessing, the live
  window's stored preferences): each a :class:`PipelineSetting`, the
  :class:`gaitmon.dsp.pipeline.PipelineConfig` field it sets and how it is shown;
* :class:`ReviewKey` - the review window's QSettings keys, with their types and defaults
  (:mod:`gaitmon.ui.review.recent` reads and writes them);
* :class:`LiveKey` - the live window's (:class:`gaitmon.ui.live.prefs.Prefs` reads and writes
  them), beside its processing settings' keys (:attr:`PipelineSetting.key`,
  ``LiveKey.TILT_METHOD``).

The stored key strings never change: a user's saved settings must load in the next version.
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


class SettingsKey(Enum):
    """A QSettings key of a window: (key, type, default); a window's keys subclass it."""

    def __init__(self, key: str, kind: type, default: object) -> None:
        self.key = key
        self.kind = kind  # object: kept as Qt stores it (a window's geometry)
        self._default = default

    @property
    def default(self) -> object:
        """Its value when nothing is stored ("~": the user's home folder, read when asked;
        None: the caller's, e.g. a PipelineConfig field's)."""
        if self._default == "~":
            return str(Path.home())
        return list(self._default) if isinstance(self._default, tuple) else self._default


class ReviewKey(SettingsKey):
    """A QSettings key of the review window."""

    LAST_FOLDER = ("review/last_folder", str, "~")  # the folder of the last file opened
    NORMATIVE_FOLDER = ("review/normative_folder", str, "~")  # of the last normative band
    RECENT = ("review/recent", list, ())  # Open recent: full paths, newest first


class LiveKey(SettingsKey):
    """A QSettings key of the live window (the processing settings' own are
    :attr:`PipelineSetting.key`)."""

    TILT_METHOD = ("pipeline/tilt_method", str, None)  # Device ▸ Tilt filter
    LAST_PORT = ("device/last_port", str, "")
    RECENT_PORTS = ("device/recent_ports", str, "")  # typed ports connected to, newest first
    MODE = ("device/mode", str, "raw")  # an engine Mode's value
    SESSION_FOLDER = ("session/folder", str, None)  # the last recording's (default: Documents)
    OPERATOR = ("session/operator", str, "")
    SIDE = ("session/side", str, "")
    PATIENT_ID = ("session/patient_id", str, "")
    WINDOW_S = ("view/window_s", float, 10.0)  # the time window shown
    FOUR_PHASES = ("view/four_phases", bool, True)
    ENGINEERING = ("view/engineering", bool, False)  # off: the clinical view
    SHOW_ACC = ("view/method_acc", bool, True)  # each method's traces shown
    SHOW_KALMAN = ("view/method_kalman", bool, True)
    SHOW_GYRO = ("view/method_gyro", bool, True)
    LSL = ("lsl/enabled", bool, False)  # Device ▸ Stream to LSL
    LSL_PATIENT_ID = ("lsl/patient_id", bool, False)  # the patient id in the streams
    GEOMETRY = ("window/geometry", object, None)
    STATE = ("window/state", object, None)  # docks and toolbars

    @classmethod
    def shown(cls, traces: str) -> LiveKey:
        """The key remembering whether the "acc", "kalman" or "gyro" traces are shown."""
        return {"acc": cls.SHOW_ACC, "kalman": cls.SHOW_KALMAN, "gyro": cls.SHOW_GYRO}[traces]
