"""The Qt-free model of the review window: what it shows, computed without Qt.

``model`` (opening a session, the recorded and reprocessed series, stride analysis,
reprocessing in memory; the :class:`~gaitmon.review.model.Document` changes its exclusions,
angles and settings itself and says so through ``events``: typed change events the window's
parts listen to), ``settings`` (every settings name the windows use, named once), ``view`` (the
timeline's view requests), ``both_legs`` (the Both legs tab's table) and ``filters`` (the filter
comparison behind the Filters view). The
window's widgets live in :mod:`gaitmon.ui.review`. May import ``dsp``, ``io``, ``engine``,
``analysis`` and ``report``; never Qt.
"""
