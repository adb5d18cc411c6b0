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
# what a method registered by name says of itself before it is built (its class's ``live``,
# ``label`` and ``reads_settings``, checked when it is built): the app's names are listed, and
# a file's settings read and shown (``gaitmon info``), without building any method
_DECLARED: dict[str, tuple[bool, str, tuple[str, ...]]] = {}
# the app's default tilt method (PipelineConfig, new recordings); its offline pass computes the
# files' smoothed angles (/smoothed)
DEFAULT_METHOD = "gait-aware"


def register(method: TiltMethod) -> TiltMethod:
    """Add ``method`` under its ``name`` (a second method of one name is refused)."""
    return REGISTRY.add(method)


def register_lazy(
    name: str, build: Callable[[], TiltMethod], live: bool, label: str,
    reads_settings: tuple[str, ...] = (),
) -> None:  # fmt: skip
    """Add the method called ``name``, built by ``build()`` when first asked for (its module
    imported then). ``live`` (whether the app offers it), ``label`` and ``reads_settings`` are
    its class's, said before it is built; building it checks that its class says the same."""
    declared = (live, label, tuple(reads_settings))

    def checked() -> TiltMethod:
        method = build()
        actual = (method.live, method.label, tuple(method.reads_settings))
        if actual != declared:
            raise ValueError(f"tilt method {name!r} is registered as (live, label, "
                             f"reads_settings) {declared}, its class says {actual}")  # fmt: skip
        return method

    REGISTRY.add_lazy(name, checked)
    _DECLARED[name] = declared


def unregister(name: str) -> None:
    """Remove a method (tests that register a throw-away one)."""
    REGISTRY.remove(name)
    _DECLARED.pop(name, None)


def _said(name: str) -> tuple[bool, str, tuple[str, ...]]:
    """(live, label, reads_settings) of a registered method, built or not."""
    method = REGISTRY.built(name)
    if method is None:
        return _DECLARED[name]
    return method.live, method.label, tuple(method.reads_settings)


def check_method(name: str, *, live: bool = False) -> None:
    """Refuse (the ValueError :func:`get_method` gives) a name that is no method, or with
    ``live`` none the app offers, without building it."""
    REGISTRY.check(name, live_names() if live else None)


def settings_read_by(name: str) -> tuple[str, ...]:
    """The pipeline settings the method ``name`` reads (its ``reads_settings``), unbuilt."""
    REGISTRY.check(name)
    return _said(name)[2]


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

    chosen = [name for name in REGISTRY if _said(name)[0]]
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
    """The name shown to users and stored in files for a method (live or offline); a live
    one's without building the method."""
    if not offline:
        REGISTRY.check(name)
        return _said(name)[1]
    m = get_method(name, offline)
    return m.offline_label if offline and m.offline_label is not None else m.label


def feeds_smoother(name: str) -> bool:
    """Whether the pipeline's tilts by method ``name`` are the smoother's first pass, bit for
    bit (gaitmon.dsp.smoother.CausalFirstPass runs the default's causal filter)."""
    return name == DEFAULT_METHOD
