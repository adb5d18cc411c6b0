"""BIDS export options and labels: which subject, session and task a recording is filed under.

The subject label is the one piece of a BIDS dataset that could name the patient, so it is
never taken from the session file unless the user asks for it (``subject_from_patient_id``):
it comes from ``subject`` (one label), or from ``subject_map``, a file the user keeps that maps
patient ids to labels, or else it is ``01``. Kept free of numpy (the command line builds these).
"""

from __future__ import annotations

import csv
import hashlib
import re
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, cast

from gaitmon.export.writers.errors import ExportError

DEFAULT_SUBJECT = "01"  # when no label is given: says nothing about the patient
DEFAULT_TASK = "walk"
_LABEL = re.compile(r"[0-9A-Za-z]+")
_MAP_HEADERS = {"patient_id", "patient", "participant_id", "label", "subject"}
# participants.tsv: with --subject-from-patient-id, which patient id made the label (its
# SHA-256, not the id: the label keeps only its letters and digits, the hash no more), so a later
# export of another id that gives the same label ("a/b", "ab", "a-b": sub-ab) is refused
PATIENT_HASH_COLUMN = "patient_id_sha256"


def patient_hash(patient_id: str) -> str:
    return hashlib.sha256(str(patient_id).strip().encode("utf-8")).hexdigest()


def check_label(kind: str, value: str) -> str:
    """A BIDS label (letters and digits only); ``sub-01`` is accepted for subject ``01``."""
    prefix = {"subject": "sub-", "session": "ses-", "task": "task-"}[kind]
    text = str(value).strip()
    if text.startswith(prefix):
        text = text[len(prefix):]
    if not _LABEL.fullmatch(text):
        raise ExportError(
            f"BIDS {kind} label {value!r} must be letters and digits only (e.g. 01)"
        )
    return text


