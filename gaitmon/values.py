"""Plain values as they travel between a session file, JSON and the exports (standard library only).

:data:`JsonValue` is what ``json.dump`` writes and an export's metadata holds: strings, numbers,
booleans, None, and lists and mappings of them. It is read-only (``Sequence``/``Mapping``), so a
``dict[str, str]`` or a ``list[float]`` is one as it is; :data:`JsonObject` is the ``dict`` a
builder fills. :func:`scalar` narrows a value that should be a number or text for ``int()``,
``float()`` or ``str()``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TypeAlias, cast

__all__ = ["JsonObject", "JsonValue", "scalar"]

JsonValue: TypeAlias = (
    "str | int | float | bool | Sequence[JsonValue] | Mapping[str, JsonValue] | None"
)
JsonObject: TypeAlias = "dict[str, JsonValue]"


def scalar(value: object) -> str | int | float:
    """A value that should hold a number (or text): a JSON value, an HDF5 attribute, for
    ``int()`` / ``float()``, which fail on anything else as they always did (the caller turns
    that into its message, e.g. the reader's damaged-file one)."""
    return cast("str | int | float", value)
