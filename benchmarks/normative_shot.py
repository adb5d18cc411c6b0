"""Take the pictures of a normative band in review and in the report (issue 15, normal data).

    python benchmarks/normative_shot.py [--out assets] [--band FILE] [--pattern stiff-knee]

Starts ``Xvfb :93`` when no ``DISPLAY`` is set, records 40 s of the simulator walking (the
given pattern, zeroed at the standing pose), opens it in the review window, loads the band
(default: ``docs/normative-example.csv``, the format example, which says it is not normal
data: gaitmon ships no normal data) and saves ``review_normative.png``; then writes
``gaitmon report --normative`` and saves page 1 as ``report_normative.png`` (needs pdftoppm).

Look at every picture before committing it: a picture not looked at is not done.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from screenshots import pause, save, wait

ROOT = Path(__file__).resolve().parent.parent


def ensure_display():  # type: ignore[no-untyped-def]
    import time

    if os.environ.get("DISPLAY"):
        return None
    xvfb = subprocess.Popen(["Xvfb", ":93", "-screen", "0", "1600x1000x24", "-nolisten", "tcp"])
    os.environ["DISPLAY"] = ":93"
    time.sleep(1.0)
    return xvfb


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "assets")
    ap.add_argument("--band", type=Path, default=ROOT / "docs" / "normative-example.csv")
    ap.add_argument("--pattern", default="stiff-knee")
    args = ap.parse_args()
    xvfb = ensure_display()
    try:
        from PySide6.QtCore import QSettings
        from PySide6.QtWidgets import QApplication

        from gaitmon.cli import main as gaitmon
        from gaitmon.ui.review.window import ReviewWindow

        app = QApplication.instance() or QApplication(sys.argv)
        tmp = Path(tempfile.mkdtemp(prefix="gaitmon-shots-"))
        rec = tmp / "demo_band.h5"
        rc = gaitmon(["record", "--simulate", "--duration", "40", "-o", str(rec), "--speed", "20",
                      "--standing-s", "5", "--zero", "--quiet", "--patient", "DEMO-15",
                      "--side", "R", "--pattern", args.pattern])  # fmt: skip
        if rc:
            return rc
        review = ReviewWindow(QSettings(str(tmp / "review.ini"), QSettings.Format.IniFormat))
        review.resize(1600, 1000)
        review.show()
        review.open_file(rec)
        wait(app, lambda: review.analysis is not None and review.table.model().rowCount() > 0)
        review.strides.load_normative(args.band)
        pause(app, 2.0)
        save(review, args.out / "review_normative.png")
        review.close()
        pdf = tmp / "report.pdf"
        rc = gaitmon(["report", str(rec), "-o", str(pdf), "--normative", str(args.band)])
        if rc:
            return rc
        if shutil.which("pdftoppm"):
            subprocess.run(["pdftoppm", "-png", "-r", "70", "-f", "1", "-l", "1", "-singlefile",
                            str(pdf), str(args.out / "report_normative")], check=True)  # fmt: skip
            print(f"wrote {args.out / 'report_normative.png'}")
        return 0
    finally:
        if xvfb is not None:
            xvfb.terminate()


if __name__ == "__main__":
    raise SystemExit(main())
