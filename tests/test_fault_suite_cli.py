"""benchmarks/fault_suite.py's own command line (issue 26, item 12): its docstring's example
`--only decoder,chunking` raised KeyError: 'chunking'. The rows run elsewhere (they are long);
here only how names are taken: an unknown one is one line naming the rows (before, any name
but the six was a KeyError traceback; "chunking" now names the decoder row, whose second half
it is)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SUITE = Path(__file__).resolve().parents[1] / "benchmarks" / "fault_suite.py"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SUITE), *args], capture_output=True, text=True,
                          timeout=120)  # fmt: skip


def test_an_unknown_row_is_one_line_naming_the_rows() -> None:
    r = _run("--only", "decoder,nosuch")
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    last = r.stderr.strip().splitlines()[-1]
    assert "no row named nosuch" in last and "decoder" in last and "soak" in last, last

