"""The contract every streaming stage in gaitmon.dsp follows, typed by what flows through it."""

from __future__ import annotations

from typing import Protocol, TypeVar, runtime_checkable

In_contra = TypeVar("In_contra", contravariant=True)
Out_co = TypeVar("Out_co", covariant=True)


@runtime_checkable
class Stage(Protocol[In_contra, Out_co]):
    """A stateful block-in/block-out stage: ``process(block: In) -> Out``.

    Processing a record in arbitrary chunks gives exactly the same output as one call on the whole
    record. ``reset()`` returns the stage to its just-constructed state. The pipeline holds its
    stages as ``Stage[In, Out]`` of precise types (gaitmon.dsp.pipeline.Stages), so mypy checks
    that each stage's output is what the next one takes.
    """

    def process(self, block: In_contra, /) -> Out_co: ...

    def reset(self) -> None: ...
