"""Finishing and deriving: the layer above the session format (:mod:`gaitmon.io.session`) that
runs the pipeline and the offline methods over what a file stores.

* :mod:`.session` - :func:`open_session` (recovers an interrupted recording first) and
  :class:`Session` (a stored session that computes what the file does not store);
* :mod:`.closing` - :func:`close_recording`, a recording closed with ``/smoothed`` and
  ``/strides`` stored;
* :mod:`.replay` - :func:`replay_pipeline`, the pipeline over a recording's raw counts;
* :mod:`.recovery` - :func:`recover_session` (an interrupted file rebuilt from its journal),
  :func:`build_session` (a whole file from rows in memory: the XDF import);
* :mod:`.reprocess`, :mod:`.reprocess_both` - :func:`rewrite_processed`, a raw session re-run
  into a new file (one unit, both legs);
* :mod:`.smoothed` - ``/smoothed``, the zero-lag angles of raw sessions (the readers' default);
* :mod:`.strides` - ``/strides``, the foot IMU's stride length and clearance;
* :mod:`.combine`, :mod:`.bilateral` - joining the two units' parts of a recording of both
  legs with their clock fits, and :func:`~.bilateral.open_bilateral`.

Importing the package imports none of them (its ``__getattr__``): the pipeline, the smoother
and numba are loaded by the first name that needs them.
"""

from typing import TYPE_CHECKING

from gaitmon.lazy import keep

if TYPE_CHECKING:
    from gaitmon.finish.bilateral import Bilateral, open_bilateral
    from gaitmon.finish.closing import close_recording
    from gaitmon.finish.recovery import build_session, recover_session
    from gaitmon.finish.replay import flagged_at_start, flags_kept, replay_pipeline
    from gaitmon.finish.reprocess import RewriteResult, rewrite_processed
    from gaitmon.finish.session import Session, open_session

def __getattr__(name: str) -> object:
    """A name of the package, imported from its module on first use (PEP 562), by a plain
    import that the layer test sees."""
    if name in ("Bilateral", "open_bilateral"):
        from gaitmon.finish import bilateral

        return keep(globals(), name, bilateral)
    if name == "close_recording":
        from gaitmon.finish import closing

        return keep(globals(), name, closing)
    if name in ("build_session", "recover_session"):
        from gaitmon.finish import recovery

        return keep(globals(), name, recovery)
    if name in ("flagged_at_start", "flags_kept", "replay_pipeline"):
        from gaitmon.finish import replay

        return keep(globals(), name, replay)
    if name in ("RewriteResult", "rewrite_processed"):
        from gaitmon.finish import reprocess

        return keep(globals(), name, reprocess)
    if name in ("Session", "open_session"):
        from gaitmon.finish import session

        return keep(globals(), name, session)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
