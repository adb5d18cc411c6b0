"""Finishing and deriving: the layer above the session format (:mod:`gaitmon.io.session`) that
runs the pipeline and the offline methods over what a file stores.

* :mod:`.session` - :func:`open_session` (recovers an interrupted recording first) and
  :class:`Session` (a stored session that computes what the file does not store);
* :mod:`.closing` - :func:`close_recording`, a recording closed with ``/smoothed`` and
  ``/strides`` stored;
* :mod:`.recovery` - :func:`replay_pipeline`, :func:`recover_session` (an interrupted file
  rebuilt from its journal), :func:`build_session` (a whole file from rows in memory: the XDF
  import);
* :mod:`.reprocess`, :mod:`.reprocess_both` - :func:`rewrite_processed`, a raw session re-run
  into a new file (one unit, both legs);
* :mod:`.smoothed` - ``/smoothed``, the zero-lag angles of raw sessions (the readers' default);
* :mod:`.strides` - ``/strides``, the foot IMU's stride length and clearance;
* :mod:`.combine`, :mod:`.bilateral` - joining the two units' parts of a recording of both
  legs with their clock fits, and :func:`~.bilateral.open_bilateral`.

Importing the package imports none of them (:mod:`gaitmon.lazy`).
"""

from typing import TYPE_CHECKING

from gaitmon.lazy import lazy_exports

if TYPE_CHECKING:
    from gaitmon.finish.bilateral import Bilateral, open_bilateral
    from gaitmon.finish.closing import close_recording
    from gaitmon.finish.recovery import (
        build_session,
        flagged_at_start,
        flags_kept,
        recover_session,
        replay_pipeline,
    )
    from gaitmon.finish.reprocess import RewriteResult, rewrite_processed
    from gaitmon.finish.session import Session, open_session

__getattr__ = lazy_exports(__name__, {
    "Bilateral": "bilateral",
    "open_bilateral": "bilateral",
    "close_recording": "closing",
    "build_session": "recovery",
    "flagged_at_start": "recovery",
    "flags_kept": "recovery",
    "recover_session": "recovery",
    "replay_pipeline": "recovery",
    "RewriteResult": "reprocess",
    "rewrite_processed": "reprocess",
    "Session": "session",
    "open_session": "session",
})  # fmt: skip

__all__ = [
    "Bilateral",
    "RewriteResult",
    "Session",
    "build_session",
    "close_recording",
    "flagged_at_start",
    "flags_kept",
    "open_bilateral",
    "open_session",
    "recover_session",
    "replay_pipeline",
    "rewrite_processed",
]
