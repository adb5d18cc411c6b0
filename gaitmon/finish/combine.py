"""Combining a bilateral recording's two parts into the one session file.

Each part (``FILE.L.partial``, ``FILE.R.partial``: :mod:`.parts`) is a complete single-unit
recording. :func:`combine_parts` recovers a part from its journal first if it was interrupted
(the single-unit recovery), fits each unit's clock against the host clock over the whole
recording (``gaitmon.dsp.clock_fit.fit_clock``), copies each part's whole layout under
``/units/<side>`` with h5py's group copy (nothing is re-processed) and writes ``/sync``. The
combined file is written as ``FILE.combining``, synced and moved over ``FILE``; the parts are
deleted last, so an interrupted combine loses nothing. A part whose bytes cannot be recovered
does not block the other: it is set aside unchanged (``FILE.<side>.partial.damaged``) and the
file holds the intact leg, naming the other in its ``missing`` attributes.
``docs/file-format.md`` ("Bilateral sessions") is the reference.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from gaitmon import __version__
from gaitmon.dsp.clock_fit import (
    MAX_PAIR_PPM,
    WINDOW_S,
    ClockFit,
    bent_pair_ppm,
    fit_clock,
    pair_disagreement_ppm,
)
from gaitmon.io.journal_files import journal_path
from gaitmon.io.session.attributes import describe
from gaitmon.io.session.h5file import _being_recorded, _fsync_path, _short_error
from gaitmon.io.session.header import DamagedSource, SessionError
from gaitmon.io.session.layout import FORMAT, FORMAT_VERSION
from gaitmon.io.session.parts import PROBE_ERRORS, SIDE_NAMES, SIDES, damaged_path, parts_of
from gaitmon.io.session.series import attr_text

SYNC_METHOD = (
    "host receive time against the unit's /timeline/t_s: one lower-envelope line per window "
    "(gaitmon.dsp.clock_fit)"
)
SEGMENT_DTYPE = np.dtype([
    ("unit_start_s", "<f8"), ("unit_stop_s", "<f8"), ("host_s", "<f8"),
    ("host_s_per_unit_s", "<f8"),
])  # fmt: skip

Progress = Callable[[float], bool | None] | None




def _ready(part: Path, progress: Progress) -> None:
    """The part as a finished file: recovered from its journal if it was interrupted (as
    ``open_session`` does; a journal beside a finished file is a left-over, deleted)."""
    jpath = journal_path(part)
    if not jpath.exists():
        if not part.exists():
            raise SessionError(f"{part.name} is missing")
        return
    if _being_recorded(jpath):
        raise SessionError(
            f"{part.name} is being recorded right now; open it after the recording stops"
        )
    if part.exists():
        done = False
        with contextlib.suppress(*PROBE_ERRORS), h5py.File(part, "r") as f:
            done = bool(f.attrs.get("complete", False) or f.attrs.get("recovered", False))
        if done:
            jpath.unlink()
            return
    from gaitmon.finish.recovery import recover_session

    recover_session(part, progress)


def _touch(_name: str, obj: Any) -> None:
    """Read an object's attributes (None: ``visititems`` goes on to the next object)."""
    dict(obj.attrs)


def _stamps(f: h5py.File) -> tuple[np.ndarray, np.ndarray]:
    """A part's (unit time, host receive time) of each row it holds."""
    a = f.attrs
    t = f["timeline/t_s"]
    h = f["timeline/host_time_s"]
    n = min(t.shape[0], h.shape[0])
    if a.get("complete", False) or a.get("recovered", False):
        n = min(n, int(a.get("n_samples", n)))
    return t[:n], h[:n]


def _part_info(part: Path) -> tuple[dict[str, Any], ClockFit]:
    try:
        with h5py.File(part, "r") as f:
            a = f.attrs
            t, h = _stamps(f)
            n = len(t)
            info = {
                "complete": bool(a.get("complete", False)),
                "recovered": bool(a.get("recovered", False)),
                "created": attr_text(a.get("created_utc", "")),
                "fs": float(a["sample_rate_hz"]),
                "mode": attr_text(a.get("mode", "")),
                "first": float(t[0]) if n else np.nan,
                "last": float(t[-1]) if n else np.nan,
                "serial": f["device"].attrs.get("serial", ""),
            }
            # every object's header and attributes, as the group copy will read them (a
            # damaged header fails here, and the part is set aside, not the combine stopped)
            f.visititems(_touch)
    except (PermissionError, FileNotFoundError) as e:  # the bytes may be fine: try again later
        raise SessionError(f"cannot read {part.name} ({_short_error(e)})") from e
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as e:
        raise DamagedSource(f"{part.name} is damaged ({_short_error(e)})") from e
    return info, fit_clock(t, h)


