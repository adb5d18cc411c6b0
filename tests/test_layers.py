"""The layer contract, checked from the source: arrows only point down, and no import circle.

    base (gaitmon, errors, jobs, lazy, text) <- dsp <- io (link, simulator, session format)
        <- engine / analysis / normative / reprocessing / finish / io.export
        <- report / live / review / lab / batch <- ui <- commands / cli

A module may import its own layer and the layers below it, never one above. Every import
counts, also one inside a function (a lazy import is still an arrow) or under ``TYPE_CHECKING``
(a type is a dependency too). Only ``gaitmon.ui`` imports Qt. Circles are looked for between
modules, whatever their layers.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

import gaitmon

ROOT = Path(gaitmon.__file__).resolve().parent

LAYERS: tuple[tuple[str, ...], ...] = (
    ("gaitmon", "gaitmon.errors", "gaitmon.jobs", "gaitmon.lazy", "gaitmon.text"),
    ("gaitmon.dsp",),
    # the exports' de-identification rules are pure data, also used by the format's
    # de-identified copy
    ("gaitmon.io", "gaitmon.io.export.deidentify"),
    # gaitmon.finish: recovery, reprocessing and what is derived from a file's rows, above the
    # format that only stores and reads; the exports open sessions through it
    ("gaitmon.engine", "gaitmon.analysis", "gaitmon.normative", "gaitmon.reprocessing",
     "gaitmon.finish", "gaitmon.io.export"),
    ("gaitmon.report", "gaitmon.report_bilateral", "gaitmon.strides_export",
     "gaitmon.bilateral_export", "gaitmon.compare",
     "gaitmon.live", "gaitmon.review", "gaitmon.lab", "gaitmon.batch", "gaitmon.lsl"),
    ("gaitmon.ui",),
    ("gaitmon.commands", "gaitmon.cli", "gaitmon.__main__"),
)
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


def import_graph() -> dict[str, set[str]]:
    mods = module_names()
    return {name: imports_of(name, path, mods) for name, path in mods.items()}


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
