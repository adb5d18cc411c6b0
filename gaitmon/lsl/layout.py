"""The Lab Streaming Layer streams gaitmon publishes: the one contract between the outlets, the
XDF import and ``docs/lsl.md``. Pure (no pylsl): names, types, channels, units, event words.

Three streams per connected unit (``unit`` is the unit's serial number, or "sim"; a unit of
a pair recording both legs adds its leg, L or R, to the names and source ids):

* ``angles``: the joint angles and segment tilts the live view shows, float32 at the unit's
  rate (100 Hz); a channel the mode does not produce is NaN. Degrees, clinical signs.
* ``events``: an irregular-rate string stream; one sample per event (``EventWord``).
* ``raw``: in raw mode only, the unit's frame counter (unwrapped) and its 14 ADC counts,
  int32 at the unit's rate. With the header carried in the stream's description (and the
  ``config``/``calibration`` events for later changes) this is enough to rebuild the session
  bit-exactly from a LabRecorder file (``gaitmon import FILE.xdf``).

Every sample's timestamp is the unit's sample clock mapped onto LSL's clock (a linear fit of
host receive time against the frame counter), never the moment of sending.

The descriptions follow the XDF meta-data conventions for motion capture (sccn/xdf wiki,
"MoCap"): ``acquisition`` (manufacturer, model, ``compensated_lag``), ``channels/channel``
(label, unit, type, object). Where they have nothing that fits, gaitmon's own names are kept
and ``docs/lsl.md`` says so: the raw ADC counts (``RawCounts``, channels ``Counter``/``ADC``).
``gaitmon/stream`` names each stream's kind, so the XDF import finds gaitmon's streams by their
manufacturer even when a recorder renamed their types; files of the older convention (angle
channel types ``JointAngle``/``SegmentTilt``, no ``gaitmon/stream``) are read too.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from gaitmon.dsp.channel_table import CHANNEL_NAMES, JOINT_TABLE, JOINTS, SEGMENTS

#: LSL stream type of each stream (the XDF meta-data conventions' content types)
ANGLES_TYPE = "MoCap"
EVENTS_TYPE = "Markers"
RAW_TYPE = "RawCounts"

#: the manufacturer field of every stream's ``acquisition`` description; the XDF import finds
#: gaitmon's streams by it
MANUFACTURER = "gaitmon"


#: the kinds of stream, as ``gaitmon/stream`` in each description says
STREAM_KINDS = ("raw", "angles", "events")
#: the angle channels' types of files written before the MoCap convention was followed
LEGACY_ANGLE_TYPES = ("JointAngle", "SegmentTilt")
#: MoCap's Euler-angle types are pitch/heading/roll; every gaitmon angle is a sagittal
#: rotation about the mediolateral axis: a pitch (a joint's, of its distal segment against
#: its proximal one, with the clinical sign)
ANGLE_CHANNEL_TYPE = "OrientationP"


@dataclass(frozen=True)
class StreamChannel:
    label: str
    unit: str
    type: str
    object: str = ""  # MoCap's <object>: the segment or joint the channel belongs to


JOINT_LABELS: dict[str, str] = {j.name: j.key for j in JOINT_TABLE}  # hip -> hip_flexion

ANGLE_CHANNELS: tuple[StreamChannel, ...] = tuple(
    StreamChannel(JOINT_LABELS[j], "degrees", ANGLE_CHANNEL_TYPE, j) for j in JOINTS
) + tuple(StreamChannel(f"{s}_tilt", "degrees", ANGLE_CHANNEL_TYPE, s) for s in SEGMENTS)

RAW_CHANNELS: tuple[StreamChannel, ...] = (
    StreamChannel("frame_counter", "frames", "Counter"),
    *(StreamChannel(name, "counts", "ADC") for name in CHANNEL_NAMES),
)


def compensated_lag_s(stream: str, mode: str, event_delay_samples: int, fs_hz: float) -> float:
    """MoCap's ``acquisition/compensated_lag``: the lag taken out of the stream's timestamps,
    in seconds. Samples are stamped at their own time on the unit's clock (nothing to take
    out: 0; the angles' filter delay is in the values, not removed from the stamps). In raw
    mode gaitmon dates a gait event at its force sensor's threshold crossing moved back by the
    low-pass filter's delay (``PipelineConfig.event_delay_samples``): that is the events
    stream's compensated lag. The unit's own events (tilt, joint mode) are not moved."""
    if stream == "events" and mode == "raw" and fs_hz > 0:
        return event_delay_samples / fs_hz
    return 0.0


def stream_name(unit: str, stream: str, leg: str = "") -> str:
    """``gaitmon <unit> <stream>``, e.g. "gaitmon sim angles"; a unit of a pair (both legs)
    says its leg: ``gaitmon <unit> <leg> <stream>``, e.g. "gaitmon sim L angles"."""
    return f"gaitmon {unit} {leg} {stream}" if leg else f"gaitmon {unit} {stream}"


def source_id(unit: str, stream: str, leg: str = "") -> str:
    """Stable across restarts, so LSL recorders reconnect to the same stream:
    ``gaitmon-<unit>-<stream>``, or ``gaitmon-<unit>-<leg>-<stream>`` for a unit of a pair."""
    return f"gaitmon-{unit}-{leg}-{stream}" if leg else f"gaitmon-{unit}-{stream}"


class EventWord(enum.StrEnum):
    """The first word of an ``events`` sample; a label or JSON follows after one space."""

    HEEL_STRIKE = "heel_strike"
    TOE_OFF = "toe_off"
    MARKER = "marker"  # "marker <label>"
    GAP_START = "gap_start"  # "gap_start <reason>"; stamped at the first lost frame
    GAP_END = "gap_end"  # stamped at the first frame after the gap
    RECORDING_START = "recording_start"  # "recording_start <file name>"
    RECORDING_STOP = "recording_stop"
    CONFIG = "config"  # "config <PipelineConfig.as_dict() as JSON>": from this sample on
    CALIBRATION = "calibration"  # "calibration <Calibration.as_dict() as JSON>"


def event_text(word: EventWord, rest: str = "") -> str:
    return f"{word.value} {rest}" if rest else word.value


def parse_event(text: str) -> tuple[EventWord | None, str]:
    """(word, rest); word is None for a sample that is not one of gaitmon's words."""
    head, _, rest = text.partition(" ")
    try:
        return EventWord(head), rest
    except ValueError:
        return None, text
