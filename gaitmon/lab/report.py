"""Markdown reports with PNG figures for ``gaitmon lab`` (matplotlib's Agg canvas, no Qt).

Figures are drawn on ``matplotlib.figure.Figure`` objects directly -- no pyplot, so no global
state, no GUI backend is ever selected (gaitmon.lab must stay Qt-free) and it is thread-safe.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # matplotlib is imported lazily, only when a figure is drawn
    from matplotlib.figure import Figure

# paper 000's colour convention: red = accelerometer, green = Kalman, blue = gyro integration
COLOURS = {
    "truth": "black",
    "accelerometer": "tab:red",
    "kalman": "tab:green",
    "gyro": "tab:blue",
    "complementary": "tab:orange",
    "adaptive": "tab:purple",
    "exponential": "tab:orange",
    "constant-rate": "tab:brown",
}


def fmt(x: Any, digits: int = 4) -> str:
    """A number for a table: NaN -> 'undefined', complex -> a +- bi, floats to ``digits`` sig."""
    if isinstance(x, str):
        return x
    if isinstance(x, complex | np.complexfloating):
        z = complex(x)
        if abs(z.imag) < 1e-12:
            return fmt(z.real, digits)
        sign = "+" if z.imag >= 0 else "-"
        return f"{fmt(z.real, digits)} {sign} {fmt(abs(z.imag), digits)}i"
    if isinstance(x, bool | np.bool_):
        return "yes" if x else "no"
    if isinstance(x, int | np.integer):
        return str(int(x))
    v = float(x)
    if np.isnan(v):
        return "undefined"
    if v != 0 and (abs(v) >= 1e6 or abs(v) < 1e-3):
        return f"{v:.{digits - 1}e}"
    return f"{v:.{digits}g}" if abs(v) >= 1 else f"{v:.{digits}f}".rstrip("0").rstrip(".")


@dataclass
class Report:
    """A Markdown document under construction plus the figures it references."""

    title: str
    out_dir: Path
    stem: str
    lines: list[str] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    numbers: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.lines.append(f"# {self.title}\n")

    def heading(self, text: str, level: int = 2) -> None:
        self.lines.append(f"{'#' * level} {text}\n")

    def para(self, text: str) -> None:
        self.lines.append(text.strip() + "\n")

    def bullets(self, items: Iterable[str]) -> None:
        self.lines.extend(f"- {item}" for item in items)
        self.lines.append("")

    def table(self, header: Sequence[str], rows: Iterable[Sequence[Any]], digits: int = 4) -> None:
        self.lines.append("| " + " | ".join(header) + " |")
        self.lines.append("|" + "|".join("---" for _ in header) + "|")
        for row in rows:
            self.lines.append("| " + " | ".join(fmt(c, digits) for c in row) + " |")
        self.lines.append("")

    def figure(self, fig: Figure, name: str, caption: str) -> Path:
        path = self.out_dir / f"{self.stem}_{name}.png"
        fig.savefig(path, dpi=100)
        self.figures.append(path)
        self.lines.append(f"![{caption}]({path.name})\n")
        self.lines.append(f"*{caption}*\n")
        return path

    def write(self) -> Path:
        path = self.out_dir / f"{self.stem}.md"
        path.write_text("\n".join(self.lines).rstrip() + "\n", encoding="utf-8")
        return path


def new_figure(
    rows: int = 1, cols: int = 1, height_in: float = 3.2, width_in: float = 9.0
) -> tuple[Figure, np.ndarray]:
    """(figure, (rows, cols) object array of Axes) on the Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in * rows), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False)
    return fig, axes
