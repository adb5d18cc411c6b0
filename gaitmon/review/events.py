"""Change events of the review document, without Qt (napari's evented models, in small).

An :class:`Emitter` carries one typed payload (a frozen dataclass) to the callbacks connected
to it, in the order they were connected, on the thread that changed the model (the review
window changes its document on the GUI thread only). :class:`DocumentEvents` is the group a
:class:`gaitmon.review.model.Document` owns (``doc.events.exclusions.connect(cb)``); the
payloads say what changed, so a listener needs nothing else from the caller:

* :class:`ExclusionsChanged` - the user's excluded ranges, and where they were kept;
* :class:`AnglesChanged` - the angle source shown (smoothed | live) and its method;
* :class:`SettingsChanged` - the processing settings (and tilt method) of the series shown: a
  reprocessing shown, or the recorded series again.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Generic, TypeVar

if TYPE_CHECKING:
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.io.session.exclusions import Exclusion

P = TypeVar("P")


class Emitter(Generic[P]):
    """Callbacks of one event, called with its payload by :meth:`emit`."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._callbacks: list[Callable[[P], object]] = []

    def connect(self, callback: Callable[[P], object]) -> Callable[[P], object]:
        """Call ``callback(payload)`` on every emit from now on (once, however often it is
        connected); returns it, so it can be a decorator."""
        if callback not in self._callbacks:
            self._callbacks.append(callback)
        return callback

    def disconnect(self, callback: Callable[[P], object] | None = None) -> None:
        """Forget ``callback`` (None: every callback)."""
        if callback is None:
            self._callbacks.clear()
        elif callback in self._callbacks:
            self._callbacks.remove(callback)

    @property
    def n_callbacks(self) -> int:
        return len(self._callbacks)

    def emit(self, payload: P) -> None:
        # a copy: a callback may connect or disconnect others
        for callback in list(self._callbacks):
            callback(payload)


@dataclass(frozen=True)
class ExclusionsChanged:
    """The document's exclusions are now ``exclusions``; ``kept_in`` is the file that keeps
    them (beside the recording, or the user store when its folder is read-only), None when
    they could not be kept (``problem`` says why: they apply until the file is closed)."""

    exclusions: tuple[Exclusion, ...]
    kept_in: Path | None
    problem: str = ""


@dataclass(frozen=True)
class AnglesChanged:
    """The angles shown are now ``angles`` (smoothed | live), made by ``method``."""

    angles: str
    method: str


@dataclass(frozen=True)
class SettingsChanged:
    """The series shown are now processed with ``config`` (a reprocessing's settings and tilt
    method, or the recording's when ``reprocessed`` is False)."""

    config: PipelineConfig
    reprocessed: bool


class DocumentEvents:
    """The events of one document (see the module docstring)."""

    def __init__(self) -> None:
        self.exclusions: Emitter[ExclusionsChanged] = Emitter("exclusions")
        self.angles: Emitter[AnglesChanged] = Emitter("angles")
        self.settings: Emitter[SettingsChanged] = Emitter("settings")

    @property
    def emitters(self) -> tuple[Emitter[ExclusionsChanged], Emitter[AnglesChanged],
                                Emitter[SettingsChanged]]:  # fmt: skip
        return self.exclusions, self.angles, self.settings

    def disconnect_all(self) -> None:
        for e in self.emitters:
            e.disconnect()
