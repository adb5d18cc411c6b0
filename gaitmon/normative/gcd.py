"""Normal data from GCD ("gait cycle data") files, the ASCII format clinical gait labs keep it in.

GCD is one lexicon of the CAMARC DST text format (Vicon Clinical Manager, Polygon, GaitLab,
Visual3D exports). What this reader relies on, as seen in published files and readers:

* an optional first line ``#!DST-0.1 GCD <writer>`` naming the format;
* ``$SECTION`` lines (``$PREFIXES``, ``$REFERENCE`` ...) followed by text lines (``Left``,
  ``Right``, ``AVERAGE:1:4``): kept as metadata, never read as data;
* ``!Name`` lines starting a variable, sometimes with a trailing number (``!HipFlexExt 3``);
  the name may carry a side prefix (``!LeftHipFlexExt``, ``!RightKneeFlexExt``);
* the variable's numbers on the following lines: 51 points (every 2 % of the cycle, Vicon's
  normal data) or 101 (every 1 %), either **two columns per line, mean and SD** (the normal-data
  layout), or one curve whose SD is a second variable ``<Name>_SD`` / ``<Name>SD``.

Only the sagittal hip, knee and ankle curves are used (``ACCEPTED_NAMES``); other variables
(pelvis, rotations, moments, scalars such as ``!Cadence``) are skipped. 51 points are
resampled to gaitmon's 101 linearly on the cycle (the even points are the file's values, each
odd point the mean of its two neighbours). Qt-free, numpy only.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from gaitmon.normative.bands import JOINT_KEYS, N_POINTS, NormativeBands, NormativeError

# sagittal variable names per joint, lower case, without side prefix. The first of each row is
# the Vicon/Plug-in Gait name found in normal-data GCD files; the others are spelled-out aliases.
# Every one has gaitmon's clinical sign: hip flexion +, knee flexion +, ankle dorsiflexion +.
ACCEPTED_NAMES: dict[str, tuple[str, ...]] = {
    "hip": ("hipflexext", "hipflexionextension", "hipflexion"),
    "knee": ("kneeflexext", "kneeflexionextension", "kneeflexion"),
    "ankle": ("dorsiplanflex", "ankledorsiplanflex", "ankledorsiflexionplantarflexion",
              "ankleflexionextension", "ankledorsiflexion"),
}  # fmt: skip
SIDES = ("left", "right")
GCD_POINTS = (51, 101)
_SD_SUFFIX = re.compile(r"_?sd$", re.IGNORECASE)
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


@dataclass
class _Variable:
    name: str  # as written, without '!'
    line_no: int
    rows: list[tuple[int, list[float]]] = field(default_factory=list)  # (line number, numbers)


def _split_side(name: str) -> tuple[str, str]:
    """'LeftKneeFlexExt' -> ('left', 'kneeflexext'); no prefix -> ('', name)."""
    low = name.lower()
    for side in SIDES:
        if low.startswith(side) and len(low) > len(side):
            return side, low[len(side) :]
    return "", low


def _joint_of(base: str) -> str | None:
    for joint, names in ACCEPTED_NAMES.items():
        if base in names:
            return joint
    return None


def is_gcd_text(text: str) -> bool:
    """Whether ``text`` looks like a GCD file: a ``#!DST`` header or a ``!Name`` line before
    any CSV-like line."""
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("#!DST") or s.startswith("!"):
            return True
        if s.startswith("#") or s.startswith("$"):
            continue
        return False
    return False


def _read(text: str, name: str) -> tuple[list[_Variable], dict[str, str]]:
    variables: list[_Variable] = []
    meta: dict[str, str] = {}
    current: _Variable | None = None
    section = ""
    for line_no, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#!DST"):
            meta["gcd_header"] = s[2:].strip()
            continue
        if s.startswith("#"):
            continue
        if s.startswith("$"):
            section, current = s[1:].strip().lower(), None
            continue
        if s.startswith("!"):
            parts = s[1:].split()
            if not parts:
                raise NormativeError(f"{name}: line {line_no}: '!' without a variable name")
            current = _Variable(parts[0], line_no)
            variables.append(current)
            section = ""
            continue
        tokens = s.replace(",", " ").split()
        if current is None:
            if section:  # the text lines of a $SECTION
                meta[f"gcd_{section}"] = (meta.get(f"gcd_{section}", "") + " " + s).strip()
                continue
            raise NormativeError(
                f"{name}: line {line_no}: {s[:30]!r} before any '!Name' variable line"
            )
        if not all(_NUMBER.match(t) for t in tokens):
            bad = next(t for t in tokens if not _NUMBER.match(t))
            raise NormativeError(
                f"{name}: line {line_no} (variable {current.name}): {bad!r} is not a number"
            )
        values = [float(t) for t in tokens]
        if not all(math.isfinite(v) for v in values):
            raise NormativeError(f"{name}: line {line_no}: a value is not finite")
        current.rows.append((line_no, values))
    return variables, meta


def _resample(values: np.ndarray) -> np.ndarray:
    """51 or 101 points on 0..100 % -> 101 points, linear on the cycle."""
    if len(values) == N_POINTS:
        return values
    return np.interp(np.arange(N_POINTS), np.linspace(0.0, 100.0, len(values)), values)


def _curve(var: _Variable, name: str) -> tuple[np.ndarray, np.ndarray | None]:
    """A variable's (mean, SD or None) at its own number of points."""
    widths = {len(v) for _, v in var.rows}
    if widths == {2} and len(var.rows) in GCD_POINTS:
        arr = np.array([v for _, v in var.rows])
        return arr[:, 0], arr[:, 1]
    flat = np.array([x for _, v in var.rows for x in v])
    if len(flat) in GCD_POINTS:  # one curve, one or several values per line
        return flat, None
    if widths - {1, 2}:
        wide = next((ln, v) for ln, v in var.rows if len(v) not in (1, 2))
        raise NormativeError(
            f"{name}: line {wide[0]} (variable {var.name}): {len(wide[1])} numbers; expected "
            "one value, or mean and SD, per line"
        )
    raise NormativeError(
        f"{name}: variable {var.name} (line {var.line_no}) has {len(var.rows)} data lines "
        f"({len(flat)} numbers); expected 51 or 101 points (one per line, or mean and SD per line)"
    )


