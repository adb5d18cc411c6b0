"""The live monitor window: connect to a unit (or both legs), watch the gait live, record.

The window (:mod:`.window`) is composed of parts, each owning its widgets and slots and sharing
one :class:`~.context.LiveContext` (what is connected, the settings in force, the messages):

* ``device``     -- the Connection toolbar, one unit's connect / disconnect / zero, the
  simulator's link, subject and foot sensors;
* ``recording``  -- Record / Stop, the session dialog, markers, for one unit or both legs;
* ``processing`` -- the Settings dialog and the tilt filter menu, applied live;
* ``lsl``        -- Device ▸ Stream to LSL and its patient-id permission;
* ``views``      -- the one-leg plots, the Gait and Raw sensors docks, the display's options,
  the clinical / engineering views;
* ``pair_part``  -- both legs: connect a pair of units, their update, zero, the simulated
  pair's link cuts; ``pair_view`` -- both legs' view (overlaid plots, each leg's link health
  and Gait panel, the live bilateral measures);
* ``status``     -- status bar, banners and gait panel: what a snapshot says, shown;
* ``guide``      -- the guided start's step bar;
* ``actions``    -- the actions as a table (name, text, shortcut, slot, menu) and the key list;
* ``jobs``       -- connect and zero off the GUI thread (one in-order ``QtWorker``);
* ``prefs``      -- what the window remembers (QSettings).

The Qt-free model (connecting, link health, both legs) is :mod:`gaitmon.live`.
"""

from gaitmon.ui.live.actions import SHORTCUTS
from gaitmon.ui.live.window import MainWindow, run

__all__ = ["SHORTCUTS", "MainWindow", "run"]
