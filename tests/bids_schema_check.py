"""A small BIDS checker for the tests: the machine-readable BIDS schema (bidsschematools, the
rules the bids-validator itself runs) applied to a dataset's sidecars and columns.

What it checks, each from the schema rather than from gaitmon's own tables:

* ``dataset_description.json``: ``rules.json.dataset.dataset_description`` and
  ``dataset_authors`` (required and recommended fields present), every key a defined
  metadata field of the right type;
* ``*_motion.json``: ``rules.sidecars.motion``: required fields present, recommended ones
  present unless listed in ``allowed_missing`` (the caller says why each is left out), every
  key a defined metadata field (no custom keys: the legacy validator's code 55), type, enum,
  minimum (``n/a`` only where the schema's addendum allows it);
* ``*_channels.tsv``: ``rules.tabular_data.motion.motionChannels``: initial columns in order,
  required and recommended columns, no undefined column; every cell of a column with an enum
  in it (``n/a`` only in a column that is not required, and where the column's description
  allows it), numbers where the type is number; every ``reference_frame`` level described in
  ``*_channels.json`` with the enums of RotationRule/RotationOrder;
* ``*_events.tsv``: the initial columns, numeric onsets and durations (>= 0), every column
  described in the events sidecar;
* ``participants.tsv``: its initial column;
* every file name (``bids_validator.BIDSValidator``) except what ``.bidsignore`` lists.
"""

from __future__ import annotations

import csv
import fnmatch
import json
from pathlib import Path
from typing import Any

_TYPES: dict[str, tuple[type, ...]] = {
    "number": (int, float), "integer": (int,), "string": (str,), "array": (list,),
    "object": (dict,),
}  # fmt: skip


def _level(value: Any) -> str:
    return value if isinstance(value, str) else value["level"]


def _n_a_allowed(rule: Any) -> bool:
    """The schema's addendum says a field "takes value n/a" when not available."""
    text = "" if isinstance(rule, str) else str(rule.get("description_addendum", ""))
    return "`n/a`" in text


def _check_value(schema: Any, key: str, value: Any, where: str, n_a: bool) -> list[str]:
    meta = schema.objects.metadata.get(key)
    if meta is None:
        return [f"{where}: {key} is not a BIDS metadata field"]
    if n_a and value == "n/a":
        return []
    errors = []
    kind = meta.get("type")
    if kind in _TYPES and (not isinstance(value, _TYPES[kind]) or isinstance(value, bool)):
        errors.append(f"{where}: {key} should be {kind}, is {value!r}")
    if "enum" in meta and value not in meta["enum"]:
        errors.append(f"{where}: {key} {value!r} not in {list(meta['enum'])}")
    if "minimum" in meta and isinstance(value, (int, float)) and value < meta["minimum"]:
        errors.append(f"{where}: {key} {value!r} < {meta['minimum']}")
    if kind == "array" and isinstance(value, list) and "items" in meta:
        item = meta["items"].get("type")
        if item in _TYPES and not all(isinstance(v, _TYPES[item]) for v in value):
            errors.append(f"{where}: {key} items should be {item}")
    return errors


def _sidecar(schema: Any, path: Path, groups: dict[str, Any],
             allowed_missing: frozenset[str]) -> list[str]:
    data = json.loads(path.read_text(encoding="utf-8"))
    rules: dict[str, Any] = {}
    for group in groups.values():
        rules.update(group["fields"])
    errors = []
    for key, rule in rules.items():
        level = _level(rule)
        if key not in data and (level == "required" or (level == "recommended"
                                                        and key not in allowed_missing)):
            errors.append(f"{path.name}: {level} {key} missing")
        if key in data and level == "deprecated":
            errors.append(f"{path.name}: {key} is deprecated")
    for key, value in data.items():
        errors += _check_value(schema, key, value, path.name, _n_a_allowed(rules.get(key, "")))
    return errors


def _tsv(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f, delimiter="\t")
        rows = list(reader)
        return list(reader.fieldnames or []), rows


