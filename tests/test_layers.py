"""The layer contract, checked from the source: arrows only point down, and no import circle.

    base (gaitmon, errors, jobs, text, values) <- dsp <- io (link, simulator, session format)
        <- engine / analysis / normative / reprocessing / finish
        <- report / export / live / review / lab / batch / lsl <- ui <- commands / cli

A module may import its own layer and the layers below it, never one above. Every import
counts, also one inside a function (a lazy import is still an arrow) or under ``TYPE_CHECKING``
(a type is a dependency too). Only ``gaitmon.ui`` imports Qt. Circles are looked for between
modules, whatever their layers. An import by name (``importlib.import_module``, ``__import__``,
a loader given a module path as a string) is an arrow this reader cannot see, so there must be
none in ``gaitmon/``: lazy imports are plain ``import`` statements inside a function.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

import gaitmon

ROOT = Path(gaitmon.__file__).resolve().parent

LAYERS: tuple[tuple[str, ...], ...] = (
    ("gaitmon", "gaitmon.errors", "gaitmon.jobs", "gaitmon.lazy", "gaitmon.text", "gaitmon.values",
     "gaitmon.paths", "gaitmon.logs"),
    ("gaitmon.dsp",),
    ("gaitmon.io",),
    # gaitmon.finish: recovery, reprocessing and what is derived from a file's rows, above the
    # format that only stores and reads
    ("gaitmon.engine", "gaitmon.analysis", "gaitmon.normative", "gaitmon.reprocessing",
     "gaitmon.finish"),
    ("gaitmon.report", "gaitmon.report_content", "gaitmon.export", "gaitmon.compare",
     "gaitmon.live", "gaitmon.review", "gaitmon.lab", "gaitmon.batch", "gaitmon.batch_pool",
     "gaitmon.batch_tables", "gaitmon.lsl",
     "gaitmon.api"),
    ("gaitmon.ui",),
    ("gaitmon.commands", "gaitmon.cli", "gaitmon.__main__"),
)
# The one arrow allowed upward: the package's public API (``gaitmon.open`` …, README "For
# researchers") is gaitmon.api's, which ``gaitmon/__init__.py`` imports only when a name is
# first looked up (PEP 562), after the package is initialised: no import-time circle, and
# ``import gaitmon`` stays cheap (tests/test_public_api.py checks that it loads none of it).
FACADE = ("gaitmon", "gaitmon.api")
QT = ("PySide6", "pyqtgraph", "shiboken6")
QT_LAYER = "gaitmon.ui"


def module_names() -> dict[str, Path]:
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        name = ".".join(parts).removesuffix(".__init__")
        out[name] = path
    return out


def imports_of(name: str, path: Path, known: Iterable[str]) -> set[str]:
    """The modules ``name`` imports: gaitmon ones resolved to the module, others by top name."""
    known = set(known)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join([*base, node.module] if node.module else base)
            else:
                mod = node.module or ""
            for a in node.names:
                sub = f"{mod}.{a.name}"
                out.add(sub if sub in known else mod)
    resolved = set()
    for m in out:
        if m.startswith("gaitmon"):
            while m not in known and "." in m:  # an attribute of a module, not a module
                m = m.rpartition(".")[0]
            resolved.add(m)
        else:
            resolved.add(m.split(".")[0])
    resolved.discard(name)
    return resolved


# calls that import a module named by a string: arrows an import reader cannot follow
BY_NAME = frozenset({"import_module", "__import__", "lazy_exports", "exec_module"})


def imports_by_name(path: Path) -> list[str]:
    """Each call in ``path`` that imports a module by name, as "file:line: call"."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call):
            f = node.func
            called = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            if called in BY_NAME:
                out.append(f"{path.name}:{node.lineno}: {called}()")
        elif isinstance(node, ast.ImportFrom) and node.module == "importlib":
            # ``from importlib import import_module as load`` hides the call's name
            out += [f"{path.name}:{node.lineno}: from importlib import {a.name}"
                    for a in node.names if a.name in BY_NAME]  # fmt: skip
    return sorted(out, key=lambda hit: int(hit.split(":")[1]))


def import_graph() -> dict[str, set[str]]:
    mods = module_names()
    graph = {name: imports_of(name, path, mods) for name, path in mods.items()}
    graph[FACADE[0]].discard(FACADE[1])  # (see FACADE)
    return graph


def layer_of(module: str) -> int | None:
    best: tuple[int, int] | None = None  # (prefix length, layer): the longest prefix decides
    for k, names in enumerate(LAYERS):
        for prefix in names:
            if (module == prefix or module.startswith(prefix + ".")) and (
                best is None or len(prefix) > best[0]
            ):
                best = (len(prefix), k)
    return None if best is None else best[1]


