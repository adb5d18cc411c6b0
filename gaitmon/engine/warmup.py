"""Getting the filters ready before a unit streams, without waiting for a compile.

The filters' inner loops (``gaitmon.dsp.loops``) run interpreted for live blocks: nothing is
compiled before or while a unit streams, so the first connect after an install waits no longer
than any other. numba's compiled form serves long batch work (a long recording's close,
``process``, recovery: ``gaitmon.dsp.kernels``), and its cache is filled here, in a background
process at a lower priority, the first time after an install (:func:`prepare_filters`), so that
such work finds it ready.
"""

from __future__ import annotations

from gaitmon.dsp import kernels
from gaitmon.dsp.channels import DEFAULT_TABLE, ChannelTable
from gaitmon.dsp.kernel_cache import cache_ready, start_fill
from gaitmon.dsp.pipeline import PipelineConfig, warm_up

__all__ = ["filters_compiled", "prepare_filters"]


def filters_compiled() -> bool:
    """Whether numba's cache holds the compiled loops for this install (long batch work will
    load them rather than run interpreted)."""
    return cache_ready()


def prepare_filters(config: PipelineConfig, table: ChannelTable = DEFAULT_TABLE) -> None:
    """Run a throwaway pipeline of ``config`` (``dsp.pipeline.warm_up``: its tables built,
    interpreted loops, milliseconds) and start filling numba's cache in the background where it
    is not ready (``dsp.kernel_cache.start_fill``): neither waits for a compile."""
    with kernels.live():  # (the form the live blocks will run)
        warm_up(config, table)
    start_fill()