def _channels(schema: Any, path: Path) -> list[str]:
    rule = schema.rules.tabular_data.motion.motionChannels
    name = {k: k.split("__")[0] for k in rule.columns}
    head, rows = _tsv(path)
    errors = []
    initial = [name[k] for k in rule.initial_columns]
    if head[: len(initial)] != initial:
        errors.append(f"{path.name}: initial columns {head[:len(initial)]} != {initial}")
    for key, level in rule.columns.items():
        if _level(level) in ("required", "recommended") and name[key] not in head:
            errors.append(f"{path.name}: {_level(level)} column {name[key]} missing")
    defined = {name[k]: k for k in rule.columns}
    for column in head:
        if column not in defined:
            errors.append(f"{path.name}: column {column} is not defined for motion channels")
            continue
        definition = schema.objects.columns[defined[column]]
        required = _level(rule.columns[defined[column]]) == "required"
        n_a_ok = not required and "n/a" in str(definition.get("description", ""))
        for row in rows:
            value = row[column]
            if value == "n/a" and (n_a_ok or "enum" not in definition) and not required:
                continue
            if "enum" in definition and value not in definition["enum"]:
                errors.append(f"{path.name}: {column} {value!r} of {row['name']} not in "
                              f"{list(definition['enum'])}")  # fmt: skip
            if definition.get("type") == "number":
                try:
                    float(value)
                except ValueError:
                    errors.append(f"{path.name}: {column} {value!r} is not a number")
            if required and value in ("", "n/a") and "enum" not in definition:
                errors.append(f"{path.name}: required {column} of {row['name']} is {value!r}")
    if "reference_frame" in head:
        side = path.with_name(path.name.replace("_channels.tsv", "_channels.json"))
        levels = {}
        if side.is_file():
            levels = json.loads(side.read_text(encoding="utf-8")).get(
                "reference_frame", {}).get("Levels", {})
        for frame in {r["reference_frame"] for r in rows} - {"n/a"}:
            if frame not in levels:
                errors.append(f"{path.name}: reference_frame {frame!r} not described in "
                              f"{side.name}")  # fmt: skip
                continue
            for key, value in levels[frame].items():
                errors += _check_value(schema, key, value, side.name, False)
    return errors


def _events(schema: Any, path: Path) -> list[str]:
    head, rows = _tsv(path)
    errors = []
    initial = list(schema.rules.tabular_data.events.Events.initial_columns)
    if head[:2] != initial:
        errors.append(f"{path.name}: initial columns {head[:2]} != {initial}")
    for row in rows:
        for column, minimum in (("onset", None), ("duration", 0.0)):
            try:
                v = float(row[column])
            except ValueError:
                if row[column] != "n/a":
                    errors.append(f"{path.name}: {column} {row[column]!r} is not a number")
                continue
            if minimum is not None and v < minimum:
                errors.append(f"{path.name}: {column} {v} < {minimum}")
    described = path.with_name(path.name.replace(".tsv", ".json"))
    if described.is_file():
        known = set(json.loads(described.read_text(encoding="utf-8")))
        for column in head:
            if column not in known and column not in schema.objects.columns:
                errors.append(f"{path.name}: column {column} is not described")
    return errors


def ignored(root: Path) -> list[str]:
    """The patterns of ``root/.bidsignore`` (comments and blank lines left out)."""
    path = root / ".bidsignore"
    if not path.is_file():
        return []
    lines = path.read_text(encoding="utf-8").splitlines()
    return [x.strip() for x in lines if x.strip() and not x.lstrip().startswith("#")]


def is_ignored(rel: str, patterns: list[str]) -> bool:
    return any(fnmatch.fnmatch(Path(rel).name, p) or fnmatch.fnmatch(rel, p) for p in patterns)


def check_dataset(root: Path, allowed_missing: frozenset[str] = frozenset()) -> list[str]:
    """Every error the schema's rules find in the dataset at ``root`` ([] for none)."""
    from bids_validator import BIDSValidator
    from bidsschematools.schema import load_schema

    schema = load_schema()
    errors: list[str] = []
    desc = root / "dataset_description.json"
    groups = {"d": schema.rules.json.dataset.dataset_description}
    if not (root / "CITATION.cff").exists():  # the rule's selector: then Authors is recommended
        groups["a"] = schema.rules.json.dataset.dataset_authors
    errors += _sidecar(schema, desc, groups, allowed_missing)
    patterns = ignored(root)
    validator = BIDSValidator()
    for p in sorted(root.rglob("*")):
        if not p.is_file():
            continue
        rel = "/" + p.relative_to(root).as_posix()
        if is_ignored(rel.lstrip("/"), patterns) or p.name == ".bidsignore":
            continue
        if not validator.is_bids(rel):
            errors.append(f"{rel}: not a BIDS file name")
        if p.parent.name == "motion":
            if p.name.endswith("_motion.json"):
                errors += _sidecar(schema, p, dict(schema.rules.sidecars.motion),
                                   allowed_missing)  # fmt: skip
            elif p.name.endswith("_channels.tsv"):
                errors += _channels(schema, p)
            elif p.name.endswith("_events.tsv"):
                errors += _events(schema, p)
    head, _ = _tsv(root / "participants.tsv")
    want = list(schema.rules.tabular_data.modality_agnostic.Participants.initial_columns)
    if head[:1] != want:
        errors.append(f"participants.tsv: initial columns {head[:1]} != {want}")
    return errors
