"""The method columns of ``gaitmon lab accuracy``'s tables, read from the tilt-method registry
(gaitmon.dsp.methods): every method the app offers, live, and its offline pass where it has one."""

from __future__ import annotations

from dataclasses import dataclass

from gaitmon.dsp.methods import methods


@dataclass(frozen=True)
class Column:
    """One method column of the table: a registered tilt method, live or offline."""

    key: str  # the table's key: "paper", "live", "offline", or a method's name
    method: str  # its name in gaitmon.dsp.methods
    offline: bool
    label: str


# the built-in methods keep the keys, headers and order the table has always had
_BUILT_IN = {
    ("paper", False): ("paper", "Kalman (paper, seed 000)"),
    ("gait-aware", False): ("live", "gait-aware Kalman (live)"),
    ("gait-aware", True): ("offline", "gait-aware + RTS smoother (offline)"),
}


def columns() -> tuple[Column, ...]:
    """The table's method columns, read from the registry: each method the app offers, and its
    offline pass where it has one."""
    out = []
    for m in methods(live=True):
        for offline in (False, True) if m.has_offline else (False,):
            key, label = _BUILT_IN.get((m.name, offline), (
                f"{m.name} (offline)" if offline else m.name,
                str(m.offline_label) if offline else m.label,
            ))  # fmt: skip
            out.append(Column(key, m.name, offline, label))
    order = [k for k, _ in _BUILT_IN.values()]
    return tuple(sorted(out, key=lambda c: order.index(c.key) if c.key in order else len(order)))


def column(key: str) -> Column:
    return next(c for c in columns() if c.key == key)


def labels() -> dict[str, str]:
    """The method columns' headers by key, read from the registry now."""
    return {c.key: c.label for c in columns()}
