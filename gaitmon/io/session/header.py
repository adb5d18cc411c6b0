"""What is known when a recording starts: session metadata, device attributes, the header.

Also :class:`SessionError`, the one exception every part of the session package raises.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any, TypeAlias, cast

from gaitmon import __version__
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channels import CHANNELS, DEFAULT_TABLE, ChannelSpec, ChannelTable
from gaitmon.dsp.pipeline_config import PipelineConfig
from gaitmon.io.session.layout import _DEVICE_KEYS, FORMAT, FORMAT_VERSION, MODES

if TYPE_CHECKING:  # the wire protocol is not needed to read a file
    from gaitmon.io.protocol import Identity


class SessionError(Exception):
    """A session file could not be written, read or recovered; one-line, actionable message."""


class DamagedSource(SessionError):
    """The recorded bytes themselves are damaged (a journal that is not one, settings that do not
    parse): trying again cannot help, unlike a full disk or a recording still running."""


class RecoveryNotSaved(SessionError):
    """An interrupted recording was rebuilt but could not be written (a full disk): its
    journal is kept, and ``why`` says what the write met."""

    def __init__(self, message: str, why: str) -> None:
        super().__init__(message)
        self.why = why


def _utc_now() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


@dataclass(frozen=True)
class SessionMeta:
    """Patient and session metadata (``/session``). ``patient_id`` is an identifier, no name."""

    patient_id: str = ""
    side: str = ""  # "L", "R" or ""
    operator: str = ""
    notes: str = ""

    def __post_init__(self) -> None:
        if self.side not in ("L", "R", ""):
            raise ValueError(f"side must be 'L', 'R' or '', got {self.side!r}")


# a /device attribute's value (None given for one is stored as "")
DeviceValue: TypeAlias = str | int | float | bool


def device_info(identity: Identity | None, transport: str) -> dict[str, DeviceValue]:
    """The ``/device`` attributes from the unit's IDENTITY answer and the transport's name."""
    if identity is None:
        blank: dict[str, DeviceValue] = dict.fromkeys(_DEVICE_KEYS, "")
        return blank | {"transport": transport}
    return {
        "name": identity.name,
        "firmware": identity.firmware,
        "serial": int(identity.serial),
        "side": identity.side,
        "transport": transport,
        "channel_table_id": int(identity.table_id),
        "channel_table_crc": int(identity.table_crc),
    }


@dataclass(frozen=True)
class SessionHeader:
    """Everything known when a recording starts."""

    mode: str  # "raw" | "tilt" | "joint"
    sample_rate_hz: float = 100.0
    meta: SessionMeta = field(default_factory=SessionMeta)
    # str, int, float, bool or None (stored as ""): checked here, as a file's may be anything
    device: Mapping[str, object] = field(default_factory=dict)
    config: PipelineConfig = field(default_factory=PipelineConfig)
    calibration: Calibration = field(default_factory=Calibration.identity)
    created_utc: str = field(default_factory=_utc_now)
    channels: tuple[ChannelSpec, ...] = CHANNELS

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")
        if not (math.isfinite(self.sample_rate_hz) and self.sample_rate_hz > 0):
            raise ValueError(f"sample_rate_hz must be > 0, got {self.sample_rate_hz}")
        device = {str(k): ("" if v is None else v) for k, v in dict(self.device).items()}
        for k, v in device.items():
            if not isinstance(v, str | int | float | bool):
                raise ValueError(f"device[{k!r}] must be a str or a number, got {type(v)}")
        object.__setattr__(self, "device", device)

    def as_dict(self) -> dict[str, object]:
        """JSON-able form: the journal's header record, and what every file attribute is."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "software_version": __version__,
            "mode": self.mode,
            "sample_rate_hz": float(self.sample_rate_hz),
            "created_utc": self.created_utc,
            "session": asdict(self.meta),
            "device": dict(self.device),
            "channels": [c.as_dict() for c in self.channels],
            "config": self.config.as_dict(),
            "event_delay_samples": self.config.event_delay_samples,
            "calibration": self.calibration.as_dict(),
        }

    @classmethod
    def from_dict(cls, record: Mapping[str, object]) -> SessionHeader:
        """The header of :meth:`as_dict`'s form (a journal's header record, parsed): a damaged
        one fails where the constructors it feeds check their arguments."""
        d = cast("Mapping[str, Any]", record)
        return cls(
            mode=d["mode"],
            sample_rate_hz=float(d["sample_rate_hz"]),
            meta=SessionMeta(**d.get("session", {})),
            device=d.get("device", {}),
            config=PipelineConfig.from_stored(d["config"]),
            calibration=Calibration.from_dict(d["calibration"]),
            created_utc=d.get("created_utc", ""),
            channels=tuple(ChannelSpec(**c) for c in d.get("channels", [])) or CHANNELS,
        )

    @property
    def table(self) -> ChannelTable:
        return DEFAULT_TABLE if self.channels == CHANNELS else ChannelTable(self.channels)
