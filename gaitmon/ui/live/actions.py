"""The live monitor's actions declared as data: one row per action, the window builds from it.

Each :class:`ActionSpec` names the slot it calls (a method of the window or of one of its
parts), its shortcut, tooltip and the menu it sits in (table order is menu order).
The Tilt filter menu's rows are read from the method registry when a window is built
(:func:`window_actions`). :func:`build_actions` makes the ``QAction`` objects with the shared
:func:`gaitmon.ui.actions.make_action`; :func:`build_menus` lays out the menu bar. The keyboard
help (F1) is the :data:`SHORTCUTS` list; a test checks each key in it is bound.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

from PySide6.QtGui import QAction
from PySide6.QtWidgets import QMainWindow, QMenu

from gaitmon.dsp.methods import DEFAULT_METHOD, methods
from gaitmon.engine import Mode
from gaitmon.ui.actions import make_action
from gaitmon.ui.plots import METHOD_LABELS

WINDOWS_S = (5.0, 10.0, 30.0)  # the time windows the display offers
METHOD_COLOURS = (("acc", "red"), ("kalman", "green"), ("gyro", "blue"))
MODES = (
    (Mode.RAW, "PC computes (raw frames)", "The unit sends raw ADC frames; gaitmon runs the "
     "paper's filters, Kalman filter and gait detection on the PC (all three methods)."),
    (Mode.TILT, "Unit's tilt angles", "The unit sends its own accelerometer and Kalman tilts "
     "(no gyro integration, no foot contacts)."),
    (Mode.JOINT, "Unit's joint angles", "The unit sends its own joint angles, foot contacts and "
     "gait phase."),
)  # fmt: skip
SHORTCUTS = [
    ("Ctrl+E", "engineering view: all traces, segment tilts, raw sensors (off: clinical view)"),
    ("Space", "pause / resume the display (acquisition and recording continue)"),
    ("M", "drop a marker (with the label typed in the marker field, if any)"),
    ("Ctrl+R", "start / stop recording"),
    ("Ctrl+K", "connect / disconnect"),
    ("F5", "refresh the list of ports"),
    ("Ctrl+0", "zero: standing pose (the subject stands upright, still, leg straight)"),
    ("1 / 2 / 3", "show the last 5 / 10 / 30 s"),
    ("Home", "reset the y ranges"),
    ("Ctrl+,", "processing settings"),
    ("Ctrl+Shift+X", "simulated unit: cut the link for 3 s"),
    ("F1", "this list"),
    ("Ctrl+Q", "quit"),
]


def tilt_methods() -> tuple[tuple[str, str, str], ...]:
    """The tilt filters the PC pipeline offers (PipelineConfig.tilt_method), read from the
    method registry (gaitmon.dsp.methods) when a window is built: key, menu text, tip."""
    return tuple(
        (m.name, f"{m.label[0].upper()}{m.label[1:]}" + (" (default)" if m.name == DEFAULT_METHOD
                                                         else ""), m.tip)
        for m in methods(live=True)
    )  # fmt: skip


# the simulated unit's foot-sensor faults: key, menu text, tip
SIM_FSR_FAULTS = (
    ("heel_dead", "Heel sensor dead", "The simulated heel force sensor reads ~0 counts and "
     "never loads (uncheck: it works again)"),
    ("toe_stuck", "Toe sensor stuck loaded", "The simulated toe force sensor stays loaded "
     "(uncheck: it works again)"),
)  # fmt: skip

# menu paths ("A/B": submenu B of menu A)
DEVICE, SIMULATOR, TILT = "&Device", "&Device/Simulator", "&Device/Tilt filter"
SESSION, VIEW, HELP = "&Session", "&View", "&Help"


@dataclass(frozen=True)
class ActionSpec:
    """One window action. ``slot`` is the name of a window or part method, called with
    ``args`` first (and, when ``checkable``, the new state last)."""

    name: str
    text: str
    slot: str
    shortcut: str | None = None
    tooltip: str = ""
    checkable: bool = False
    menu: str = ""  # "" = in no menu; "A/B" = submenu B of menu A
    separator_before: bool = False  # in its menu
    args: tuple[object, ...] = ()


ACTIONS: tuple[ActionSpec, ...] = (
    ActionSpec("connect", "Connect", "toggle_connect", "Ctrl+K",
               "Connect to the selected unit (Ctrl+K)", menu=DEVICE),
    ActionSpec("refresh", "Refresh ports", "refresh_ports", "F5",
               "Look for serial ports again (F5)", menu=DEVICE),
    ActionSpec("pair_sim", "Connect simulated pair (both legs)", "connect_simulated_pair", None,
               "Two simulated units, left and right leg, walking one walk on two "
               "pseudo-terminals: both legs in one window (docs/bilateral.md)", menu=DEVICE,
               separator_before=True),
    ActionSpec("pair_ports", "Connect two units (both legs)…", "connect_two_ports", None,
               "Pick the left and the right unit's ports and connect both legs", menu=DEVICE),
    ActionSpec("zero", "Zero", "zero", "Ctrl+0",
               "Zero the standing pose: the subject stands upright and still, leg straight "
               "(Ctrl+0)", menu=DEVICE, separator_before=True),
    ActionSpec("settings", "Settings…", "open_settings", "Ctrl+,",
               "Filter, Kalman and FSR settings", menu=DEVICE),
    # (the Tilt filter menu's rows follow here: tilt_method_actions)
    ActionSpec("cut", "Cut link for 3 s", "cut_simulated_link", "Ctrl+Shift+X",
               "Simulate a Bluetooth drop-out: the simulated unit's port vanishes for 3 s",
               menu=SIMULATOR, separator_before=True, args=(3.0,)),
    ActionSpec("restore", "Restore link now", "restore_simulated_link", None,
               "End a simulated drop-out", menu=SIMULATOR),
    *(
        ActionSpec(f"cut_{side}", f"Cut {name} leg's link for 3 s", "cut_pair_link", None,
                   f"Both legs: the simulated {name} unit's port vanishes for 3 s; the other "
                   "leg records on", menu=SIMULATOR, args=(side, 3.0))
        for side, name in (("L", "left"), ("R", "right"))
    ),
    ActionSpec("stall", "Stall link for 5 s (then the backlog)", "stall_simulated_link", None,
               "The simulated unit holds its frames for 5 s and then sends them all at once: "
               "nothing is lost, the data only comes late", menu=SIMULATOR, args=(5.0,)),
    *(
        ActionSpec(f"stall_{side}", f"Stall {name} leg's link for 5 s (then the backlog)",
                   "stall_pair_link", None,
                   f"Both legs: the simulated {name} unit holds its frames for 5 s, then sends "
                   "them all at once (nothing is lost)", menu=SIMULATOR, args=(side, 5.0))
        for side, name in (("L", "left"), ("R", "right"))
    ),
    ActionSpec("sim_stand", "Stand still", "set_simulated_standing", None,
               "The simulated subject stops at the next step and stands upright and still "
               "until Walk again: time to zero", menu=SIMULATOR, separator_before=True,
               args=(True,)),
    ActionSpec("sim_walk", "Walk again", "set_simulated_standing", None,
               "The simulated subject starts walking again", menu=SIMULATOR, args=(False,)),
    *(
        ActionSpec(f"sim_{key}", text, "set_simulated_fsr_fault", None, tip, checkable=True,
                   menu=SIMULATOR, separator_before=i == 0, args=(key,))
        for i, (key, text, tip) in enumerate(SIM_FSR_FAULTS)
    ),
    ActionSpec("lsl", "Stream to LSL", "set_lsl_streaming", None,
               "Publish the angles, the gait events (and in raw mode the raw counts) as Lab "
               "Streaming Layer streams while connected, for LabRecorder (needs gaitmon[lsl]; "
               "docs/lsl.md). Remembered", checkable=True, menu=DEVICE, separator_before=True),
    ActionSpec("lsl_patient_id", "Patient id in LSL streams", "set_lsl_patient_id", None,
               "Let the patient id (the last one entered for a recording) into the LSL "
               "streams' description (off: left out). Remembered", checkable=True,
               menu=DEVICE),
    ActionSpec("quit", "Quit", "close", "Ctrl+Q", menu=DEVICE, separator_before=True),
    ActionSpec("record", "Record", "toggle_recording", "Ctrl+R",
               "Start / stop recording a session (Ctrl+R)", menu=SESSION),
    ActionSpec("marker", "Marker", "add_marker", "M",
               "Drop a marker now, with the label typed beside (M)", menu=SESSION),
    ActionSpec("engineering", "Engineering view", "set_engineering_view", "Ctrl+E",
               "Engineering view: the accelerometer and gyro-integration traces, the segment "
               "tilts and the raw sensors (off: the clinical view, the filter's joint angles "
               "only; Ctrl+E). Remembered", checkable=True, menu=VIEW),
    ActionSpec("pause", "Pause", "set_paused", "Space",
               "Freeze the display; acquisition and recording continue (Space)",
               checkable=True, menu=VIEW, separator_before=True),
    *(
        ActionSpec(f"window_{w:g}", f"Last {w:g} s", "set_window", str(i),
                   f"Show the last {w:g} seconds ({i})", checkable=True, menu=VIEW,
                   separator_before=i == 1, args=(w,))
        for i, w in enumerate(WINDOWS_S, start=1)
    ),
    *(
        ActionSpec(f"method_{key}", f"{METHOD_LABELS[key]} ({colour})", "set_method", None,
                   f"Show the {METHOD_LABELS[key].lower()} traces", checkable=True, menu=VIEW,
                   separator_before=key == "acc", args=(key,))
        for key, colour in METHOD_COLOURS
    ),
    ActionSpec("four_phases", "Four gait sub-phases", "set_four_phases", None,
               "Shade loading response / foot flat / push-off (off: stance vs swing)",
               checkable=True, menu=VIEW),
    ActionSpec("reset_y", "Reset y ranges", "reset_y_ranges", "Home",
               "Back to the clinical y ranges", menu=VIEW),
    ActionSpec("guide", "Guided start", "show_guide", None,
               "Show the step bar above the plots: Connect → stand still, Zero → Record",
               menu=HELP),
    ActionSpec("help", "Keyboard shortcuts", "show_shortcuts", "F1", menu=HELP),
    ActionSpec("about", "About gaitmon", "show_about", menu=HELP),
)  # fmt: skip


def tilt_action(method: str) -> str:
    """The name of the Device ▸ Tilt filter action that chooses ``method``."""
    return f"tilt_{method}"


def tilt_method_actions() -> tuple[ActionSpec, ...]:
    """Device ▸ Tilt filter: one checkable row per method the registry offers now."""
    return tuple(
        ActionSpec(tilt_action(key), text, "set_tilt_method", None,
                   f"{tip}. Applied live; remembered", checkable=True, menu=TILT, args=(key,))
        for key, text, tip in tilt_methods()
    )  # fmt: skip


def window_actions() -> tuple[ActionSpec, ...]:
    """Every row of a window being built: :data:`ACTIONS` with the Tilt filter menu's rows
    after Settings…, read from the method registry now (a method registered at run time is
    offered by the next window)."""
    at = next(i for i, spec in enumerate(ACTIONS) if spec.name == "settings") + 1
    return (*ACTIONS[:at], *tilt_method_actions(), *ACTIONS[at:])


def build_actions(
    window: QMainWindow,
    find_slot: Callable[[str], Callable[..., object]],
    specs: tuple[ActionSpec, ...] | None = None,
) -> dict[str, QAction]:
    """The window's actions by name (``specs``, else :func:`window_actions`), each calling
    ``find_slot(<slot>)(*args)``: looked up when triggered, so the window's parts can be built
    with the actions they use."""
    if specs is None:
        specs = window_actions()
    actions: dict[str, QAction] = {}
    for spec in specs:
        slot = functools.partial(_call, find_slot, spec.slot, *spec.args)
        actions[spec.name] = make_action(
            window, spec.text, slot, spec.shortcut, spec.tooltip, checkable=spec.checkable
        )
    return actions


def _call(find_slot: Callable[[str], Callable[..., object]], name: str, *args: object) -> object:
    return find_slot(name)(*args)


def build_menus(
    window: QMainWindow, actions: dict[str, QAction], specs: tuple[ActionSpec, ...]
) -> dict[str, QMenu]:
    """The menu bar in table order (``specs``, the rows ``actions`` were built from); returns
    the menus by path (``"&Device/Simulator"``)."""
    menus: dict[str, QMenu] = {}
    bar = window.menuBar()

    def menu(path: str) -> QMenu:
        if path not in menus:
            parent, _, title = path.rpartition("/")
            menus[path] = menu(parent).addMenu(title) if parent else bar.addMenu(title)
        return menus[path]

    for spec in specs:
        if not spec.menu:
            continue
        parent = spec.menu.rpartition("/")[0]
        if spec.separator_before and spec.menu not in menus:
            # the first action of a submenu: the separator goes before the submenu itself
            menu(parent or spec.menu).addSeparator()
        elif spec.separator_before:
            menus[spec.menu].addSeparator()
        menu(spec.menu).addAction(actions[spec.name])
    return menus
