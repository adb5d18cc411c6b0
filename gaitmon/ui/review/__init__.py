"""The review window: a recorded session browsed, analysed, reported and exported (the widgets).

``window`` is the shell that composes the window of parts (``part``: each owns its widgets and
slots and listens to the document's change events): ``timeline`` (overview + detail lanes,
shared cursor; built by ``timeline_build``, drawn with ``lanes``) and ``navigation`` (the View
menu over it), ``strides_part`` (``strides``: stride table, summary; ``cycles``: the
cycle-normalised plots; their analysis and the normative band), ``exclusions_part``, ``jobs``
(background requests and typed responses), ``outputs`` (export, report, reprocess and Filters
dialogs), ``legs`` (one leg of a bilateral file, the Both legs tab) and ``compare_actions``.
``actions`` declares the actions and menus as data, ``status`` the banner, notes and progress
bar, ``recent`` what the window remembers. What the window shows is computed without Qt in
:mod:`gaitmon.review`. Importing this package does not import Qt.
"""
