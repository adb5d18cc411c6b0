"""The contract every streaming stage in gaitmon.dsp follows."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable


@runtime_checkable
class Stage(Protocol):
    """A stateful block-in/block-out stage.

    Processing a record in arbitrary chunks gives exactly the same output as one call on the whole
    record. ``reset()`` returns the stage to its just-constructed state.
    """

    def process(self, *args: Any, **kwargs: Any) -> Any: ...

    def reset(self) -> None: ...
