"""A registry of plugins by name: what the tilt methods (:mod:`gaitmon.dsp.methods`) and the
gait-event sources (:mod:`gaitmon.dsp.events`) are listed in.

Registration order is kept (menus and the lab's tables list in it); a second plugin of one
name is refused; an unknown name is a ``ValueError`` that names the choices.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Generic, Protocol, TypeVar


class Named(Protocol):
    @property
    def name(self) -> str: ...


P = TypeVar("P", bound=Named)


class Registry(Generic[P]):
    """Plugins of one kind (``noun``, as messages say it: "tilt method"), by name."""

    def __init__(self, noun: str) -> None:
        self.noun = noun
        self._by_name: dict[str, P] = {}

    def add(self, plugin: P) -> P:
        if plugin.name in self._by_name:
            raise ValueError(f"a {self.noun} named {plugin.name!r} is registered already")
        self._by_name[plugin.name] = plugin
        return plugin

    def remove(self, name: str) -> None:
        self._by_name.pop(name, None)

    def get(self, name: str, among: Iterable[str] | None = None) -> P:
        """The plugin called ``name``, which must be one of ``among`` (default: any)."""
        pool = tuple(self._by_name) if among is None else tuple(among)
        if name not in pool or name not in self._by_name:
            raise ValueError(f"unknown {self.noun} {name!r}; use one of {sorted(pool)}")
        return self._by_name[name]

    def all(self) -> tuple[P, ...]:
        """Every plugin, in registration order."""
        return tuple(self._by_name.values())

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def __iter__(self) -> Iterator[str]:
        return iter(self._by_name)
