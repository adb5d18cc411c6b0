"""The loops compiled ahead of time: a C extension module that numba's ``pycc`` builds from
:mod:`gaitmon.dsp.loops` (the one source) into the user's cache folder, beside numba's own
cache. It imports in well under a millisecond and needs neither numba nor LLVM at run time,
where loading numba's cached loops costs ~0.45 s of CPU (numba's import, LLVM's start, the
cached code's linking) and ~100 MB of memory in every process that runs them.

Built by the background cache filler (:mod:`gaitmon.dsp.kernel_fill`), after numba has compiled
every loop at its real call sites: the module exports each loop with the argument types numba
compiled it for there (the ones gaitmon passes; arrays of any layout), under the loop's own
name, and the filler writes those types beside it (``.json``): the module's wrappers convert
without checking (an array of another dtype is read as raw memory), so each call is checked
against them first (:func:`_fits`). Where it cannot be built (numba without ``pycc``, no C
compiler or Python headers, a loop compiled for several argument types) nothing is lost:
numba's cached loops serve, as before. Loaded by :mod:`gaitmon.dsp.kernels`' rule in
preference to numba's (:func:`load`); a call whose arguments do not fit runs in numba's loops
instead, or interpreted without numba.

The file is named by the same key as the cache's ready mark
(:func:`gaitmon.dsp.kernel_cache.aot_file`: the stamp of ``loops.py``, numba's and Python's
version), so a changed loop never loads an old build.
"""

from __future__ import annotations

import glob
import importlib.util
import json
import logging
import os
import shutil
import tempfile
from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np

log = logging.getLogger("gaitmon.dsp")


def _module_name(path: str) -> str:
    return os.path.basename(path).split(".", 1)[0]


def kernel_names() -> tuple[str, ...]:
    """The loops numba compiles (:mod:`gaitmon.dsp.kernels_numba`'s dispatchers), by name."""
    from gaitmon.dsp import kernels_numba

    return tuple(sorted(name for name, obj in vars(kernels_numba).items()
                        if hasattr(obj, "signatures") and hasattr(obj, "py_func")))  # fmt: skip


def build(path: str) -> bool:
    """Build the module into ``path`` (atomically: a reader sees the whole file or none) from
    the signatures numba compiled the loops for in this process; False where it cannot."""
    try:
        from numba.core import types
        from numba.pycc import CC  # type: ignore[attr-defined]
    except ImportError:  # (pycc is deprecated in numba; a version without it: JIT only)
        return False
    from gaitmon.dsp import kernels_numba, loops

    names = kernel_names()
    sigs = {name: getattr(kernels_numba, name).signatures for name in names}
    if not names or any(not s for s in sigs.values()):
        return False  # (a loop not compiled here)
    specs: dict[str, list[list[Any]]] = {}
    os.makedirs(os.path.dirname(path), exist_ok=True)
    work = tempfile.mkdtemp(prefix="gaitmon-aot-", dir=os.path.dirname(path))
    try:
        cc = CC(_module_name(path))  # type: ignore[no-untyped-call]
        cc.output_dir = work
        cc.verbose = False
        for name in names:
            args = _one_signature(sigs[name], types)
            if args is None:
                return False
            specs[name] = [_spec(t, types) for t in args]
            # arrays of any layout (strides read at run time): the pipeline passes both C-
            # and Fortran-ordered blocks, and a call never gets another layout's code
            any_layout = [t.copy(layout="A") if isinstance(t, types.Array) else t for t in args]
            export = cc.export(name, types.void(*any_layout))  # type: ignore[no-untyped-call]
            export(getattr(loops, name))
        cc.compile()
        built = glob.glob(os.path.join(work, _module_name(path) + ".*"))
        if len(built) != 1:
            return False
        # the signatures first: a module is never there without them
        with open(os.path.join(work, "specs.json"), "w") as f:
            json.dump(specs, f)
        os.replace(os.path.join(work, "specs.json"), path + ".json")
        os.replace(built[0], path)
        return True
    except Exception as exc:  # no C compiler, no Python headers...: numba's cache serves
        log.info("the loops were not compiled ahead of time (%s)", exc)
        return False
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _one_signature(sigs: list[tuple[Any, ...]], types: Any) -> tuple[Any, ...] | None:
    """The argument types of a loop numba compiled for one set of types, whatever the layouts
    of its arrays; None if it was compiled for several (another dtype, a scalar's type)."""
    def key(t: Any) -> str:
        return str(t.copy(layout="A")) if isinstance(t, types.Array) else str(t)

    if len({tuple(key(t) for t in s) for s in sigs}) != 1:
        return None
    return sigs[0]


