"""The Lab Streaming Layer outlets: gaitmon's live streams for LabRecorder and other LSL tools.

:class:`LslOutlets` is an engine listener (``Engine.add_listener``): on the engine thread,
after each block, it pushes the block's samples to the ``angles`` stream (and, in raw mode,
the ``raw`` stream) and its events to the ``events`` stream, as ``gaitmon.lsl.layout`` says.
It opens the outlets (LSL's sockets) when it is made, and only then: nothing here runs, and
pylsl is not even imported, unless the user turned LSL on (``gaitmon record --lsl``, the live
window's Device ▸ Stream to LSL).

Timestamps. Every sample is stamped with the unit's sample clock mapped onto LSL's clock,
never with the moment it is sent: ``SampleClock`` (``gaitmon.dsp.sample_clock``) fits host
receive time (``time.monotonic``) against the sample counter, and the offset between
``time.monotonic`` and ``pylsl.local_clock`` is measured when the outlets open (on Linux both
read CLOCK_MONOTONIC, but nothing here assumes it). An event is stamped at its sample: a heel
strike the detector confirms 60 ms later still carries the time of its own sample.

What a stream says about itself (its XML description, the XDF MoCap meta-data convention
where it fits: ``gaitmon.lsl.layout``): ``acquisition`` (manufacturer "gaitmon", the unit's
model, serial number and firmware, gaitmon's version, ``compensated_lag``), ``channels`` (one
``channel`` per channel with its label, unit, type and object) and ``gaitmon`` (``stream``,
``mode``, ``fs_hz``, ``side``; ``subject_id`` only if the user allowed the patient id out;
on the raw stream ``header``: the session header as JSON, the patient id blanked unless
allowed). A unit of a pair
(both legs, ``leg``) has its leg in its names, source ids and ``side``, and its own sample
clock, as every ``LslOutlets`` has. Later changes
of the filter settings or the calibration go out on the events stream (``config <json>``,
``calibration <json>``), so a LabRecorder file is enough to rebuild the session; and when the
events stream gains a consumer (LabRecorder subscribing after a Zero), the ones in force go out
again, since the descriptions still say what they were when the outlets opened (the XDF import
skips a repeat that changes nothing).
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from gaitmon import __version__
from gaitmon.dsp.sample_clock import SampleClock
from gaitmon.errors import UserError
from gaitmon.lsl import layout
from gaitmon.lsl.layout import EventWord, event_text
from gaitmon.lsl.network import configure

if TYPE_CHECKING:
    from gaitmon.engine import Engine
    from gaitmon.engine.taps import BlockOut
    from gaitmon.io.session import SessionMeta

INSTALL_HINT = "Streaming to LSL needs pylsl: install gaitmon[lsl] (pip install 'gaitmon[lsl]')"
SIM_DEVICE_NAME = "gaitmon-sim"  # the simulated unit's IDENTITY name (gaitmon.io.sim.unit)


class LslUnavailable(UserError):
    """pylsl (the optional extra ``gaitmon[lsl]``) is not installed, or liblsl cannot load."""


STAMP_RING = 4096  # samples whose pushed stamps are kept (41 s at 100 Hz): events come later


def require_pylsl(scope: str | None = None) -> ModuleType:
    """pylsl with gaitmon's network settings applied (``gaitmon.lsl.network``: ``scope``, by
    default this computer only), or :class:`LslUnavailable` with the one line that says what
    to install."""
    try:
        import pylsl
    except (ImportError, OSError, RuntimeError) as exc:  # no package, or no liblsl in it
        raise LslUnavailable(INSTALL_HINT) from exc
    configure(pylsl, scope)
    return pylsl


def clock_offset_s(lsl_clock: Callable[[], float], tries: int = 25) -> float:
    """``lsl_clock() - time.monotonic()``, from the reading bracketed most tightly."""
    best_gap, best = float("inf"), 0.0
    for _ in range(tries):
        a = time.monotonic()
        t = lsl_clock()
        b = time.monotonic()
        if b - a < best_gap:
            best_gap, best = b - a, t - (a + b) / 2
    return best


def unit_label(engine: Engine) -> str:
    """The ``unit`` of the stream names: "sim" for the simulator, else the serial number."""
    ident = engine.identity
    if ident is None:
        return "unknown"
    return "sim" if ident.name == SIM_DEVICE_NAME else str(ident.serial)


def _channels(desc: Any, channels: tuple[layout.StreamChannel, ...]) -> None:
    chans = desc.append_child("channels")
    for c in channels:
        ch = chans.append_child("channel")
        ch.append_child_value("label", c.label)
        ch.append_child_value("unit", c.unit)
        ch.append_child_value("type", c.type)
        if c.object:
            ch.append_child_value("object", c.object)


class LslOutlets:
    """The three streams of one connected unit, fed by the engine (see the module doc).

    Make it with :meth:`attach` (opens the outlets, listens to the engine) and end it with
    :meth:`detach`. ``allow_patient_id``: the user allowed the session's patient id into the
    streams (``--lsl-patient-id``); without it, no stream carries it."""

    def __init__(
        self,
        engine: Engine,
        meta: SessionMeta | None = None,
        *,
        allow_patient_id: bool = False,
        unit: str | None = None,
        leg: str = "",
    ) -> None:
        from gaitmon.io.session import SessionMeta

        pylsl = require_pylsl()
        self._pylsl = pylsl
        self.engine = engine
        self.meta = meta or SessionMeta()
        self.allow_patient_id = allow_patient_id
        self.unit = unit or unit_label(engine)
        self.leg = leg  # "L" / "R" for a unit of a pair: in the names and source ids
        self.mode = engine.mode.value
        self.fs_hz = float(engine.fs_hz)
        self.clock = SampleClock(self.fs_hz)
        self.offset_s = clock_offset_s(pylsl.local_clock)
        self._lock = threading.Lock()
        self._closed = False
        self._k_end = 0  # the sample clock just after the last sample pushed
        self._consumers = False  # the events stream had a consumer at the last push
        # the stamps of the last STAMP_RING samples pushed, by sample clock modulo the ring:
        # an event confirmed later gets its sample's own stamp, not the clock fit's newer
        # estimate of it (the fit moves while it settles, by milliseconds)
        self._ring_k = np.full(STAMP_RING, -1, np.int64)
        self._ring_t = np.zeros(STAMP_RING, np.float64)
        self.samples_pushed = 0
        self.events_pushed = 0
        self.angles = pylsl.StreamOutlet(self._info("angles"))
        self.events = pylsl.StreamOutlet(self._info("events"))
        self.raw = pylsl.StreamOutlet(self._info("raw")) if self.mode == "raw" else None

    # -- the streams' descriptions ------------------------------------------------------

    @property
    def names(self) -> list[str]:
        """The stream names, e.g. ``gaitmon sim angles``."""
        kinds = ["angles", "events"] + (["raw"] if self.raw is not None else [])
        return [layout.stream_name(self.unit, s, self.leg) for s in kinds]

    def _info(self, stream: str) -> Any:
        pylsl = self._pylsl
        name = layout.stream_name(self.unit, stream, self.leg)
        sid = layout.source_id(self.unit, stream, self.leg)
        if stream == "angles":
            channels = layout.ANGLE_CHANNELS
            info = pylsl.StreamInfo(
                name, layout.ANGLES_TYPE, len(channels),
                self.fs_hz, pylsl.cf_float32, sid,
            )  # fmt: skip
        elif stream == "raw":
            channels = layout.RAW_CHANNELS
            info = pylsl.StreamInfo(
                name, layout.RAW_TYPE, len(channels),
                self.fs_hz, pylsl.cf_int32, sid,
            )  # fmt: skip
        else:
            channels = (layout.StreamChannel("event", "", "Marker"),)
            info = pylsl.StreamInfo(
                name, layout.EVENTS_TYPE, 1,
                pylsl.IRREGULAR_RATE, pylsl.cf_string, sid,
            )  # fmt: skip
        desc = info.desc()
        ident = self.engine.identity
        acq = desc.append_child("acquisition")
        acq.append_child_value("manufacturer", layout.MANUFACTURER)
        acq.append_child_value("model", ident.name if ident else "")
        acq.append_child_value("serial_number", str(ident.serial) if ident else "")
        acq.append_child_value("firmware", ident.firmware if ident else "")
        acq.append_child_value("gaitmon_version", __version__)
        config = self.engine.config
        lag = layout.compensated_lag_s(stream, self.mode, config.event_delay_samples, self.fs_hz)
        acq.append_child_value("compensated_lag", repr(lag))
        _channels(desc, channels)
        g = desc.append_child("gaitmon")
        g.append_child_value("stream", stream)
        g.append_child_value("mode", self.mode)
        g.append_child_value("fs_hz", repr(self.fs_hz))
        g.append_child_value("side", self.leg or self.meta.side or (ident.side if ident else ""))
        if self.allow_patient_id and self.meta.patient_id:
            g.append_child_value("subject_id", self.meta.patient_id)
        if stream == "raw":
            g.append_child_value("header", json.dumps(self.header_dict()))
        return info

    def header_dict(self) -> dict[str, Any]:
        """The session header a recording started now would have (``SessionHeader``), the
        patient id blanked unless allowed."""
        from gaitmon.io.session import SessionHeader, device_info

        e = self.engine
        meta = self.meta if self.allow_patient_id else replace(self.meta, patient_id="")
        header = SessionHeader(
            mode=self.mode,
            sample_rate_hz=self.fs_hz,
            meta=meta,
            device=device_info(e.identity, e.transport_label),
            config=e.config,
            calibration=e.calibration,
        )
        return header.as_dict()

    # -- the engine's listener ----------------------------------------------------------

    def __call__(self, out: BlockOut) -> None:
        with self._lock:
            if self._closed:
                return
            self._push(out)

    def _push(self, out: BlockOut) -> None:
        events: list[tuple[int, str]] = []  # (sample clock, text)
        n = len(out)
        if n:
            self.clock.update(out.k, out.host_time_s)
            k0 = int(out.k[0])
        else:
            k0 = self._k_end
        if out.recording_stopped:
            events.append((k0, event_text(EventWord.RECORDING_STOP)))
        if out.recording_started:
            name = Path(out.recording_started).name
            part = f".{self.leg}.partial"  # a leg's part: the session's file is what counts
            if self.leg and name.endswith(part):
                name = name[: -len(part)]
            events.append((k0, event_text(EventWord.RECORDING_START, name)))
        config, calibration = out.config, out.calibration
        if self.clock.ready:
            consumers = self.events.have_consumers()
            if consumers and not self._consumers:
                # a consumer just subscribed (LabRecorder starting to record): it missed the
                # changes made before, and the stream descriptions still hold the settings and
                # calibration the outlets opened with, so the ones in force go out now
                config, calibration = self.engine.config, self.engine.calibration
            self._consumers = consumers
        if config is not None:
            events.append((k0, event_text(EventWord.CONFIG, json.dumps(config.as_dict()))))
        if calibration is not None:
            cal = json.dumps(calibration.as_dict())
            events.append((k0, event_text(EventWord.CALIBRATION, cal)))
        events += [(k0, event_text(EventWord.MARKER, m)) for m in out.markers]
        if n:
            for i in np.flatnonzero(out.lost_before):
                k = int(out.k[i])
                reason = (out.gap_reason if i == 0 else "") or "frames lost"
                events.append(
                    (k - int(out.lost_before[i]), event_text(EventWord.GAP_START, reason))
                )
                events.append((k, event_text(EventWord.GAP_END)))
            events += [(int(k), event_text(EventWord.HEEL_STRIKE)) for k in out.heel_strike_k]
            events += [(int(k), event_text(EventWord.TOE_OFF)) for k in out.toe_off_k]
            stamps_arr = self.clock.map(out.k) + self.offset_s
            slots = out.k.astype(np.int64) % STAMP_RING
            self._ring_k[slots] = out.k
            self._ring_t[slots] = stamps_arr
            stamps = stamps_arr.tolist()
            data = np.concatenate([out.joint_deg, out.tilt_deg], axis=1).astype(np.float32)
            self.angles.push_chunk(data, stamps)
            if self.raw is not None and out.adc is not None:
                raw = np.empty((n, len(layout.RAW_CHANNELS)), np.int32)
                raw[:, 0] = out.seq
                raw[:, 1:] = out.adc
                self.raw.push_chunk(raw, stamps)
            self._k_end = int(out.k[-1]) + 1
            self.samples_pushed += n
        if events and self.clock.ready:
            events.sort(key=lambda e: e[0])
            t = self._stamps(np.array([e[0] for e in events], np.int64))
            for (_k, text), ts in zip(events, t.tolist(), strict=True):
                self.events.push_sample([text], ts)
            self.events_pushed += len(events)

    def _stamps(self, k: np.ndarray) -> np.ndarray:
        """LSL stamps of samples ``k``: the stamp each was pushed with, where it was pushed
        within the ring, else the clock fit's mapping (a gap's start, a sample not streamed)."""
        slots = k % STAMP_RING
        known = self._ring_k[slots] == k
        t = self.clock.map(k.astype(np.float64)) + self.offset_s
        t[known] = self._ring_t[slots[known]]
        return t

    # -- lifecycle ------------------------------------------------------------------------

    @classmethod
    def attach(
        cls,
        engine: Engine,
        meta: SessionMeta | None = None,
        *,
        allow_patient_id: bool = False,
        unit: str | None = None,
        leg: str = "",
    ) -> LslOutlets:
        """Open the outlets and feed them from ``engine`` from its next block on."""
        outlets = cls(engine, meta, allow_patient_id=allow_patient_id, unit=unit, leg=leg)
        engine.add_listener(outlets)
        return outlets

    def detach(self, linger_s: float = 0.0) -> None:
        """Stop listening and close the outlets; with ``linger_s``, give a recorder that is
        connected that long to take the last samples first."""
        self.engine.remove_listener(self)
        if linger_s > 0 and self.angles.have_consumers():
            time.sleep(linger_s)
        self.close()

    def close(self) -> None:
        """Close the outlets (the streams disappear from the network). Idempotent."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            # liblsl destroys an outlet when its last reference goes
            self.angles = self.events = self.raw = None
