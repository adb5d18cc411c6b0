"""``gaitmon lab``: reproduce the papers' filter experiments as Markdown reports with PNG plots."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from gaitmon.errors import UserError
from gaitmon.io.sim.patterns import REALISM_LEVELS

CHOICES = ("all", "p000", "p001", "p002", "p003", "p004", "accuracy")
# matplotlib is in the ``lab`` extra, not in a plain ``pip install .`` (pyproject.toml)
NO_MATPLOTLIB = "gaitmon lab needs matplotlib: pip install 'gaitmon[lab]'"


def _require_matplotlib() -> None:
    """One line (UserError) when matplotlib, which draws the reports' figures, is missing."""
    try:
        import matplotlib  # noqa: F401  (only whether it is there)
    except ImportError:
        raise UserError(NO_MATPLOTLIB) from None


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "experiment",
        nargs="?",
        default="all",
        help=f"which experiment: {', '.join(CHOICES)} (default all; 'accuracy' prints the tilt "
        "methods' accuracy table and needs no -o)",
    )
    p.add_argument("-o", "--out", metavar="DIR", help="directory for the reports")
    p.add_argument(
        "--data",
        metavar="DIR",
        help="the shared real recordings (accuracy: every dataset in it, trial by trial; a "
        "missing one is skipped with a note; default ../shared/data beside the source)",
    )
    p.add_argument(
        "--realism",
        choices=REALISM_LEVELS,
        default="default",
        help="accuracy: the simulator's realism level for its scenarios ('real': sensor gain "
        "and cross-axis errors, roll, 180-degree turns, a rolling stance foot and stride "
        "variability, as measured on real feet; docs/simulator.md)",
    )
    p.add_argument(
        "--quick", action="store_true", help="shorter records and fewer runs (for a smoke test)"
    )


def run(args: argparse.Namespace) -> int:
    if args.experiment not in CHOICES:
        raise UserError(f"unknown experiment {args.experiment!r}; use one of {', '.join(CHOICES)}")
    if args.experiment == "accuracy":
        return _accuracy(args)
    _require_matplotlib()  # before any folder is made
    if not args.out:
        raise UserError("gaitmon lab needs -o DIR, the directory for the reports")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out} exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".gaitmon-lab-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise UserError(f"cannot write reports to {out}: {exc.strerror or exc}") from None
    from gaitmon.lab import EXPERIMENTS, run_all

    names = list(EXPERIMENTS) if args.experiment == "all" else [args.experiment]
    t0 = time.perf_counter()
    print(f"gaitmon lab: {len(names)} experiment(s) -> {out}", flush=True)
    run_all(names, out, quick=args.quick, progress=lambda m: print(f"  {m}", flush=True))
    print(f"gaitmon lab: done in {time.perf_counter() - t0:.1f} s", flush=True)
    return 0


def _accuracy(args: argparse.Namespace) -> int:
    from gaitmon.lab.accuracy import default_data_dir, evaluate, format_table

    data = Path(args.data) if args.data else default_data_dir()
    if data is not None and args.data:
        from gaitmon.lab.datasets import DATASETS, available

        if not any(available(data).values()):
            raise UserError(f"{data} holds none of the real datasets ({', '.join(DATASETS)}; "
                            "see ../shared/data/README.md)")  # fmt: skip
    t0 = time.perf_counter()
    print(f"gaitmon lab accuracy: simulator scenarios (realism {args.realism})"
          + (f" and the recordings in {data}" if data else " (no real recordings found)"),
          flush=True)  # fmt: skip
    acc = evaluate(
        quick=args.quick,
        data_dir=data,
        realism=args.realism,
        progress=lambda m: print(f"  {m}", flush=True),
    )
    table = format_table(acc)
    print(table)
    if args.out:
        out = Path(args.out)
        try:
            out.mkdir(parents=True, exist_ok=True)
            (out / "accuracy.md").write_text(table + "\n", encoding="utf-8")
        except OSError as exc:
            raise UserError(f"cannot write the table to {out}: {exc.strerror or exc}") from None
    print(f"gaitmon lab accuracy: done in {time.perf_counter() - t0:.1f} s", flush=True)
    return 0