def _spec(t: Any, types: Any) -> list[Any]:
    """What :func:`_fits` checks of an argument of numba type ``t``."""
    if isinstance(t, types.Array):
        return ["array", str(t.dtype), int(t.ndim), bool(t.mutable)]
    return ["scalar", str(t)]


_SCALARS: dict[str, tuple[type, ...]] = {
    "float64": (float, int, np.floating, np.integer),
    "int64": (int, np.integer),
    "bool": (bool, np.bool_),
}


def _prepared(spec: list[list[Any]]) -> list[tuple[Any, ...]]:
    """A loop's argument spec as :func:`_fits` checks it (dtypes as numpy's, made once)."""
    out: list[tuple[Any, ...]] = []
    for s in spec:
        if s[0] == "array":
            out.append((True, np.dtype(s[1]), int(s[2]), bool(s[3])))
        else:
            out.append((False, _SCALARS.get(s[1]), s[1] == "bool"))
    return out


def _fits(args: tuple[Any, ...], spec: list[tuple[Any, ...]]) -> bool:
    """Whether ``args`` are what the module's loop was built for (``spec``: :func:`_prepared`):
    its wrapper converts without checking (an array of another dtype would be read as raw
    memory)."""
    if len(args) != len(spec):
        return False
    for a, s in zip(args, spec, strict=True):
        if s[0]:
            if type(a) is not np.ndarray or a.dtype != s[1] or a.ndim != s[2]:
                return False
            flags = a.flags
            if not flags.aligned or (s[3] and not flags.writeable):
                return False
        else:
            kinds = s[1]
            if kinds is None or not isinstance(a, kinds):
                return False
            if not s[2] and isinstance(a, (bool, np.bool_)):
                return False
    return True


class Loops:
    """The ahead-of-time module's loops by name, each falling back to ``fallback(name)`` on a
    call whose arguments its one signature does not take; a loop it lacks (added to
    ``loops.py`` since: its key would have changed, so only a hand-made file) is
    ``fallback(name)`` too."""

    def __init__(self, module: ModuleType, specs: dict[str, list[list[Any]]],
                 fallback: Callable[[str], Any]) -> None:  # fmt: skip
        self.__file__ = module.__file__
        self._fallback = fallback
        self._elsewhere: dict[str, Any] = {}  # the fallback's loop by name, once asked for
        for name, spec in specs.items():
            fn = getattr(module, name, None)
            if callable(fn):
                setattr(self, name, self._guarded(name, fn, spec))

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        return self._other(name)

    def _other(self, name: str) -> Any:
        """The fallback's loop ``name``, looked up (and said in the log) once."""
        if name not in self._elsewhere:
            self._elsewhere[name] = self._fallback(name)
        return self._elsewhere[name]

    def _guarded(self, name: str, fn: Any, spec_json: list[list[Any]]) -> Any:
        spec = _prepared(spec_json)

        def call(*args: Any) -> Any:
            if _fits(args, spec):
                return fn(*args)
            return self._other(name)(*args)

        call.__name__ = name
        return call


def load(path: str, fallback: Callable[[str], Any]) -> Loops | None:
    """The module at ``path``, or None (absent, or unloadable)."""
    if not os.path.exists(path):
        return None
    try:
        with open(path + ".json") as f:
            specs = json.load(f)
        spec = importlib.util.spec_from_file_location(_module_name(path), path)
        if spec is None or spec.loader is None:
            return None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except Exception as exc:  # (a damaged or foreign file: numba's cache serves)
        log.warning("the loops compiled ahead of time in %s are not used (%s)", path, exc)
        return None
    return Loops(module, specs, fallback)
