"""The live monitor window: connect to a unit, watch the gait live, record sessions.

* ``window``    -- :class:`MainWindow`, the shell: layout, toolbars, docks, the 30 Hz update;
* ``actions``   -- the actions as a table (name, text, shortcut, slot, menu) and the key list;
* ``device``    -- ports, connect / disconnect, zero, the simulator's link, subject and foot
  sensors (slots);
* ``recording`` -- start / stop a recording, markers (slots);
* ``processing`` -- the Settings dialog and the tilt filter menu, applied live (slots);
* ``lsl``       -- Device ▸ Stream to LSL and its patient-id permission (slots);
* ``pair_slots`` -- both legs: connect a pair of units, their update, Record into one file,
  markers, zero, the simulated pair's link cuts (slots);
* ``pair_view`` -- both legs' view: overlaid plots, each leg's link health and Gait panel,
  the live bilateral measures;
* ``jobs``      -- connect and zero off the GUI thread (one in-order ``QtWorker``);
* ``status``    -- status bar, banners and gait panel: what a snapshot says, shown;
* ``prefs``     -- what the window remembers (QSettings);
* ``base``      -- the state the slot groups share.

The Qt-free model (connecting, link health) is :mod:`gaitmon.live`.
"""

from gaitmon.ui.live.actions import SHORTCUTS
from gaitmon.ui.live.window import MainWindow, run

__all__ = ["SHORTCUTS", "MainWindow", "run"]
