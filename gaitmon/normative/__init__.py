"""Normative bands for the gait-cycle plots: the CSV format of ``docs/normative-format.md``,
GCD files (:mod:`gaitmon.normative.gcd`), and the deviation of a patient's mean from a band.

A normative band is a reference mean ± SD per joint over the gait cycle (0-100 %, 101 points,
the same grid as ``gaitmon.analysis.cycles``), drawn behind a patient's curves in the review
window and the clinical report. gaitmon ships no normative data (no reference curves with a
licence that allows shipping and numbers readable from here were found; see
``docs/normative-format.md``), so the user supplies a file (and its source) explicitly. This
module reads and writes the format and never guesses a missing value.

Qt-free (numpy only), so the report command and the tests use it headless.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from gaitmon.normative.bands import (
    JOINT_KEYS,
    N_POINTS,
    NormativeBands,
    NormativeError,
)
from gaitmon.normative.gcd import ACCEPTED_NAMES, is_gcd_text, parse_gcd

__all__ = [
    "ACCEPTED_NAMES",
    "CAVEAT",
    "CYCLE_COLUMN",
    "DEVIATION_LABEL",
    "EXAMPLE_METADATA",
    "EXAMPLE_PREAMBLE",
    "JOINT_KEYS",
    "N_POINTS",
    "REQUIRED_METADATA",
    "NormativeBands",
    "NormativeError",
    "deviation_deg",
    "format_normative",
    "is_gcd_text",
    "load",
    "load_normative",
    "parse_gcd",
    "parse_normative",
    "simulated_example",
    "write_normative",
]

CYCLE_COLUMN = "cycle_pct"
REQUIRED_METADATA: tuple[str, ...] = ("source", "licence")


def _number(text: str, line_no: int, column: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise NormativeError(
            f"line {line_no}, column {column}: {text.strip()!r} is not a number"
        ) from None
    if not math.isfinite(v):
        raise NormativeError(f"line {line_no}, column {column}: {text.strip()!r} is not finite")
    return v


def parse_normative(text: str, name: str = "normative file") -> NormativeBands:
    """Parse the CSV text of a normative file (see ``docs/normative-format.md``)."""
    metadata: dict[str, str] = {}
    data_lines: list[tuple[int, str]] = []
    for line_no, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            body = stripped[1:].strip()
            if ":" in body:
                key, value = body.split(":", 1)
                key = key.strip().lower()
                if key and " " not in key:
                    # several lines with one key (a long licence text) are joined
                    metadata[key] = (metadata[key] + " " if key in metadata else "") + value.strip()
            continue
        data_lines.append((line_no, line))
    if not data_lines:
        raise NormativeError(f"{name}: no header row (expected {CYCLE_COLUMN},hip_mean_deg,...)")
    missing_meta = [k for k in REQUIRED_METADATA if not metadata.get(k)]
    if missing_meta:
        raise NormativeError(
            f"{name}: missing metadata line '# {missing_meta[0]}: ...' "
            "(say where the values come from and under which licence)"
        )
    header_no, header_line = data_lines[0]
    header = [h.strip() for h in next(csv.reader([header_line]))]
    dupes = sorted({h for h in header if header.count(h) > 1})
    if dupes:
        raise NormativeError(f"{name}: column {dupes[0]!r} appears twice in the header")
    if CYCLE_COLUMN not in header:
        raise NormativeError(
            f"{name}: missing column {CYCLE_COLUMN!r} in the header (line {header_no})"
        )
    given = []
    for joint in JOINT_KEYS:
        mean_col, sd_col = f"{joint}_mean_deg", f"{joint}_sd_deg"
        if (mean_col in header) != (sd_col in header):
            have, lack = (mean_col, sd_col) if mean_col in header else (sd_col, mean_col)
            raise NormativeError(f"{name}: column {have!r} has no matching {lack!r}")
        if mean_col in header:
            given.append(joint)
    if not given:
        raise NormativeError(
            f"{name}: missing columns: need at least one of hip/knee/ankle as "
            "<joint>_mean_deg and <joint>_sd_deg"
        )
    rows = data_lines[1:]
    if len(rows) != N_POINTS:
        raise NormativeError(
            f"{name}: wrong length: {len(rows)} data rows, expected {N_POINTS} "
            f"({CYCLE_COLUMN} 0, 1, ..., 100)"
        )
    cycle = np.empty(N_POINTS)
    mean = np.full((N_POINTS, len(JOINT_KEYS)), np.nan)
    sd = np.full((N_POINTS, len(JOINT_KEYS)), np.nan)
    col = {h: k for k, h in enumerate(header)}
    for r, (line_no, line) in enumerate(rows):
        cells = next(csv.reader([line]))
        if len(cells) != len(header):
            raise NormativeError(
                f"{name}: line {line_no} has {len(cells)} values, the header has {len(header)}"
            )
        cycle[r] = _number(cells[col[CYCLE_COLUMN]], line_no, CYCLE_COLUMN)
        for j, joint in enumerate(JOINT_KEYS):
            if joint not in given:
                continue
            mean[r, j] = _number(cells[col[f"{joint}_mean_deg"]], line_no, f"{joint}_mean_deg")
            s = _number(cells[col[f"{joint}_sd_deg"]], line_no, f"{joint}_sd_deg")
            if s < 0:
                raise NormativeError(f"line {line_no}, column {joint}_sd_deg: SD {s:g} is negative")
            sd[r, j] = s
    expected = np.arange(N_POINTS, dtype=np.float64)
    bad = np.flatnonzero(np.abs(cycle - expected) > 1e-6)
    if bad.size:
        k = int(bad[0])
        raise NormativeError(
            f"{name}: line {rows[k][0]}: {CYCLE_COLUMN} is {cycle[k]:g}, expected {k} "
            f"(rows must be 0, 1, ..., 100)"
        )
    return NormativeBands(expected, mean, sd, metadata)


def load_normative(path: str | os.PathLike[str], side: str | None = None) -> NormativeBands:
    """Read a normative band: a GCD file (``.gcd``, or text starting with ``#!DST`` or a
    ``!Name`` line) or the CSV format. Raises :class:`NormativeError` with a one-line message.

    ``side`` ('left' / 'right') picks a GCD file's side-prefixed curves; the CSV has no sides.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise NormativeError(f"{p.name} does not exist; check the file name and folder") from None
    except IsADirectoryError:
        raise NormativeError(f"{p.name} is a folder; choose a .csv or .gcd file") from None
    except OSError as e:
        raise NormativeError(f"cannot read {p.name}: {e.strerror or e}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        if p.suffix.lower() != ".gcd":
            raise NormativeError(f"{p.name} is not UTF-8 text; save it as UTF-8 CSV") from None
        text = raw.decode("latin-1")  # GCD files from older lab software are often Latin-1
    if p.suffix.lower() == ".gcd" or is_gcd_text(text):
        bands = parse_gcd(text, p.name, side)
    else:
        bands = parse_normative(text, p.name)
    return NormativeBands(bands.cycle_pct, bands.mean_deg, bands.sd_deg, bands.metadata, p)


load = load_normative  # the one entry point for every format


# Where a band is drawn, what it cannot tell: lab normal data are anatomical joint angles from
# marker models; gaitmon's are sagittal segment-tilt differences zeroed at standing.
CAVEAT = (
    "gaitmon's angles are sagittal only, zeroed at the standing pose, and its hip is the thigh "
    "relative to the trunk (not the pelvis), so a marker lab's normal data may sit a few "
    "degrees apart"
)
DEVIATION_LABEL = "sagittal GVS-like deviation, deg"


def deviation_deg(mean_deg: np.ndarray, bands: NormativeBands) -> np.ndarray:
    """(3,) per joint: the RMS distance over the 101 cycle points between a patient's mean
    cycle ``mean_deg`` (101, 3) and the band's mean, in degrees.

    A sagittal variant of the Gait Variable Score (Baker et al. 2009: RMS difference from the
    reference mean over the cycle), on gaitmon's 101 points; NaN for a joint the band does not
    give or the patient's mean lacks. Not the Gait Profile Score nor the Gait Deviation Index.
    """
    m = np.asarray(mean_deg, dtype=np.float64)
    if m.shape != (N_POINTS, len(JOINT_KEYS)):
        raise ValueError(f"mean_deg must have shape ({N_POINTS}, {len(JOINT_KEYS)})")
    d = m - bands.mean_deg
    out = np.sqrt(np.mean(d * d, axis=0))
    out[~np.all(np.isfinite(d), axis=0)] = np.nan
    return out


def format_normative(bands: NormativeBands, decimals: int = 3, preamble: Sequence[str] = ()) -> str:
    """The CSV text of ``bands``: ``preamble`` comment lines, metadata lines, then the joints
    the bands give."""
    out = io.StringIO()
    for line in preamble:
        out.write(f"# {line}\n")
    for key, value in bands.metadata.items():
        out.write(f"# {key}: {value}\n")
    joints = [j for j in JOINT_KEYS if bands.has(j)]
    header = [CYCLE_COLUMN] + [f"{j}_{w}_deg" for j in joints for w in ("mean", "sd")]
    out.write(",".join(header) + "\n")
    for r in range(N_POINTS):
        cells = [f"{bands.cycle_pct[r]:g}"]
        for j in joints:
            k = JOINT_KEYS.index(j)
            cells += [f"{bands.mean_deg[r, k]:.{decimals}f}", f"{bands.sd_deg[r, k]:.{decimals}f}"]
        out.write(",".join(cells) + "\n")
    return out.getvalue()


def write_normative(
    bands: NormativeBands,
    path: str | os.PathLike[str],
    decimals: int = 3,
    preamble: Sequence[str] = (),
) -> Path:
    p = Path(path)
    p.write_text(format_normative(bands, decimals, preamble), encoding="utf-8")
    return p


EXAMPLE_PREAMBLE: tuple[str, ...] = (
    "EXAMPLE FILE - NOT NORMATIVE DATA. Generated from gaitmon's simulator; regenerate with",
    'python -c "from gaitmon.normative import *; write_normative(simulated_example(), '
    "'docs/normative-example.csv', 2, EXAMPLE_PREAMBLE)\"",
)
EXAMPLE_METADATA: dict[str, str] = {
    "name": "EXAMPLE ONLY - simulated, not normative data",
    "source": "generated by gaitmon's gait simulator (gaitmon.normative.simulated_example, "
    "gaitmon.io.sim.kinematics): mean and SD across simulated subjects whose cadence, stance "
    "fraction and knee swing amplitude were drawn at random; the simulator's curves are shaped "
    "after published adult averages but these numbers describe no real people",
    "licence": "MIT, as gaitmon (generated data, no third-party values)",
    "description": "an example of the file format for demonstrations and tests; do NOT use "
    "it as a clinical reference",
}


def simulated_example(n_subjects: int = 12, seed: int = 0, walk_s: float = 30.0) -> NormativeBands:
    """An *example* band from gaitmon's simulator (see ``EXAMPLE_METADATA``), never normative.

    Each simulated subject walks ``walk_s`` seconds with cadence, stance fraction and knee
    swing scale drawn uniformly (95-125 steps/min, 0.57-0.63, 0.85-1.15); its strides after
    the ramp-in are time-normalised to 101 points and averaged; the band is the mean and
    sample SD of the subjects' averages (the way reference bands are usually built).
    """
    from gaitmon.io.sim.kinematics import GaitConfig, GaitModel

    rng = np.random.default_rng(seed)
    per_subject = []
    for k in range(n_subjects):
        cfg = GaitConfig(
            cadence_steps_min=float(rng.uniform(95.0, 125.0)),
            stance_fraction=float(rng.uniform(0.57, 0.63)),
            knee_swing_scale=float(rng.uniform(0.85, 1.15)),
            seed=seed * 1000 + k,
            standing_s=1.0,
        )
        model = GaitModel(cfg)
        n = int(walk_s * cfg.fs_hz)
        joints = np.degrees(model.evaluate(0, n).joint_rad)
        hs, _ = model.events(0, n)
        strides = []
        for a, b in itertools.pairwise(hs[2:]):  # skip start-up strides
            t = np.linspace(a, b, N_POINTS)
            strides.append(
                np.stack([np.interp(t, np.arange(n), joints[:, j]) for j in range(3)], 1)
            )
        per_subject.append(np.mean(strides, axis=0))
    arr = np.asarray(per_subject)
    return NormativeBands(
        np.arange(N_POINTS, dtype=np.float64),
        arr.mean(axis=0),
        arr.std(axis=0, ddof=1),
        dict(EXAMPLE_METADATA),
    )
