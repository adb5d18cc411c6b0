"""Leave-one-trial-out: report a figure that depends on a parameter fitted on a dataset.

A parameter fitted on the same trials it is judged on flatters itself. :func:`loto` fits on all
trials but one, judges the one left out with that fit, for every trial in turn: the figure a
new recording would get. :func:`in_sample` is the flattering version, for the table beside it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TypeVar

T = TypeVar("T")
P = TypeVar("P")
R = TypeVar("R")


def loto(
    trials: Sequence[T], fit: Callable[[Sequence[T]], P], evaluate: Callable[[T, P], R]
) -> list[R]:
    """``evaluate(trials[i], fit(every trial but i))`` for each i (needs >= 2 trials)."""
    if len(trials) < 2:
        raise ValueError("leave-one-trial-out needs at least two trials")
    return [
        evaluate(t, fit([u for j, u in enumerate(trials) if j != i])) for i, t in enumerate(trials)
    ]


def in_sample(
    trials: Sequence[T], fit: Callable[[Sequence[T]], P], evaluate: Callable[[T, P], R]
) -> list[R]:
    """``evaluate(trial, fit(all trials))`` for each trial (fitted on what it is judged on)."""
    params = fit(trials)
    return [evaluate(t, params) for t in trials]
