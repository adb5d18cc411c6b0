"""The review window's actions and menus, declared as data.

Each :class:`ReviewActionSpec` names an action (text, shortcut, tip, the slot it calls (a method of
the window or of one of its parts, ``"part.method"``) and with which arguments), the optional
modules it needs and when it is enabled. :data:`MENUS` lays them out; :func:`build_actions`
and :func:`build_menus` turn the table into QActions (through
:func:`gaitmon.ui.actions.make_action`) and menus, and :func:`update_enabled` applies the
``enabled`` rules to the window's state.
"""

from __future__ import annotations

import functools
import importlib.util
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

from PySide6.QtGui import QAction, QActionGroup
from PySide6.QtWidgets import QMainWindow, QMenu

from gaitmon.ui.actions import make_action

# when an action is enabled: always, with a document, with a selected range, with a raw-mode
# document (reprocessing needs the raw counts), with a reprocessed series, with a document that
# has two angle sources (smoothed and live: raw mode), with one leg of a bilateral file shown
Enabled = Literal[
    "always", "document", "selection", "raw", "reprocessed", "angles", "bilateral"
]
SEPARATOR = "-"
RECENT = "@recent"  # the Open recent submenu, filled by the window when it is shown


@dataclass(frozen=True)
class ReviewActionSpec:
    """One review-window action (the live window's are gaitmon.ui.live.actions.ActionSpec)."""

    name: str  # key in the window's action table
    text: str
    slot: str  # the slot it calls: the window's method, or "part.method" of one of its parts
    args: tuple[Any, ...] = ()  # bound before the action's own argument (a checkable's state)
    shortcut: str | None = None
    tip: str = ""
    checkable: bool = False
    checked: bool = False
    enabled: Enabled = "always"
    requires: tuple[str, ...] = ()  # modules the action needs (optional parts of the window)
    group: str = ""  # checkable actions of one group are exclusive (a QActionGroup)


A = ReviewActionSpec
OPEN = A("open", "&Open…", "open_dialog", shortcut="Ctrl+O", tip="Open a recorded session (.h5)")
CLOSE = A("close", "&Close", "close_document", shortcut="Ctrl+W", tip="Close the session",
          enabled="document")  # fmt: skip
OPEN_FOLDER = A("open_folder", "Open &folder…", "comparer.folder_dialog", shortcut="Ctrl+Shift+O",
                tip="List the recordings of a folder by patient and date, to compare or open")
COMPARE_SESSIONS = A(
    "compare_sessions", "Compare &sessions…", "comparer.compare_dialog",
    shortcut="Ctrl+Shift+C", tip="Pick two or more sessions of a patient: their cycles overlaid "
    "and their measures side by side, with the changes", requires=("gaitmon.compare",),
)  # fmt: skip
EXPORT = A("export", "&Export…", "outputs.export_dialog", shortcut="Ctrl+Shift+E",
           tip="Export the session to CSV, MATLAB .mat or C3D", enabled="document",
           requires=("gaitmon.ui.review.export_dialog",))  # fmt: skip
REPORT = A(
    "report", "&Report (PDF)…", "outputs.report_dialog", shortcut="Ctrl+Shift+R",
    tip="One-page clinical report of the recorded series, with the exclusions in force",
    enabled="document", requires=("gaitmon.ui.report_pdf", "gaitmon.report"),
)  # fmt: skip
SAVE_REPROCESSED = A(
    "save_reprocessed", "Save reprocessed as…", "outputs.save_reprocessed_dialog",
    tip="Write a new session file with the reprocessed series (as gaitmon process does); the "
    "recording is not modified",
    enabled="reprocessed",
)  # fmt: skip
QUIT = A("quit", "&Quit", "close", shortcut="Ctrl+Q")

WHOLE = A("whole", "Whole session", "nav.show_whole", shortcut="Ctrl+0",
          tip="Zoom out to everything", enabled="document")  # fmt: skip
ZOOM_IN = A("zoom_in", "Zoom in", "nav.zoom", (0.5,), shortcut="=",
            tip="Zoom in around the cursor",
            enabled="document")  # fmt: skip