def _agreed(parts: dict[str, Path], fits: dict[str, ClockFit]) -> str:
    """Two fits that disagree beyond two crystals (``bent_pair_ppm``) were bent by receive
    times late for much of the recording (a host that fell behind): the leg whose times sat
    further above its line (median) is fitted again at the other's rate, only its offsets
    from its data. ``fits`` is changed in place; the warning the file keeps ("" if none)."""
    if len(fits) != 2 or not all(len(f.x0_s) for f in fits.values()):
        return ""
    (sa, fa), (sb, fb) = fits.items()
    ppm = pair_disagreement_ppm(fa, fb)
    if not abs(ppm) > bent_pair_ppm(fa, fb):  # (NaN: too short to judge, or no rate)
        return ""
    bad, good = (sa, sb) if fa.residual_p50_ms > fb.residual_p50_ms else (sb, sa)
    late = fits[bad].residual_p50_ms
    try:
        with h5py.File(parts[bad], "r") as f:
            t, h = _stamps(f)
        fits[bad] = fit_clock(t, h, slope_s_per_s=fits[good].mean_slope)
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as e:  # read a moment ago
        raise SessionError(f"cannot read {parts[bad].name} ({_short_error(e)})") from e
    return (
        f"the units' clock fits disagreed by {abs(ppm):.0f} ppm (two units differ by less than "
        f"{MAX_PAIR_PPM:.0f}): the {SIDE_NAMES[bad]} unit's data arrived late for much of the "
        f"recording (median {late:.0f} ms above its line), so its clock runs at the "
        f"{SIDE_NAMES[good]} unit's rate, only its offset fitted; the legs' relative timing "
        "may be off by the late data's delay"
    )


def _usable(
    path: Path, parts: dict[str, Path], progress: Progress
) -> tuple[dict[str, dict[str, Any]], dict[str, ClockFit], dict[str, str]]:
    """(info, clock fit) of each part that can be recovered and read, and why each other leg
    is missing. A part whose bytes are damaged is set aside (``damaged_path``) with its
    journal, never deleted; anything that may pass (a recording still running, a full disk)
    raises ``SessionError`` and leaves the parts as they are."""
    info: dict[str, dict[str, Any]] = {}
    fits: dict[str, ClockFit] = {}
    damaged: dict[str, str] = {}
    for side, p in parts.items():
        try:
            _ready(p, progress)
            info[side], fits[side] = _part_info(p)
        except DamagedSource as e:
            damaged[side] = str(e)
        except SessionError as e:
            raise SessionError(f"{path.name}, {SIDE_NAMES[side]} leg: {e}") from e
        except (ValueError, KeyError, TypeError, IndexError) as e:  # a journal that lies
            damaged[side] = f"cannot recover {p.name} ({_short_error(e)})"
    if damaged and not info:
        raise SessionError(
            f"{path.name}: neither leg can be recovered ("
            + "; ".join(f"{SIDE_NAMES[s]}: {why}" for s, why in damaged.items())
            + "); the parts are kept beside it"
        )
    missing: dict[str, str] = {}
    for side in SIDES:
        aside = damaged_path(path, side)
        if side in damaged:
            try:
                for src, dst in ((parts[side], aside), (journal_path(parts[side]),
                                                        journal_path(aside))):  # fmt: skip
                    if src.exists():
                        os.replace(src, dst)
            except OSError as e:
                raise SessionError(
                    f"{path.name}: cannot set the damaged {SIDE_NAMES[side]} part aside "
                    f"({_short_error(e)}); the parts are kept beside it"
                ) from e
            missing[side] = f"{damaged[side]}; its bytes are kept in {aside.name}"
        elif side not in parts and aside.exists():  # set aside before an interrupted combine
            missing[side] = f"its part was damaged; its bytes are kept in {aside.name}"
    return info, fits, missing


