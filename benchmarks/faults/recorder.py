"""Fault rows of the recorder (issue 26 items 7, 9, 10).

  diskfull_create  `gaitmon record` with the disk full at the file's creation (RLIMIT_FSIZE of
                   4-24 KiB: writes fail with EFBIG as on a full disk): exit 2, one line, no
                   traceback, no "Exception ignored", no segfault, nothing left behind
  soak8h           `gaitmon record --simulate --speed max` of 8 h of data (quick: 20 min) beside
                   a busy child process: every frame the file misses (its sequence numbers,
                   counted here) is reported on the command's last line and in the gap table
                   with a named cause, and finishing (from the Stop) peaks no higher than the
                   recording did plus a bounded margin
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import textwrap
from collections.abc import Callable
from pathlib import Path

from faults.common import GAITMON, Row, env

# finishing may peak this much above the recording's own peak (the smoother's 15-min blocks,
# the ground truth's 10,000-row blocks, /overview): a bound that does not grow with the length
FINISH_MARGIN_MB = 120.0


def _file_size_limit(limit: int) -> Callable[[], None]:
    def pre() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return pre


def row_diskfull_create(args: argparse.Namespace) -> list[Row]:
    limits = [8192, 16384] if args.quick else [4096, 8192, 12288, 16384, 24576, 27000]
    bad: list[str] = []
    segfaults = tracebacks = 0
    for limit in limits:
        with tempfile.TemporaryDirectory() as d:
            out = Path(d) / "g.h5"
            r = subprocess.run(
                [*GAITMON, "record", "--simulate", "--speed", "max", "--duration", "600",
                 "-o", str(out), "-q"], capture_output=True, text=True, timeout=120, env=env(),
                preexec_fn=_file_size_limit(limit),
            )  # fmt: skip
            lines = r.stderr.strip().splitlines()
            left = sorted(p.name for p in Path(d).iterdir())
            segfaults += r.returncode < 0
            tb = r.stderr.count("Traceback") + r.stderr.count("Exception ignored")
            tracebacks += tb
            # a limit past the empty file's size fails at the first rows instead: the file and
            # its journal stay (every row written is recovered), said in the one line
            ok = r.returncode == 2 and len(lines) == 1 and tb == 0 and (
                left == [] if "cannot create" in lines[0] else "up to row" in lines[0])
            if not ok:
                bad.append(f"{limit} B: exit {r.returncode}, {len(lines)} lines, {tb} tracebacks, "
                           f"left {left}")  # fmt: skip
    said = "; ".join(bad) if bad else "each exit 2 with one line, nothing left"
    figure = (f"{len(limits)} limits ({', '.join(str(x) for x in limits)} B): "
              f"{segfaults} segfaults, {tracebacks} tracebacks; {said}")  # fmt: skip
    return [Row("diskfull_create", "full disk at creation: exit 2, one line, 0 tracebacks, "
                "0 segfaults, no partial file", figure, not bad)]  # fmt: skip


SOAK_CHILD = textwrap.dedent("""
    import json, sys
    from pathlib import Path
    from gaitmon.commands.bench_memory import record_phases
    print(json.dumps(record_phases(float(sys.argv[1]), Path(sys.argv[2]))))
""")

CHECK_CHILD = textwrap.dedent("""
    import json, sys
    import numpy as np
    from gaitmon.finish import open_session
    with open_session(sys.argv[1]) as s:
        seq = np.asarray(s.read("timeline/seq"), np.int64)
        gaps = [(int(g.n_lost), g.reason) for g in s.gaps]
        complete = bool(s.complete)
    print(json.dumps({"missing": int((np.diff(seq) - 1).sum()), "rows": len(seq),
                      "gaps": gaps, "complete": complete}))
""")


def _busy() -> subprocess.Popen[bytes]:
    """A child process that keeps one CPU busy (the load of a busy clinic laptop)."""
    return subprocess.Popen([sys.executable, "-c", "while True: pass"])


def row_soak8h(args: argparse.Namespace) -> list[Row]:
    seconds = 1200.0 if args.quick else 8 * 3600.0
    label = f"{seconds / 3600:g} h" if seconds >= 3600 else f"{seconds / 60:g} min"
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "soak.h5"
        busy = _busy()
        try:
            r = subprocess.run([sys.executable, "-c", SOAK_CHILD, str(seconds), str(out)],
                               capture_output=True, text=True, env=env(),
                               timeout=seconds + 3600)  # fmt: skip
        finally:
            os.kill(busy.pid, signal.SIGKILL)
            busy.wait()
        if r.returncode != 0:
            tail = r.stderr.strip().splitlines()[-1:] or ["(no output)"]
            return [Row("soak8h", "runs", f"child failed: {tail[0][:200]}", False)]
        got = json.loads(r.stdout.strip().splitlines()[-1])
        chk = subprocess.run([sys.executable, "-c", CHECK_CHILD, str(out)], capture_output=True,
                             text=True, env=env(), timeout=600)  # fmt: skip
        if chk.returncode != 0:
            tail = chk.stderr.strip().splitlines()[-1:] or ["(no output)"]
            return [Row("soak8h", "file opens", f"cannot read: {tail[0][:200]}", False)]
        f = json.loads(chk.stdout)
    stderr = "\n".join(got["stderr"])
    m = re.search(r"; (\d+) frames? lost", stderr)
    reported = int(m.group(1)) if m else -1
    in_gaps = sum(n for n, _ in f["gaps"])
    unnamed = sum(n for n, why in f["gaps"] if not why.endswith("queue full"))
    lost_ok = (got["rc"] == 0 and "Traceback" not in stderr and f["complete"]
               and reported == f["missing"] == in_gaps and unnamed == 0)  # fmt: skip
    causes: dict[str, int] = {}
    for n, why in f["gaps"]:
        causes[why] = causes.get(why, 0) + n
    rec, fin = float(got["recording_rss_mb"]), float(got["rss_mb"])
    mem_ok = fin <= rec + FINISH_MARGIN_MB
    return [
        Row("soak8h: lost frames", f"{label} at --speed max beside a busy process: the file's "
            "missing sequence numbers = the last line's count = the gaps', each gap with a "
            "named cause",
            f"{f['rows']:,} rows; missing {f['missing']}, reported {reported}, in gaps "
            f"{in_gaps} ({causes or 'none'}); last line: {got['stderr'][-1:]}", lost_ok),
        Row("soak8h: finishing RSS", f"finishing peak <= recording peak + "
            f"{FINISH_MARGIN_MB:.0f} MB",
            f"recording {rec:.0f} MB, finishing {fin:.0f} MB ({fin - rec:+.0f}), "
            f"{float(got['cpu_s']):.1f} CPU s", mem_ok),
    ]  # fmt: skip


ROWS: dict[str, Callable[[argparse.Namespace], list[Row]]] = {
    "diskfull_create": row_diskfull_create,
    "soak8h": row_soak8h,
}
