"""BIDS export, the dataset-level files: ``dataset_description.json``, the ``README`` (made
from every recording in the dataset), ``.bidsignore`` (gaitmon's own per-recording metadata)
and the one-line hint about what only the user can fill in (Authors, License).

gaitmon's own metadata of a recording (mode, the angles' method and convention, what a row
is, the two legs' common time line) are not BIDS fields: as custom keys in ``_motion.json``
the legacy bids-validator refuses them (code 55, a JSON schema error). They go to a file
beside the recording, ``..._tracksys-<label>_gaitmon.json``, that ``.bidsignore`` (the
mechanism both validators read, .gitignore syntax) hides from validation; every BIDS file
stays plain BIDS.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from gaitmon import __version__
from gaitmon.export.writers.bids_labels import BidsOptions
from gaitmon.values import JsonObject

BIDS_VERSION = "1.9.0"
DATASET_TYPE = "raw"  # why raw, not derivative: see README_HEAD
GAITMON_SUFFIX = "gaitmon.json"  # ..._tracksys-<label>_gaitmon.json, listed in .bidsignore
BIDSIGNORE_LINES = ("# gaitmon's own metadata of each recording (not BIDS fields; README)",
                    f"*_{GAITMON_SUFFIX}")  # fmt: skip
_TRACKSYS = re.compile(r"_tracksys-([0-9A-Za-z]+)_")


def dataset_description(options: BidsOptions) -> JsonObject:
    """Authors and License only as the user gave them: gaitmon cannot know either."""
    desc: JsonObject = {
        "Name": "gaitmon gait recordings",
        "BIDSVersion": BIDS_VERSION,
        "DatasetType": DATASET_TYPE,
    }
    if options.license:
        desc["License"] = options.license
    if options.author_list:
        desc["Authors"] = list(options.author_list)
    desc["GeneratedBy"] = [{"Name": "gaitmon", "Version": __version__,
                            "Description": "gaitmon export --format bids"}]  # fmt: skip
    return desc


def missing_description_fields(root: Path) -> list[str]:
    """Fields of ``root/dataset_description.json`` only the user can fill (Authors, License)
    that it lacks; [] if it has them or cannot be read (then it is not gaitmon's to judge)."""
    import json

    try:
        desc = json.loads((root / "dataset_description.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    if not isinstance(desc, dict):
        return []
    return [k for k in ("Authors", "License") if not desc.get(k)]


def description_hint(root: Path) -> str | None:
    """One line telling the user what to fill in, or None."""
    missing = missing_description_fields(root)
    if not missing:
        return None
    return (f"{root / 'dataset_description.json'} has no {' or '.join(missing)}: fill them in "
            "there (or give --bids-authors 'A. Author; B. Author' and --bids-license CC0 when "
            "exporting into a new dataset folder)")


def bidsignore_text(path: Path) -> str:
    """``path``'s lines (a study's own) with gaitmon's added where missing."""
    have = path.read_text(encoding="utf-8").splitlines() if path.exists() else []
    lines = have + [x for x in BIDSIGNORE_LINES if x not in have]
    return "\n".join(lines) + "\n"


def is_gaitmon_readme(path: Path) -> bool:
    """A README gaitmon wrote (regenerated at every export) rather than the study's own."""
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline().rstrip("\n") == README_HEAD.splitlines()[0]
    except (OSError, UnicodeDecodeError):
        return False


def recording_kinds(root: Path, planned: Iterable[Path]) -> set[int]:
    """How many tracking systems (units) each recording in the dataset has: {1}, {2} or both.
    A recording is a ``_motion.json`` file's name less its tracksys entity; ``planned`` are
    the ``_motion.json`` files of the export under way (not written yet)."""
    systems: dict[tuple[str, str], set[str]] = {}
    for p in [*root.glob("sub-*/**/motion/*_motion.json"), *planned]:
        m = _TRACKSYS.search(p.name)
        if m:
            key = (p.parent.as_posix(), _TRACKSYS.sub("_", p.name))
            systems.setdefault(key, set()).add(m.group(1))
    return {len(s) for s in systems.values()}


def readme_text(root: Path, planned: Iterable[Path]) -> str:
    """The dataset's README, describing every kind of recording in it (one unit, both legs)."""
    kinds = recording_kinds(root, planned)
    text = README_HEAD
    if 1 in kinds:
        text += README_ONE
    if any(k >= 2 for k in kinds):
        text += README_BOTH
    return text + README_TAIL


README_HEAD = """\
Gait recordings exported by gaitmon (Motion-BIDS, BIDS 1.9, datatype "motion").

Each gaitmon unit is one tracking system, named by the leg it was worn on: tracksys-imuL (left)
or tracksys-imuR (right); tracksys-imu when no side was entered. A unit has four planar
inertial sensors (body, thigh, shank, foot; accelerometer x and z, gyro about the
mediolateral axis y), a heel and a toe force sensor, and gaitmon's segment tilts and joint
angles computed from them. _channels.tsv lists every column of _motion.tsv with its type,
tracked point, placement, reference frame (described in _channels.json) and units.
"""

README_ONE = """
Recordings of one leg have one tracking system (the leg's unit) and one _events.tsv.
Rows: _motion.tsv has no header. Row k is the time k / SamplingFrequency from the first
sample. Frames the wireless link lost are rows of n/a at their true place, so the sampling is
regular, and each loss is also a "gap" event in _events.tsv (duration = time lost).
SamplingFrequencyEffective is the unit's frames per second of the recording computer's clock
(a straight-line fit of the frames' receive times).
"""

README_BOTH = """
Recordings of both legs have two tracking systems, tracksys-imuL and tracksys-imuR (one unit
on each leg), and one _events.tsv for both (column "side"). Both _motion.tsv files are on one
time line: each unit's samples were resampled linearly onto it by the fit of its own clock
(the units' crystals differ by tens of ppm), so row k of either is the same instant, k /
SamplingFrequency from the first sample of the unit that started first. Rows where a unit had
not started, had stopped, or lost frames are n/a. SamplingFrequencyEffective is the rows per
second of the recording computer's clock.
"""

README_TAIL = """
Events: heel_strike, toe_off (gait events), marker (set by the clinician; text in "label"),
gap. onset = sample / SamplingFrequency, where sample is the 0-based row of _motion.tsv.

gaitmon's own metadata of each recording (unit mode, the method behind the angles and their
sign convention, what a row is, the two legs' common time line) are in
..._tracksys-<label>_gaitmon.json beside it: they are not BIDS fields, so .bidsignore lists
these files for the validators.

DatasetType is "raw": the series are what the recording system outputs (calibrated,
low-passed inertial signals and its orientation estimates), as BIDS motion data are; the
unit's ADC counts remain in the gaitmon session files (.h5), which are the source data.

De-identification (the default for BIDS exports): subject labels come from the user (a label
or a patient-id-to-label map), never from the patient id unless asked; no patient id,
operator, notes, device serial or recording date is written (n/a marks what is left out).
No _scans.tsv is written then (its acq_time would date the recording): times count from the
start of each recording only.

This README is rewritten by every gaitmon export into this folder; replace it with your own
text (any first line but this file's) and gaitmon leaves it alone.
"""