@dataclass(frozen=True)
class BidsOptions:
    """What ``gaitmon export --format bids`` is told besides the file (all optional)."""

    subject: str | None = None  # the subject label
    subject_map: Path | None = None  # a TSV/CSV file: patient id -> subject label
    subject_from_patient_id: bool = False  # label = the patient id (letters and digits kept)
    session: str | None = None  # a ses-<label> level, if given
    task: str = DEFAULT_TASK
    # dataset_description.json of a new dataset: never invented (left out when not given)
    authors: str | tuple[str, ...] | None = None  # "A. Author; B. Author" or a sequence
    license: str | None = None  # e.g. CC0, CC-BY-4.0 (SPDX abbreviations)

    @classmethod
    def from_mapping(cls, options: Mapping[str, object] | None) -> BidsOptions:
        """Options as given to ``export_session(options=...)`` (any values: the dataclass's
        fields are checked below and by the label checks); None values are left out."""
        # the fields' own types are what the command line and the export dialog give
        given = cast("dict[str, Any]", {k: v for k, v in (options or {}).items() if v is not None})
        known = [f.name for f in fields(cls)]
        for key in given:
            if key not in known:
                raise ExportError(f"BIDS export has no option {key!r} (it has {', '.join(known)})")
        if "subject_map" in given:
            given["subject_map"] = Path(given["subject_map"])
        if isinstance(given.get("authors"), (list, tuple)):
            given["authors"] = tuple(str(a) for a in given["authors"])
        opts = cls(**given)
        chosen = [opts.subject is not None, opts.subject_map is not None,
                  bool(opts.subject_from_patient_id)]  # fmt: skip
        if sum(chosen) > 1:
            raise ExportError(
                "give only one of --subject, --subject-map and --subject-from-patient-id"
            )
        if opts.subject is not None:
            check_label("subject", opts.subject)
        if opts.session is not None:
            check_label("session", opts.session)
        check_label("task", opts.task)
        return opts

    def subject_label(self, patient_id: str) -> str:
        """The subject label of the session whose patient id is ``patient_id``."""
        pid = str(patient_id).strip()
        if self.subject is not None:
            return check_label("subject", self.subject)
        if self.subject_map is not None:
            table = read_subject_map(self.subject_map)
            if not pid:
                raise ExportError(
                    f"the session has no patient id to look up in {self.subject_map.name}; "
                    "give a subject label instead (--subject LABEL)"
                )
            if pid not in table:
                # the id itself is not repeated: a message may end up in a log
                raise ExportError(
                    f"{self.subject_map.name} has no row for this session's patient id; "
                    "add one (patient_id<TAB>label)"
                )
            return table[pid]
        if self.subject_from_patient_id:
            label = re.sub(r"[^0-9A-Za-z]", "", pid)
            if not label:
                raise ExportError(
                    "the session's patient id has no letters or digits to use as a subject "
                    "label; give a subject label instead (--subject LABEL)"
                )
            return label
        return DEFAULT_SUBJECT

    def participant_row(self, patient_id: str) -> dict[str, str]:
        """The session's row of participants.tsv (with the patient id's hash when the label
        is made from it)."""
        row = {"participant_id": f"sub-{self.subject_label(patient_id)}"}
        if self.subject_from_patient_id:
            row[PATIENT_HASH_COLUMN] = patient_hash(patient_id)
        return row

    def check_subject_free(self, participants: Path, patient_id: str) -> None:
        """With --subject-from-patient-id, refuse to file this patient under a subject that
        the dataset (its participants.tsv) already gives to another patient id: different ids
        can give one label ("a/b", "ab" and "a-b" are all sub-ab)."""
        if not self.subject_from_patient_id or not participants.is_file():
            return
        row = self.participant_row(patient_id)
        try:
            with open(participants, encoding="utf-8", newline="") as f:
                rows = list(csv.DictReader(f, delimiter="\t"))
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            raise ExportError(f"cannot read {participants}: {exc}") from None
        for r in rows:
            if r.get("participant_id") != row["participant_id"]:
                continue
            theirs = (r.get(PATIENT_HASH_COLUMN) or "").strip()
            if theirs and theirs != "n/a" and theirs != row[PATIENT_HASH_COLUMN]:
                raise ExportError(
                    f"BIDS subject {row['participant_id']} in {participants.parent} is already "
                    f"another patient, whose id also gives that label (this patient id is "
                    f"{str(patient_id).strip()!r}: ids such as 'a/b', 'ab' and 'a-b' give one "
                    "label); give --subject LABEL or --subject-map FILE for this patient"
                )

    @property
    def session_label(self) -> str | None:
        return None if self.session is None else check_label("session", self.session)

    @property
    def task_label(self) -> str:
        return check_label("task", self.task)

    @property
    def author_list(self) -> tuple[str, ...]:
        """The authors, one per entry (a string is split at ';')."""
        raw = self.authors or ()
        parts = raw.split(";") if isinstance(raw, str) else raw
        return tuple(a.strip() for a in parts if a.strip())


def read_subject_map(path: Path) -> dict[str, str]:
    """``patient id -> subject label`` from a two-column file (tab- or comma-separated, an
    optional header row, ``#`` comments); the label may be written ``07`` or ``sub-07``."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ExportError(f"subject map not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ExportError(f"cannot read the subject map {path}: {exc}") from None
    table: dict[str, str] = {}
    first = True
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = [c.strip() for c in line.split("\t" if "\t" in line else ",")]
        header = first and (cells[0].lower() in _MAP_HEADERS
                            or (len(cells) > 1 and cells[1].lower() in _MAP_HEADERS))
        first = False
        if header:
            continue
        if len(cells) < 2 or not cells[0] or not cells[1]:
            raise ExportError(f"{path.name} line {n}: expected a patient id and a label")
        try:
            label = check_label("subject", cells[1])
        except ExportError as exc:
            raise ExportError(f"{path.name} line {n}: {exc}") from None
        if table.get(cells[0], label) != label:
            raise ExportError(f"{path.name} line {n}: a patient id is given two labels")
        table[cells[0]] = label
    if not table:
        raise ExportError(f"subject map {path} has no rows (patient_id<TAB>label)")
    return table
