"""The one list of tilt methods: every menu, CLI choice, report and lab table reads it.

``register(method)`` adds a method (gaitmon.dsp.methods registers the built-in ones, in
order), ``get_method(name)`` finds one, ``methods(live=True)`` lists those the app offers (the
default first, then in registration order) and ``methods(live=False)`` the lab-only ones.
"""

from __future__ import annotations

from gaitmon.dsp.methods.base import TiltMethod
from gaitmon.dsp.registry import Registry

REGISTRY: Registry[TiltMethod] = Registry("tilt method")
# the app's default tilt method (PipelineConfig, new recordings); its offline pass computes the
# files' smoothed angles (/smoothed)
DEFAULT_METHOD = "gait-aware"


def register(method: TiltMethod) -> TiltMethod:
    """Add ``method`` under its ``name`` (a second method of one name is refused)."""
    return REGISTRY.add(method)


def unregister(name: str) -> None:
    """Remove a method (tests that register a throw-away one)."""
    REGISTRY.remove(name)


def methods(live: bool | None = None) -> tuple[TiltMethod, ...]:
    """The registered methods; ``live=True`` those the app offers (the default first),
    ``live=False`` the lab-only ones, None all of them in registration order."""
    if live is None:
        return REGISTRY.all()
    chosen = [m for m in REGISTRY.all() if m.live == live]
    return tuple(sorted(chosen, key=lambda m: m.name != DEFAULT_METHOD))


def live_names() -> tuple[str, ...]:
    """The names the app offers (``process --method``, ``PipelineConfig.tilt_method``)."""
    return tuple(m.name for m in methods(live=True))


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
