"""The Qt-free model of the review window: what it shows, computed without Qt.

``model`` (opening a session, the recorded and reprocessed series, stride analysis,
reprocessing in memory) and ``filters`` (the filter comparison behind the Filters view). The
window's widgets live in :mod:`gaitmon.ui.review`. May import ``dsp``, ``io``, ``engine``,
``analysis`` and ``report``; never Qt.
"""
