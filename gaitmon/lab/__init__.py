"""``gaitmon lab``: the five papers' filter experiments, reproduced as Markdown reports with PNGs.

Each experiment module (p000 ... p004) has ``run(out_dir, quick=False) -> Report``; the report
holds its Markdown lines, its figures and ``numbers`` (the key figures, for tests). ``quick``
shrinks record lengths and run counts for tests; the conclusions are the same.
Qt-free: figures are drawn with matplotlib's Agg canvas (gaitmon.lab.report).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from gaitmon.lab.report import Report

EXPERIMENTS: dict[str, str] = {
    "p000": "tilt filters on the simulated walking unit (paper 000)",
    "p001": "6-state constant-rate Kalman and its accuracy metric (paper 001)",
    "p002": "3-state PVA Kalman: published gains, poles, q sweep, gravity (paper 002)",
    "p003": "complementary filter at rest and its adaptive cut-off (paper 003)",
    "p004": "Kalman vs exponential filter vs sampling period (paper 004)",
}


def run_experiment(name: str, out_dir: Path, quick: bool = False) -> Report:
    """Run one experiment and write its report; returns the written Report."""
    if name not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {name!r}; use one of: all, {', '.join(EXPERIMENTS)}")
    report = _experiment(name)(Path(out_dir), quick=quick)
    report.write()
    return report


def _experiment(name: str) -> Callable[..., Report]:
    """The experiment's ``run`` (its module imported here, plainly: only the one asked for)."""
    if name == "p000":
        from gaitmon.lab import p000

        return p000.run
    if name == "p001":
        from gaitmon.lab import p001

        return p001.run
    if name == "p002":
        from gaitmon.lab import p002

        return p002.run
    if name == "p003":
        from gaitmon.lab import p003

        return p003.run
    if name == "p004":
        from gaitmon.lab import p004

        return p004.run
    raise ValueError(f"unknown experiment {name!r}")


def run_all(
    names: list[str], out_dir: Path, quick: bool = False, progress: Callable[[str], None] = print
) -> dict[str, Report]:
    reports = {}
    for name in names:
        progress(f"{name}: {EXPERIMENTS[name]} ...")
        reports[name] = run_experiment(name, out_dir, quick)
        progress(
            f"{name}: wrote {Path(out_dir) / (name + '.md')} and "
            f"{len(reports[name].figures)} figure(s)"
        )
    return reports
