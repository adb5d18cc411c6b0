"""A registry of plugins by name: what the tilt methods (:mod:`gaitmon.dsp.methods`) and the
gait-event sources (:mod:`gaitmon.dsp.events`) are listed in.

Registration order is kept (menus and the lab's tables list in it); a second plugin of one
name is refused; an unknown name is a ``ValueError`` that names the choices.

A plugin may be registered by name with the function that builds it (:meth:`Registry.add_lazy`):
its module is imported when the plugin is first asked for, so that a reader naming one plugin
(``gaitmon info`` reading a file's tilt method) loads that one alone (issue 28).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator
from typing import Generic, Protocol, TypeVar


class Named(Protocol):
    @property
    def name(self) -> str: ...


P = TypeVar("P", bound=Named)


class Registry(Generic[P]):
    """Plugins of one kind (``noun``, as messages say it: "tilt method"), by name."""

    def __init__(self, noun: str) -> None:
        self.noun = noun
        self._by_name: dict[str, P | None] = {}  # None: registered by add_lazy, not built yet
        self._lazy: dict[str, Callable[[], P]] = {}  # name -> its builder, until first asked for
        self._building = threading.Lock()  # two threads asking for one plugin build it once

    def add(self, plugin: P) -> P:
        if plugin.name in self._by_name:
            raise ValueError(f"a {self.noun} named {plugin.name!r} is registered already")
        self._by_name[plugin.name] = plugin
        return plugin

    def add_lazy(self, name: str, build: Callable[[], P]) -> None:
        """Register ``name``, built by ``build()`` (which imports its module) when first asked
        for; the plugin it builds must bear that name."""
        if name in self._by_name:
            raise ValueError(f"a {self.noun} named {name!r} is registered already")
        self._by_name[name] = None  # its place in the order
        self._lazy[name] = build

    def built(self, name: str) -> P | None:
        """The plugin called ``name`` if it is built (None: registered lazily, not asked for)."""
        return self._by_name.get(name)

    def _built(self, name: str) -> P:
        plugin = self._by_name[name]
        if plugin is not None:
            return plugin
        with self._building:
            plugin = self._by_name[name]
            if plugin is None:
                plugin = self._lazy[name]()
                if plugin.name != name:
                    raise ValueError(f"the {self.noun} registered as {name!r} is {plugin.name!r}")
                self._by_name[name] = plugin
                del self._lazy[name]
            return plugin

    def remove(self, name: str) -> None:
        self._by_name.pop(name, None)
        self._lazy.pop(name, None)

    def check(self, name: str, among: Iterable[str] | None = None) -> None:
        """Refuse (ValueError naming the choices) a ``name`` that is not registered or not one
        of ``among`` (default: any), without building it."""
        pool = tuple(self._by_name) if among is None else tuple(among)
        if name not in pool or name not in self._by_name:
            raise ValueError(f"unknown {self.noun} {name!r}; use one of {sorted(pool)}")

    def get(self, name: str, among: Iterable[str] | None = None) -> P:
        """The plugin called ``name``, which must be one of ``among`` (default: any)."""
        self.check(name, among)
        return self._built(name)

    def all(self) -> tuple[P, ...]:
        """Every plugin, in registration order (building those not built yet)."""
        return tuple(self._built(name) for name in list(self._by_name))

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def __iter__(self) -> Iterator[str]:
        return iter(self._by_name)
