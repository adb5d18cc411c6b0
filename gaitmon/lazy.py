"""Names a package exports, imported from their module on first use (PEP 562).

A package whose ``__init__`` re-exported every submodule made any import of it pay for all of
them: reading a session file loaded the writer, the device link and the pipeline's reprocessing.
With ``__getattr__ = lazy_exports(__name__, {name: submodule})`` the package imports nothing
until a name is used; its ``TYPE_CHECKING`` imports keep the names typed for mypy.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, homes: Mapping[str, str]) -> Callable[[str], Any]:
    """A module ``__getattr__`` that finds ``name`` in ``package.<homes[name]>`` (or in
    ``homes[name]`` itself when that is a whole ``gaitmon.…`` module path)."""

    def __getattr__(name: str) -> Any:
        module = homes.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        path = module if module.startswith("gaitmon.") else f"{package}.{module}"
        value = getattr(importlib.import_module(path), name)
        setattr(sys.modules[package], name, value)  # found once; later lookups are plain
        return value

    return __getattr__
