"""The same recording command and seed on a quiet and on a loaded machine must give bit-identical
live angles (issue 24, "load independence").

Runs ``gaitmon record --simulate --seed S --speed 10 --duration 20`` twice, the second time with
two CPU burners (``python -c "while True: pass"``) running beside it, and compares every dataset
of the two files under /processed, /raw, /events and /smoothed bit for bit (h5py). Prints each
dataset's largest difference and the overall verdict; exits 1 if any differs.

    python benchmarks/load_identical.py [--seed 3] [--speed 10] [--duration 20] [--burners 2]
        [-- extra record options, e.g. --zero, --loss-pct 2]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

GROUPS = ("processed", "raw", "events", "smoothed")


def record(out: Path, args: argparse.Namespace, extra: list[str]) -> float:
    cmd = [sys.executable, "-m", "gaitmon", "record", "--simulate", "--seed", str(args.seed),
           "--speed", str(args.speed), "--duration", str(args.duration), "-o", str(out),
           "--force", "-q", *extra]  # fmt: skip
    t0 = time.monotonic()
    subprocess.run(cmd, check=True)
    return time.monotonic() - t0


def datasets(path: Path) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    with h5py.File(path, "r") as f:
        for g in GROUPS:
            if g in f:
                f[g].visititems(
                    lambda name, obj, g=g: out.__setitem__(f"{g}/{name}", obj[()])
                    if isinstance(obj, h5py.Dataset) else None
                )  # fmt: skip
    return out


def difference(a: np.ndarray, b: np.ndarray) -> float:
    """The largest absolute difference (inf: shapes or records differ; 0: bit-identical)."""
    if a.shape != b.shape or a.dtype != b.dtype:
        return float("inf")
    if a.dtype.names is not None or a.dtype.kind not in "fiub":
        return 0.0 if a.tobytes() == b.tobytes() else float("inf")
    if a.tobytes() == b.tobytes():
        return 0.0
    d = np.abs(a.astype(np.float64) - b.astype(np.float64))
    return float(np.nanmax(d)) if np.isfinite(d).any() else float("inf")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--speed", default="10")
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--burners", type=int, default=2)
    args, extra = ap.parse_known_args()
    extra = [x for x in extra if x != "--"]
    with tempfile.TemporaryDirectory() as tmp:
        quiet, loaded = Path(tmp) / "quiet.h5", Path(tmp) / "loaded.h5"
        t_quiet = record(quiet, args, extra)
        burners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                   for _ in range(args.burners)]  # fmt: skip
        try:
            time.sleep(0.5)
            t_loaded = record(loaded, args, extra)
        finally:
            for p in burners:
                p.kill()
                p.wait()
        a, b = datasets(quiet), datasets(loaded)
    print(f"record --simulate --seed {args.seed} --speed {args.speed} --duration "
          f"{args.duration:g} {' '.join(extra)}: quiet {t_quiet:.1f} s, with {args.burners} CPU "
          f"burners {t_loaded:.1f} s (wall)")  # fmt: skip
    worst = 0.0
    for name in sorted(set(a) | set(b)):
        if name not in a or name not in b:
            print(f"  {name:<28} only in {'the quiet' if name in a else 'the loaded'} file")
            worst = float("inf")
            continue
        d = difference(a[name], b[name])
        worst = max(worst, d)
        print(f"  {name:<28} {a[name].shape!s:<12} max difference {d:g}")
    print("bit-identical" if worst == 0 else f"DIFFERENT (max difference {worst:g})")
    return 0 if worst == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