def combine_parts(path: str | os.PathLike[str], progress: Progress = None) -> Path:
    """Combine the parts beside ``path`` into the one session file ``path`` (module doc).

    A part that cannot be recovered (its bytes damaged) does not block the other: the file
    holds the intact leg, names the other in its ``missing`` attributes, and the damaged part
    is set aside as ``FILE.<side>.partial.damaged`` (never deleted). ``SessionError`` if there
    is no part, neither can be recovered, or one cannot be recovered now (a full disk: the
    parts are kept then)."""
    path = Path(path)
    parts = parts_of(path)
    if not parts:
        raise SessionError(f"{path.name} has no recorded parts to combine")
    info, fits, missing = _usable(path, parts, progress)
    clock_warning = _agreed(parts, fits)
    usable = {side: fit for side, fit in fits.items() if len(fit.x0_s)}
    if usable:
        # common time 0: the first sample of the unit that started first; its seconds are the
        # units' mean clock (host seconds / the mean slope), so a simulator running faster
        # than real time, and the host clock's own rate, drop out
        host_t0 = min(float(fit.host_at(info[s]["first"])) for s, fit in usable.items())
        host_end = max(float(fit.host_at(info[s]["last"])) for s, fit in usable.items())
        scale = float(np.mean([fit.mean_slope for fit in usable.values()]))
    else:
        host_t0, host_end, scale = 0.0, 0.0, 1.0
    first = next(iter(info.values()))
    created = sorted(i["created"] for i in info.values() if i["created"])
    tmp = path.with_name(path.name + ".combining")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    try:
        with h5py.File(tmp, "w") as dst:
            a = dst.attrs
            a["format"] = FORMAT
            a["format_version"] = FORMAT_VERSION
            a["bilateral"] = True
            a["sides"] = " ".join(info)
            a["missing"] = " ".join(missing)
            for side, why in missing.items():
                a[f"missing_{side}"] = why
            a["created_utc"] = created[0] if created else ""
            a["sample_rate_hz"] = first["fs"]
            a["software_version"] = __version__
            a["mode"] = first["mode"]
            a["complete"] = len(info) == 2 and all(i["complete"] for i in info.values())
            a["recovered"] = any(i["recovered"] for i in info.values())
            a["duration_s"] = (host_end - host_t0) / scale + 1.0 / first["fs"] if usable else 0.0
            units = dst.create_group("units")
            for side in info:
                with h5py.File(parts[side], "r") as src:
                    src.copy(src["/"], units, name=side)
            sync = dst.create_group("sync")
            sync.attrs["host_t0_s"] = host_t0
            sync.attrs["host_s_per_common_s"] = scale
            sync.attrs["window_s"] = WINDOW_S
            sync.attrs["method"] = SYNC_METHOD
            sync.attrs["warning"] = clock_warning  # "" when the fits agree (_agreed)
            for side, fit in fits.items():
                seg = np.zeros(len(fit.x0_s), SEGMENT_DTYPE)
                seg["unit_start_s"], seg["unit_stop_s"] = fit.x0_s, fit.x1_s
                seg["host_s"], seg["host_s_per_unit_s"] = fit.host_s, fit.slope
                g = sync.create_group(side)
                g.create_dataset("segments", data=seg)
                g.attrs["residual_p50_ms"] = fit.residual_p50_ms
                g.attrs["residual_p95_ms"] = fit.residual_p95_ms
                g.attrs["serial"] = info[side]["serial"]
            describe(dst)  # (the units' own were copied with them: /sync's)
        _fsync_path(tmp)
        os.replace(tmp, path)
        _fsync_path(path.parent, directory=True)
    except BaseException as e:  # the half-written file never stays
        with contextlib.suppress(OSError):
            tmp.unlink()
        if not isinstance(e, PROBE_ERRORS):  # h5py's, as its errors come
            raise
        raise SessionError(
            f"cannot write {path.name} ({_short_error(e)}); its parts are kept beside it and "
            "are combined when it is next opened"
        ) from e
    for side in info:
        with contextlib.suppress(OSError):
            parts[side].unlink()
    return path


def finish_parts(path: str | os.PathLike[str], progress: Progress = None) -> None:
    """Combine left-over parts (the process died before the combine), or delete them (it
    died after the combined file was in place, while deleting them)."""
    path = Path(path)
    parts = parts_of(path)
    if not parts:
        return
    if path.exists():
        done = False
        with contextlib.suppress(*PROBE_ERRORS), h5py.File(path, "r") as f:
            done = bool(f.attrs.get("bilateral", False))
        if done:
            for p in parts.values():
                if not journal_path(p).exists():
                    with contextlib.suppress(OSError):
                        p.unlink()
            return
    combine_parts(path, progress)