def parse_gcd(text: str, name: str = "GCD file", side: str | None = None) -> NormativeBands:
    """Normal data (mean ± SD of hip, knee, ankle flexion) from GCD text.

    ``side`` ('left' / 'right') picks side-prefixed variables when the file has both; without
    it, unprefixed names come first, then the only side present, then Left (noted in the
    metadata).
    """
    variables, meta = _read(text, name)
    by_key: dict[tuple[str, str], _Variable] = {}  # (side, base name) -> variable
    for var in variables:
        s, base = _split_side(var.name)
        if (s, base) in by_key:
            raise NormativeError(
                f"{name}: line {var.line_no}: variable {var.name} appears twice "
                f"(first at line {by_key[(s, base)].line_no})"
            )
        by_key[(s, base)] = var
    found: dict[str, dict[str, _Variable]] = {}  # joint -> side -> mean variable
    for (s, base), var in by_key.items():
        joint = _joint_of(base)
        if joint is not None:
            found.setdefault(joint, {}).setdefault(s, var)
    if not found:
        accepted = ", ".join(ns[0] for ns in ACCEPTED_NAMES.values())
        raise NormativeError(
            f"{name}: no hip, knee or ankle flexion variable; expected one of "
            f"!HipFlexExt, !KneeFlexExt, !DorsiPlanFlex (or aliases; accepted: {accepted}, ...)"
        )
    sides_present = {s for per in found.values() for s in per}
    if side is not None:
        side = side.lower()
        if side not in SIDES:
            raise NormativeError(f"side must be 'left' or 'right', not {side!r}")
        chosen = side if side in sides_present else ""
    elif "" in sides_present:
        chosen = ""
    elif len(sides_present) == 1:
        chosen = next(iter(sides_present))
    else:
        chosen = "left"
        meta["gcd_side_note"] = "the file has Left and Right curves; the Left ones are used"
    mean = np.full((N_POINTS, len(JOINT_KEYS)), np.nan)
    sd = np.full((N_POINTS, len(JOINT_KEYS)), np.nan)
    points: set[int] = set()
    for j, joint in enumerate(JOINT_KEYS):
        mv = found.get(joint, {}).get(chosen)
        if mv is None:
            continue
        m, s_ = _curve(mv, name)
        if s_ is None:
            base = _split_side(mv.name)[1]
            sd_var = next((v for (vs, vb), v in by_key.items()
                           if vs == chosen and _SD_SUFFIX.sub("", vb) == base and vb != base),
                          None)  # fmt: skip
            if sd_var is None:
                raise NormativeError(
                    f"{name}: variable {mv.name} (line {mv.line_no}) has no SD: normal data "
                    f"needs mean and SD per line, or a !{mv.name}_SD variable"
                )
            s_, extra = _curve(sd_var, name)
            if extra is not None or len(s_) != len(m):
                raise NormativeError(
                    f"{name}: variable {sd_var.name} (line {sd_var.line_no}) must have one "
                    f"value per point, {len(m)} like {mv.name}"
                )
        neg = np.flatnonzero(s_ < 0)
        if neg.size:
            raise NormativeError(
                f"{name}: variable {mv.name}: SD {s_[neg[0]]:g} at point {int(neg[0]) + 1} is "
                "negative"
            )
        points.add(len(m))
        mean[:, j], sd[:, j] = _resample(m), _resample(s_)
    used = [JOINT_KEYS[j] for j in range(len(JOINT_KEYS)) if np.isfinite(mean[0, j])]
    if not used:
        raise NormativeError(
            f"{name}: no hip, knee or ankle flexion variable for the {side} side; the file has "
            + ", ".join(sorted(s or "unprefixed" for s in sides_present))
        )
    stem = name.rsplit(".", 1)[0]
    how = " and ".join(f"{p}" for p in sorted(points)) + " points per cycle"
    meta.setdefault("name", f"{stem} (GCD)")
    meta["source"] = (
        f"GCD file {name}"
        + (f" ({meta['gcd_header']})" if "gcd_header" in meta else "")
        + f": {', '.join(used)} flexion"
        + (f", {chosen} side" if chosen else "")
        + (f" ({meta['gcd_side_note']})" if "gcd_side_note" in meta else "")
        + f"; {how}"
        + (", resampled linearly to 101" if 51 in points else "")
    )
    meta["licence"] = "not stated (GCD files carry no licence; ask the lab that supplied it)"
    return NormativeBands(np.arange(N_POINTS, dtype=np.float64), mean, sd, meta)