def cycles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def violations(graph: Mapping[str, set[str]]) -> list[str]:
    problems = []
    for mod, deps in sorted(graph.items()):
        mine = layer_of(mod)
        if mine is None:
            problems.append(f"{mod} belongs to no layer: add it to LAYERS in {Path(__file__).name}")
            continue
        for dep in sorted(deps):
            if dep.startswith("gaitmon"):
                theirs = layer_of(dep)
                if theirs is not None and theirs > mine:
                    problems.append(f"{mod} imports {dep}, a higher layer")
            elif dep in QT and not (mod == QT_LAYER or mod.startswith(QT_LAYER + ".")):
                problems.append(f"{mod} imports {dep}; only {QT_LAYER} may import Qt")
    problems.extend("import circle: " + " <-> ".join(c) for c in cycles(graph))
    return problems


def test_arrows_only_point_down_and_there_is_no_circle() -> None:
    graph = import_graph()
    assert len(graph) > 50 and "gaitmon.ui" in graph and "gaitmon.dsp.kalman" in graph
    assert violations(graph) == []


def test_the_contract_catches_an_upward_arrow_qt_below_ui_and_a_circle() -> None:
    graph = import_graph()
    graph["gaitmon.dsp.kalman"] = graph["gaitmon.dsp.kalman"] | {"gaitmon.engine", "PySide6"}
    graph["gaitmon.dsp.angles"] = graph["gaitmon.dsp.angles"] | {"gaitmon.dsp.kalman"}
    found = violations(graph)
    assert "gaitmon.dsp.kalman imports gaitmon.engine, a higher layer" in found
    assert "gaitmon.dsp.kalman imports PySide6; only gaitmon.ui may import Qt" in found
    assert any(p.startswith("import circle:") and "gaitmon.dsp.angles" in p for p in found)


def test_the_import_reader_resolves_relative_and_from_imports(tmp_path: Path) -> None:
    src = tmp_path / "m.py"
    src.write_text(
        "from gaitmon.dsp import kalman\n"
        "from gaitmon.io.session import SessionError\n"
        "from . import angles\n"
        "def f():\n    import PySide6.QtCore\n"
        "if TYPE_CHECKING:\n    from gaitmon.engine import Engine\n",
        encoding="utf-8",
    )
    known = ["gaitmon.dsp.kalman", "gaitmon.dsp.angles", "gaitmon.io.session", "gaitmon.dsp",
             "gaitmon.engine"]  # fmt: skip
    got = imports_of("gaitmon.dsp.m", src, known)
    assert got == {"gaitmon.dsp.kalman", "gaitmon.io.session", "gaitmon.dsp.angles", "PySide6",
                   "gaitmon.engine"}  # fmt: skip


# the one load by name that is no arrow: the loops compiled ahead of time, a C extension built
# into the user's cache folder (gaitmon.dsp.kernel_aot), imports nothing of gaitmon's
NOT_AN_ARROW = frozenset({"kernel_aot.py: exec_module()"})


def test_no_module_imports_by_name() -> None:
    found = [hit for path in module_names().values() for hit in imports_by_name(path)]
    assert [hit for hit in found if _without_line(hit) not in NOT_AN_ARROW] == []
    assert {_without_line(hit) for hit in found} <= NOT_AN_ARROW


def _without_line(hit: str) -> str:
    name, _line, call = hit.split(":")
    return f"{name}:{call}"


def test_the_by_name_reader_finds_every_spelling(tmp_path: Path) -> None:
    src = tmp_path / "m.py"
    src.write_text(
        "import importlib\n"
        "from importlib import import_module as load\n"
        "def f():\n    return importlib.import_module('gaitmon.engine')\n"
        "def g():\n    return __import__('gaitmon.ui')\n"
        "__getattr__ = lazy_exports(__name__, {'Session': 'reader'})\n"
        "import importlib.util\n"
        "def h():\n    return importlib.util.find_spec('PySide6')\n"  # locates, imports nothing
        "def k():\n    from gaitmon.engine import Engine\n    return Engine\n",
        encoding="utf-8",
    )
    assert imports_by_name(src) == [
        "m.py:2: from importlib import import_module",
        "m.py:4: import_module()",
        "m.py:6: __import__()",
        "m.py:7: lazy_exports()",
    ]


def test_a_lazy_plain_import_is_an_arrow_the_contract_sees(tmp_path: Path) -> None:
    """The shape that replaced imports by name (a module ``__getattr__`` or a loader function
    with a plain import inside) is read as an arrow, so an upward one fails the contract."""
    src = tmp_path / "m.py"
    src.write_text(
        "def __getattr__(name):\n"
        "    if name == 'Engine':\n"
        "        from gaitmon.engine import core as module\n"
        "    return getattr(module, name)\n",
        encoding="utf-8",
    )
    got = imports_of("gaitmon.dsp.m", src, ["gaitmon.engine", "gaitmon.engine.core"])
    assert got == {"gaitmon.engine.core"}
    assert violations({"gaitmon.dsp.m": got}) == [
        "gaitmon.dsp.m imports gaitmon.engine.core, a higher layer"
    ]
