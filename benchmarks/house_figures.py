"""The house's figures (issue 23): size, layering, names, seams and tests, read from the source.

    python benchmarks/house_figures.py [ROOT]

ROOT is a checkout (default: this one). Prints one line per figure, so two checkouts (before and
after a reshaping) can be put side by side with ``diff``. Everything is read with ``ast``;
nothing is imported, so a checkout with another layout can be measured too.
"""

from __future__ import annotations

import ast
import re
import sys
from collections import Counter
from pathlib import Path

SLEEPY = {"sleep", "monotonic", "perf_counter", "time", "waitUntil", "waitSignal", "wait",
          "waitExposed", "wait_for", "waitCallback"}  # fmt: skip
FIXED_WAITS = {"sleep", "wait"}  # a fixed time, not a condition (qtbot.wait, time.sleep)
TWO_LEG_NAMES = re.compile(r"Bilateral|Pair|Leg|Side")
# the session, export, method and finishing packages; gaitmon/io/export is where the export
# writers were before issue 23 (so that an older checkout is measured the same way)
PUBLIC_PACKAGES = ("gaitmon/io/session", "gaitmon/io/export", "gaitmon/export",
                   "gaitmon/dsp/methods", "gaitmon/dsp/events", "gaitmon/finish")  # fmt: skip


def _py(root: Path, sub: str) -> list[Path]:
    return sorted((root / sub).rglob("*.py"))


def _lines(p: Path) -> int:
    return len(p.read_text(encoding="utf-8").splitlines())


def _calls(tree: ast.AST) -> list[str]:
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            out.append(f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", ""))
    return out


def _any_in_public_signatures(files: list[Path], root: Path) -> list[str]:
    hits = []
    for p in files:
        tree = ast.parse(p.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            if node.name.startswith("_") and node.name != "__init__":
                continue
            anns = [a.annotation for a in (*node.args.args, *node.args.kwonlyargs)
                    if a.annotation is not None]  # fmt: skip
            for extra in (node.args.vararg, node.args.kwarg):
                if extra is not None and extra.annotation is not None:
                    anns.append(extra.annotation)
            if node.returns is not None:
                anns.append(node.returns)
            if any(re.search(r"\bAny\b", ast.unparse(a)) for a in anns):
                hits.append(f"{p.relative_to(root)}:{node.lineno} {node.name}")
    return hits


def figures(root: Path) -> list[tuple[str, str]]:
    src = _py(root, "gaitmon")
    lines = {p: _lines(p) for p in src}
    total = sum(lines.values())
    io_lines = sum(n for p, n in lines.items() if "gaitmon/io/" in p.as_posix())
    big = sorted((n, p.relative_to(root).as_posix()) for p, n in lines.items() if n > 600)
    trees = {p: ast.parse(p.read_text(encoding="utf-8")) for p in src}
    by_name = [f"{p.relative_to(root)}" for p, t in trees.items()
               if {"import_module", "__import__"} & set(_calls(t))]  # fmt: skip
    classes: Counter[str] = Counter()
    two_leg = 0
    widest: list[tuple[int, str]] = []
    for p, t in trees.items():
        for node in ast.walk(t):
            if isinstance(node, ast.ClassDef):
                classes[node.name] += 1
                two_leg += bool(TWO_LEG_NAMES.search(node.name))
                n_methods = sum(isinstance(b, ast.FunctionDef) for b in node.body)
                widest.append((n_methods, f"{node.name} ({p.relative_to(root)})"))
    dup = sorted(f"{n} x{k}" for n, k in classes.items() if k > 1)
    tests = _py(root, "tests")
    n_tests = timed = fixed = 0
    helper_defs: Counter[str] = Counter()
    for p in tests:
        t = ast.parse(p.read_text(encoding="utf-8"))
        for node in ast.walk(t):
            if isinstance(node, ast.FunctionDef):
                if node.name in ("make_engine", "wait_for"):
                    helper_defs[node.name] += 1
                if node.name.startswith("test_"):
                    n_tests += 1
                    calls = set(_calls(node))
                    kw = {k.arg for c in ast.walk(node) if isinstance(c, ast.Call)
                          for k in c.keywords}  # fmt: skip
                    timed += bool(calls & SLEEPY or "timeout" in kw)
                    fixed += bool(calls & FIXED_WAITS)
    public = [f for pkg in PUBLIC_PACKAGES for f in _py(root, pkg)]
    anys = _any_in_public_signatures(public, root)
    bilateral_tree = [
        p.relative_to(root).as_posix() for p in src
        if "bilateral" in p.name or "bilateral_export" in p.as_posix()
    ]  # fmt: skip
    widest.sort(reverse=True)
    return [
        ("python files in gaitmon/", str(len(src))),
        ("lines in gaitmon/", str(total)),
        ("lines in gaitmon/io/", f"{io_lines} ({100 * io_lines / total:.0f} %)"),
        ("modules over 600 lines", f"{len(big)}: " + ", ".join(f"{p} {n}" for n, p in big)),
        ("imports by name (import_module/__import__)", f"{len(by_name)}: " + ", ".join(by_name)),
        ("class names defined more than once", f"{len(dup)}: " + ", ".join(dup)),
        ("classes named Bilateral/Pair/Leg/Side", str(two_leg)),
        ("modules named *bilateral* or in bilateral_export/",
         f"{len(bilateral_tree)}: " + ", ".join(bilateral_tree)),
        ("most methods in one class body", ", ".join(f"{n} {c}" for n, c in widest[:3])),
        ("test functions that sleep, read the clock or wait", f"{timed} of {n_tests}"),
        ("... of them waiting a fixed time (sleep, qtbot.wait)", f"{fixed} of {n_tests}"),
        ("copies of make_engine / wait_for in tests/",
         f"{helper_defs['make_engine']} / {helper_defs['wait_for']}"),
        ("public signatures with Any (session, export, methods, finishing packages)",
         f"{len(anys)}" + (": " + ", ".join(anys[:8]) + (" ..." if len(anys) > 8 else "")
                           if anys else "")),
    ]  # fmt: skip


def main(argv: list[str]) -> int:
    root = Path(argv[0]).resolve() if argv else Path(__file__).resolve().parents[1]
    for name, value in figures(root):
        print(f"{name:<75} {value}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
