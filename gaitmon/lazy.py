"""A package's names imported on first use (PEP 562), one lookup each.

A package ``__init__`` that should not load its modules when it is imported (``gaitmon info``
reads a file without the writer, the simulator or scipy) defines a module ``__getattr__`` that
imports the module holding a name with a plain ``import`` (so the layer test sees the arrow)
and returns :func:`keep` of it: the value is stored in the package's namespace, so later
lookups are plain attribute reads.
"""

from __future__ import annotations

from types import ModuleType


def keep(namespace: dict[str, object], name: str, module: ModuleType) -> object:
    """``module.name``, stored in ``namespace`` (the package's ``globals()``) for later."""
    value = getattr(module, name)
    namespace[name] = value
    return value