ZOOM_OUT = A("zoom_out", "Zoom out", "nav.zoom", (2.0,), shortcut="-", tip="Zoom out",
             enabled="document")  # fmt: skip
LEFT = A("left", "Pan left", "nav.pan", (-0.5,), shortcut="[", tip="Half a view back",
         enabled="document")  # fmt: skip
RIGHT = A("right", "Pan right", "nav.pan", (0.5,), shortcut="]", tip="Half a view forward",
          enabled="document")  # fmt: skip
FIT = A("fit", "Fit y ranges", "nav.fit_y", shortcut="Home", tip="Fit every lane's y range",
        enabled="document")  # fmt: skip
LANES = tuple(
    A(f"lane_{key}", label, "nav.set_lane_visible", (key,), checkable=True, checked=on)
    for key, label, on in (("tilt", "Segment tilt lane", True), ("fsr", "Foot sensor lane", True),
                           ("raw", "Raw channels lane", False))
)
METHODS = (
    A("method_acc", "Joint angles from the accelerometer (red)", "nav.set_method", ("acc",),
      checkable=True),
    A("method_gyro", "Joint angles from gyro integration (blue)", "nav.set_method", ("gyro",),
      checkable=True),
)  # fmt: skip
ANGLES = (
    A("angles_smoothed", "&Smoothed (zero-lag, offline)", "jobs.set_angles", ("smoothed",),
      tip="The zero-lag offline estimate (gait-aware Kalman + RTS smoother) stored with the "
      "recording: what gaitmon info, the report and export use by default",
      checkable=True, checked=True, enabled="angles", group="angles"),
    A("angles_live", "&Live (as shown while recording)", "jobs.set_angles", ("live",),
      tip="The causal filter's angles, as the live window showed them (they lag a little)",
      checkable=True, enabled="angles", group="angles"),
)  # fmt: skip
LEGS = tuple(
    A(f"leg_{side}", f"&{name} leg", "legs.leg_chosen", (side,), shortcut=f"Alt+{side}",
      tip=f"Of a file that records both legs: show the {name.lower()} leg (its traces, strides, "
      "cycles and exclusions)", checkable=True, enabled="bilateral", group="legs")
    for side, name in (("L", "Left"), ("R", "Right"))
)  # fmt: skip
LEG_MENU = "&Leg"
COMPARE = A(
    "compare", "Show recorded under reprocessed", "strides.set_compare",
    tip="After a reprocessing, draw the recorded series (grey, dashed) for comparison",
    checkable=True, checked=True,
)  # fmt: skip
FILTERS = A("filters", "&Filters…", "outputs.show_filters", shortcut="Ctrl+F",
            tip="Compare tilt filters on the range in view", enabled="document",
            requires=("gaitmon.ui.review.filters_view",))  # fmt: skip

EXCLUDE = A(
    "exclude", "&Exclude selected range", "exclusions.exclude_selection", shortcut="E",
    tip="Leave the selected range (Shift+drag on the timeline, e.g. a turn) out of the statistics",
    enabled="selection",
)  # fmt: skip
INCLUDE = A("include", "&Include selected range again", "exclusions.include_selection",
            shortcut="Shift+E", tip="Remove exclusions inside the selected range",
            enabled="selection")  # fmt: skip
CLEAR_EXCLUSIONS = A("clear_exclusions", "Clear all exclusions", "exclusions.clear_exclusions",
                     enabled="document")  # fmt: skip
CLEAR_SELECTION = A("clear_selection", "Clear selection", "nav.clear_selection",
                    shortcut="Esc")  # fmt: skip
REPROCESS = A(
    "reprocess", "&Reprocess with settings…", "outputs.reprocess_dialog", shortcut="Ctrl+P",
    tip="Recompute angles and gait events from the raw counts with other filter settings",
    enabled="raw",
)  # fmt: skip
REVERT = A("revert", "Back to the recorded series", "jobs.revert_reprocessing",
           enabled="reprocessed")  # fmt: skip
NORMATIVE = A("normative", "Load &normative band…", "strides.normative_dialog",
              tip="Draw a reference mean ± SD band behind the cycle plots",
              requires=("gaitmon.normative",))  # fmt: skip
