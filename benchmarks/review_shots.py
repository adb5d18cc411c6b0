"""Take the README's pictures of the review window: one leg, and a both-legs session.

    python benchmarks/review_shots.py [--out assets] [--only review|review_bilateral]

Starts ``Xvfb :88`` when no ``DISPLAY`` is set, records with the CLI's simulator into a
temporary folder and opens each recording in the review window at 1500x960:

- ``review.png``: a 60 s simulated walk of one leg (right, zeroed at the standing pose), a
  stride selected in the Strides tab;
- ``review_bilateral.png``: a 40 s simulated pair of units, a hemiparetic walk with the left
  leg affected (``--simulate-bilateral --asymmetry hemiparetic --affected L``), opened on the
  left leg with the Both legs tab shown (the symmetry table and the overlaid cycles).

Look at every picture before committing it: a picture not looked at is not done.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from screenshots import pause, pick_stride, save, wait

ROOT = Path(__file__).resolve().parent.parent
SIZE = (1500, 960)


def ensure_display() -> subprocess.Popen[bytes] | None:
    if os.environ.get("DISPLAY"):
        return None
    xvfb = subprocess.Popen(["Xvfb", ":88", "-screen", "0", "1600x1000x24", "-nolisten", "tcp"])
    os.environ["DISPLAY"] = ":88"
    time.sleep(1.0)
    return xvfb


def open_review(app, tmp: Path, rec: Path):  # type: ignore[no-untyped-def]
    from PySide6.QtCore import QSettings

    from gaitmon.ui.review.window import ReviewWindow

    review = ReviewWindow(QSettings(str(tmp / f"{rec.stem}.ini"), QSettings.Format.IniFormat))
    review.resize(*SIZE)
    review.show()
    return review


def check_length(review, duration_s: float) -> None:  # type: ignore[no-untyped-def]
    """Refuse a recording shorter than asked (a run once kept 5.7 of 60 s): not the picture
    the README describes."""
    rows, fs = review.doc.n_rows, review.doc.fs_hz
    if rows < 0.95 * duration_s * fs:
        raise SystemExit(f"review_shots: the recording holds {rows / fs:.1f} s, not "
                         f"{duration_s:g} s; run again")  # fmt: skip


def review_one_leg(app, out: Path, tmp: Path) -> int:  # type: ignore[no-untyped-def]
    from gaitmon.cli import main as gaitmon

    rec = tmp / "demo_walk.h5"
    rc = gaitmon(["record", "--simulate", "--duration", "60", "-o", str(rec), "--speed", "20",
                  "--standing-s", "5", "--zero", "--quiet", "--patient", "DEMO-03",
                  "--side", "R", "--seed", "5"])  # fmt: skip
    if rc:
        return rc
    review = open_review(app, tmp, rec)
    review.open_file(rec)
    wait(app, lambda: review.analysis is not None and review.table.model().rowCount() > 0)
    check_length(review, 60.0)
    pick_stride(review, min(20, review.table.model().rowCount() - 1))
    pause(app, 2.0)
    save(review, out / "review.png")
    review.close()
    return 0


def review_bilateral(app, out: Path, tmp: Path) -> int:  # type: ignore[no-untyped-def]
    from gaitmon.cli import main as gaitmon

    rec = tmp / "demo_both.h5"
    rc = gaitmon(["record", "--simulate-bilateral", "--asymmetry", "hemiparetic",
                  "--affected", "L", "--duration", "40", "-o", str(rec), "--speed", "4",
                  "--standing-s", "5", "--zero", "--quiet", "--patient", "DEMO-17"])  # fmt: skip
    if rc:
        return rc
    review = open_review(app, tmp, rec)
    computed: list[int] = []
    review.legs.computed.connect(lambda: computed.append(1))
    review.open_file(rec, "L")
    wait(app, lambda: review.analysis is not None and review.table.model().rowCount() > 0
         and bool(computed))  # fmt: skip
    check_length(review, 40.0)
    review.tabs.setCurrentWidget(review.both_legs)
    pause(app, 2.0)
    save(review, out / "review_bilateral.png")
    review.close()
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "assets")
    ap.add_argument("--only", choices=["review", "review_bilateral"])
    args = ap.parse_args()
    xvfb = None if os.environ.get("QT_QPA_PLATFORM") == "offscreen" else ensure_display()
    try:
        from PySide6.QtWidgets import QApplication

        app = QApplication.instance() or QApplication(sys.argv)
        tmp = Path(tempfile.mkdtemp(prefix="gaitmon-shots-"))
        if args.only != "review_bilateral":
            rc = review_one_leg(app, args.out, tmp)
            if rc:
                return rc
        if args.only != "review":
            return review_bilateral(app, args.out, tmp)
        return 0
    finally:
        if xvfb is not None:
            xvfb.terminate()


if __name__ == "__main__":
    raise SystemExit(main())
