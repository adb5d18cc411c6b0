"""The Qt-free model of the live monitor: connecting to a unit or the simulator, link health.

May import ``gaitmon.dsp``, ``gaitmon.io`` and ``gaitmon.engine``; never Qt, never the UI or
the command line above it. The window (``gaitmon.ui.live``) shows what these modules compute; a
batch tool or a test can use them without a display.
"""
