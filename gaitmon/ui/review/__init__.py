"""The review window: a recorded session browsed, analysed, reported and exported (the widgets).

Modules: ``window`` (the window's shell), ``actions`` (its actions and menus as data),
``status`` (banner, notes, progress bar), ``jobs`` (its background requests and typed
responses), ``timeline`` (overview + detail lanes, shared cursor) drawn with ``lanes``,
``strides`` (stride table, summary), ``cycles`` (cycle-normalised plots); the export dialog,
plot export and filter comparison live in their own modules. What the window shows is computed
without Qt in :mod:`gaitmon.review`. Importing this package does not import Qt.
"""
