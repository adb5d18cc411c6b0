"""The review window: a recorded session browsed, analysed, reported and exported.

Modules: ``window`` (the main window), ``timeline`` (overview + detail lanes, shared cursor),
``strides`` (stride table, summary), ``cycles`` (cycle-normalised plots), ``model`` (Qt-free:
opening, analysis, reprocessing), ``exclusions`` (the ``FILE.review.json`` side file),
``workers`` (request -> worker -> response); the PDF report, export dialog, plot export,
normative bands and filter comparison live in their own modules. Importing this package does
not import Qt.
"""
