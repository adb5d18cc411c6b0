"""The one list of tilt methods: every menu, CLI choice, report and lab table reads it.

``register(method)`` adds a method (gaitmon.dsp.methods registers the built-in ones, in
order, by name: :func:`register_lazy`, each built when first asked for), ``get_method(name)``
finds one (building it alone), ``methods(live=True)`` lists those the app offers (the
default first, then in registration order) and ``methods(live=False)`` the lab-only ones.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from gaitmon.dsp.registry import Registry

if TYPE_CHECKING:  # a method's module imports it when it is built
    from gaitmon.dsp.methods.base import TiltMethod

REGISTRY: Registry[TiltMethod] = Registry("tilt method")
# whether the app offers each method registered by name and not built yet (its class's ``live``,
# checked when it is built): the app's names are listed without building any method
_LIVE: dict[str, bool] = {}
# the app's default tilt method (PipelineConfig, new recordings); its offline pass computes the
# files' smoothed angles (/smoothed)
DEFAULT_METHOD = "gait-aware"


def register(method: TiltMethod) -> TiltMethod:
    """Add ``method`` under its ``name`` (a second method of one name is refused)."""
    return REGISTRY.add(method)


def register_lazy(name: str, build: Callable[[], TiltMethod], live: bool) -> None:
    """Add the method called ``name``, built by ``build()`` when first asked for (its module
    imported then); ``live``: whether the app offers it (its class must say the same)."""

    def checked() -> TiltMethod:
        method = build()
        if method.live != live:
            raise ValueError(f"tilt method {name!r} is registered with live={live}, its class "
                             f"says {method.live}")  # fmt: skip
        return method

    REGISTRY.add_lazy(name, checked)
    _LIVE[name] = live


def unregister(name: str) -> None:
    """Remove a method (tests that register a throw-away one)."""
    REGISTRY.remove(name)
    _LIVE.pop(name, None)


def methods(live: bool | None = None) -> tuple[TiltMethod, ...]:
    """The registered methods; ``live=True`` those the app offers (the default first),
    ``live=False`` the lab-only ones, None all of them in registration order."""
    if live is None:
        return REGISTRY.all()
    chosen = [m for m in REGISTRY.all() if m.live == live]
    return tuple(sorted(chosen, key=lambda m: m.name != DEFAULT_METHOD))


def live_names() -> tuple[str, ...]:
    """The names the app offers (``process --method``, ``PipelineConfig.tilt_method``), as
    :func:`methods` orders them, without building a method."""

    def offered(name: str) -> bool:
        method = REGISTRY.built(name)
        return method.live if method is not None else _LIVE[name]

    chosen = [name for name in REGISTRY if offered(name)]
    return tuple(sorted(chosen, key=lambda name: name != DEFAULT_METHOD))


def get_method(name: str, offline: bool = False, *, live: bool = False) -> TiltMethod:
    """The method called ``name`` (ValueError naming the choices when there is none, when
    ``offline`` and it has no offline pass, or when ``live`` and the app does not offer it)."""
    method = REGISTRY.get(name, live_names() if live else None)
    if offline and not method.has_offline:
        raise ValueError(f"tilt method {name!r} has no offline smoother")
    return method


def by_lab_name() -> dict[str, TiltMethod]:
    """The methods with a filter of the lab's form, by their lab name, in registration order
    (the Filters view's list)."""
    return {m.lab_name: m for m in REGISTRY.all() if m.lab_name is not None}


def smoothing_method() -> TiltMethod:
    """The method whose offline pass gives a file's smoothed angles (the default's)."""
    return get_method(DEFAULT_METHOD, offline=True)


def method_label(name: str, offline: bool = False) -> str:
    """The name shown to users and stored in files for a method (live or offline)."""
    m = get_method(name, offline)
    return m.offline_label if offline and m.offline_label is not None else m.label


def feeds_smoother(name: str) -> bool:
    """Whether the pipeline's tilts by method ``name`` are the smoother's first pass, bit for
    bit (gaitmon.dsp.smoother.CausalFirstPass runs the default's causal filter)."""
    return name == DEFAULT_METHOD
