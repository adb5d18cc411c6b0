"""Getting the filters ready before a unit streams, and knowing when that will take a while.

The gait-aware filter's inner loop is compiled by numba (``gaitmon.dsp.kernels``) on its first
call and cached on disk in the user's cache folder. The first connect after an install compiles
it: ~3 s on a quiet machine, 30-40 s on a busy one, with the unit not yet asked for data. Later
runs load it from the cache (~1 s). :func:`filters_compiled` says which it will be before the
warm-up runs, so a viewer can say why the first connect waits; :func:`prepare_filters` runs
the warm-up and tells a caller first when it is going to compile.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

from gaitmon.dsp.channels import DEFAULT_TABLE, ChannelTable
from gaitmon.dsp.pipeline import PipelineConfig, warm_up


def filters_compiled() -> bool | None:
    """Whether the live filter's compiled loop is ready without compiling: loaded in this
    process already, or in numba's cache on disk for this gaitmon's source (numba drops a cache
    whose source file changed: a new install). False: the next warm-up compiles it; None: the
    cache cannot be looked at (a numba without these internals: say nothing rather than guess).
    """
    from gaitmon.dsp.kernels import gait_aware_update  # lazy: numba only where it is used

    if gait_aware_update.signatures:  # compiled or loaded in this process
        return True
    try:
        # numba's own reading of the index (it checks the source's stamp, as a call would)
        dispatcher = cast("Any", gait_aware_update)  # its cache is not in numba's stubs
        index = dispatcher._cache._cache_file._load_index()
    except Exception:  # numba's internals changed, or no cache: not knowable
        return None
    return bool(index)


def prepare_filters(
    config: PipelineConfig,
    table: ChannelTable = DEFAULT_TABLE,
    *,
    compiling: Callable[[], None] | None = None,
) -> None:
    """Compile or load the filters of ``config`` now (``dsp.pipeline.warm_up``); ``compiling()``
    first when that compiles (:func:`filters_compiled` is False), for a viewer to say so."""
    if compiling is not None and filters_compiled() is False:
        compiling()
    warm_up(config, table)
