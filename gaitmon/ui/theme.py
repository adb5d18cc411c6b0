"""Colours of the live view, following the system's light or dark theme.

The paper's colour code is kept in both themes (red = accelerometer, green = Kalman filter,
blue = gyro integration; FSR red = heel, green = toe); only the shades change so that every
trace stays readable on a dark background. Plot backgrounds come from the application palette,
so pyqtgraph's black default never clashes with a light desktop.
"""

from __future__ import annotations

from dataclasses import dataclass

import pyqtgraph as pg
from PySide6.QtGui import QColor, QGuiApplication, QPalette, QPen

from gaitmon.dsp.channel_table import SEGMENT_TABLE


@dataclass(frozen=True)
class Colours:
    dark: bool
    background: QColor
    foreground: QColor
    grid_alpha: float
    acc: QColor  # accelerometer (paper: red)
    kalman: QColor  # Kalman filter (paper: green)
    gyro: QColor  # gyro integration (paper: blue)
    heel: QColor  # FSR heel (paper: red)
    toe: QColor  # FSR toe (paper: green)
    event: QColor  # heel-strike / toe-off lines on the angle plots
    marker: QColor  # clinician markers
    current: QColor  # the current stride in the cycle overlay
    band: QColor  # mean +- SD bands and the review timeline's view region
    segments: tuple[QColor, ...]  # per SEGMENTS entry (raw traces), from the channel table
    phases: tuple[QColor, QColor, QColor]  # loading, foot flat, push-off shading
    stance: QColor  # stance shading in the two-phase view

    @property
    def ok(self) -> str:
        return "#3fb950" if self.dark else "#1a7f37"

    @property
    def warn(self) -> str:
        return "#d29922" if self.dark else "#9a6700"

    @property
    def alert(self) -> str:
        return "#f85149" if self.dark else "#cf222e"


def _c(hex_rgb: str, alpha: int = 255) -> QColor:
    c = QColor(hex_rgb)
    c.setAlpha(alpha)
    return c


def system_is_dark() -> bool:
    """True when the desktop uses a dark theme (explicit scheme, else the palette's lightness)."""
    app = QGuiApplication.instance()
    if app is None:
        return False
    try:
        from PySide6.QtCore import Qt

        scheme = QGuiApplication.styleHints().colorScheme()
        if scheme == Qt.ColorScheme.Dark:
            return True
        if scheme == Qt.ColorScheme.Light:
            return False
    except AttributeError:  # Qt < 6.5: no colour-scheme hint
        pass
    return QGuiApplication.palette().color(QPalette.ColorRole.Window).lightness() < 128


def current_colours() -> Colours:
    dark = system_is_dark()
    pal = QGuiApplication.palette()
    bg = pal.color(QPalette.ColorRole.Base)
    fg = pal.color(QPalette.ColorRole.Text)
    # a palette that disagrees with the scheme (some platforms) would make traces unreadable
    if dark and bg.lightness() > 128:
        bg, fg = QColor("#1e1e1e"), QColor("#dcdcdc")
    elif not dark and bg.lightness() < 128:
        bg, fg = QColor("#ffffff"), QColor("#202020")
    if dark:
        return Colours(
            dark=True,
            background=bg,
            foreground=fg,
            grid_alpha=0.18,
            acc=_c("#ff5c5c"),
            kalman=_c("#3ddc5a"),
            gyro=_c("#5ca8ff"),
            heel=_c("#ff5c5c"),
            toe=_c("#3ddc5a"),
            event=_c("#b0b0b0", 150),
            marker=_c("#ffb000"),
            current=_c("#ffffff"),
            band=_c("#5ca8ff", 70),
            segments=tuple(_c(s.colour_dark) for s in SEGMENT_TABLE),
            phases=(_c("#ff8a80", 60), _c("#b0bec5", 55), _c("#80d8ff", 60)),
            stance=_c("#b0bec5", 55),
        )
    return Colours(
        dark=False,
        background=bg,
        foreground=fg,
        grid_alpha=0.25,
        acc=_c("#d62728"),
        kalman=_c("#1f9e3a"),
        gyro=_c("#1f5fd6"),
        heel=_c("#d62728"),
        toe=_c("#1f9e3a"),
        event=_c("#606060", 140),
        marker=_c("#b35c00"),
        current=_c("#111111"),
        band=_c("#1f5fd6", 55),
        segments=tuple(_c(s.colour_light) for s in SEGMENT_TABLE),
        phases=(_c("#ef9a9a", 95), _c("#b0bec5", 110), _c("#81d4fa", 110)),
        stance=_c("#b0bec5", 110),
    )


def configure_pyqtgraph(colours: Colours) -> None:
    """Global pyqtgraph options; call before creating plots (and again on a theme change)."""
    pg.setConfigOptions(
        background=colours.background,
        foreground=colours.foreground,
        antialias=False,  # measured: antialiased live traces redraw ~40x slower
    )


def pen(colour: QColor, *, dashed: bool = False) -> QPen:
    """Width-1 cosmetic pens only: width 2 cut the redraw speed ~5x here."""
    from PySide6.QtCore import Qt

    p: QPen = pg.mkPen(colour, width=1)
    if dashed:
        p.setStyle(Qt.PenStyle.DashLine)
    return p


# the left and right legs' colours: (light theme and print, dark theme)
_SIDE_HEX = {"L": ("#d98200", "#ffa94d"), "R": ("#7e3fa8", "#c28bf0")}


def side_colours(colours: Colours | None = None) -> dict[str, QColor]:
    """The left and right legs' trace colours: orange and purple, in the live view (``colours``:
    its theme) and, with ``None``, on paper (the light theme's: the bilateral report).

    Neither hue is one of the paper's (red accelerometer and heel, green Kalman and toe, blue
    gyro integration), so a leg's colour never reads as a method's. Orange / purple are the
    Okabe-Ito pair that colour-blind readers tell apart. Simulated (Machado et al. 2009, full
    severity), red-green blindness turns them ochre and blue (CIELAB distance ~100 in both
    themes, as without it), blue-yellow blindness salmon and mauve (49 light, 35 dark); in
    grey print orange is the lighter."""
    dark = colours is not None and colours.dark
    return {side: _c(hexes[1] if dark else hexes[0]) for side, hexes in _SIDE_HEX.items()}