NO_NORMATIVE = A("no_normative", "Remove normative band", "strides.set_normative", (None,),
                 requires=("gaitmon.normative",))  # fmt: skip
ABOUT = A("about", "About", "show_about")

# str: SEPARATOR or RECENT; (title, actions): a submenu
MenuItem = ReviewActionSpec | str | tuple[str, tuple[ReviewActionSpec, ...]]
ANGLES_MENU = "&Angles"
MENUS: tuple[tuple[str, tuple[MenuItem, ...]], ...] = (
    ("&File", (OPEN, OPEN_FOLDER, RECENT, CLOSE, SEPARATOR, COMPARE_SESSIONS, SEPARATOR, EXPORT,
               REPORT, SAVE_REPROCESSED, SEPARATOR, QUIT)),
    ("&View", ((ANGLES_MENU, ANGLES), (LEG_MENU, LEGS), SEPARATOR, WHOLE, ZOOM_IN, ZOOM_OUT,
               LEFT, RIGHT, FIT, SEPARATOR, *LANES, *METHODS, COMPARE, SEPARATOR, FILTERS)),
    ("&Analysis", (EXCLUDE, INCLUDE, CLEAR_EXCLUSIONS, CLEAR_SELECTION, SEPARATOR, REPROCESS,
                   REVERT, SEPARATOR, NORMATIVE, NO_NORMATIVE)),
    ("&Help", (ABOUT,)),
)  # fmt: skip
SPECS: tuple[ReviewActionSpec, ...] = tuple(
    spec
    for _title, items in MENUS
    for item in items
    for spec in ((item,) if isinstance(item, ReviewActionSpec)
                 else item[1] if isinstance(item, tuple) else ())
)  # fmt: skip


def available(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def build_actions(
    window: QMainWindow, specs: tuple[ReviewActionSpec, ...] = SPECS
) -> dict[str, QAction]:
    """The window's actions, by name; an action whose modules are missing is left out."""
    out: dict[str, QAction] = {}
    groups: dict[str, QActionGroup] = {}
    for spec in specs:
        if not all(available(m) for m in spec.requires):
            continue
        owner: object = window
        for name in spec.slot.split("."):  # "part.method": a part's slot
            owner = getattr(owner, name)
        if not callable(owner):
            raise TypeError(f"action {spec.name}: {spec.slot} is not a slot")
        method: Callable[..., object] = owner
        slot = functools.partial(method, *spec.args) if spec.args else method
        action = make_action(
            window, spec.text, slot, spec.shortcut, spec.tip, spec.checkable, spec.checked
        )
        if spec.group:
            groups.setdefault(spec.group, QActionGroup(window)).addAction(action)
        out[spec.name] = action
    return out


def build_menus(window: QMainWindow, actions: Mapping[str, QAction]) -> dict[str, QMenu]:
    """The menu bar from :data:`MENUS`, by title (the Open recent submenu under
    :data:`RECENT`); separators are never doubled or at an end (an optional action left out
    leaves no stray separator)."""
    menus: dict[str, QMenu] = {}
    for title, items in MENUS:
        menu = window.menuBar().addMenu(title)
        pending_separator = False
        for item in items:
            if item == SEPARATOR:
                pending_separator = not menu.isEmpty()
                continue
            if isinstance(item, ReviewActionSpec) and item.name not in actions:
                continue
            if pending_separator:
                menu.addSeparator()
                pending_separator = False
            if isinstance(item, ReviewActionSpec):
                menu.addAction(actions[item.name])
            elif isinstance(item, tuple):
                sub = menu.addMenu(item[0])
                for spec in item[1]:
                    if spec.name in actions:
                        sub.addAction(actions[spec.name])
                menus[item[0]] = sub
            elif item == RECENT:
                menus[RECENT] = menu.addMenu("Open &recent")
        menus[title] = menu
    return menus


def update_enabled(actions: Mapping[str, QAction], state: Mapping[Enabled, bool]) -> None:
    """Enable each action by its spec's rule; ``state`` says which conditions hold now."""
    for spec in SPECS:
        action = actions.get(spec.name)
        if action is not None and spec.enabled != "always":
            action.setEnabled(state.get(spec.enabled, False))
