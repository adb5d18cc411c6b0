"""What every fault row shares: its table row, the checkout and how to run gaitmon in a child."""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GAITMON = [sys.executable, "-m", "gaitmon"]


@dataclass
class Row:
    test: str
    goal: str
    figure: str
    ok: bool

    def line(self) -> str:
        return f"| {self.test} | {self.goal} | {self.figure} | {'PASS' if self.ok else 'FAIL'} |"


def env() -> dict[str, str]:
    """The environment of a gaitmon child: this checkout first, no screen needed."""
    out = dict(os.environ)
    out["PYTHONPATH"] = str(ROOT) + os.pathsep + out.get("PYTHONPATH", "")
    out.setdefault("QT_QPA_PLATFORM", "offscreen")
    return out
