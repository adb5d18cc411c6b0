"""Retake the README's picture of the review window's Compare view (issue 15, section 4).

    python benchmarks/screenshot_compare.py [--out assets]

Starts ``Xvfb :92`` when no ``DISPLAY`` is set, writes two simulated sessions of one patient a
month apart (a stiff knee, then normal gait: 30 s each, with SessionWriter so that they carry
their dates), opens the review window, compares them through File ▸ Compare sessions… (the
file dialog answered) and saves the Compare view as ``compare.png``. Look at it before
committing it.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def write_session(path: Path, pattern: str, created_utc: str, seed: int) -> Path:
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import realistic_sensors, simulate

    fs, n = 100.0, 3000
    counts = simulate(n, GaitModel(GaitConfig(seed=seed, pattern=pattern, standing_s=2.0)),
                      realistic_sensors(seed)).counts  # fmt: skip
    header = SessionHeader("raw", fs, meta=SessionMeta(patient_id="DEMO-01", side="R"),
                           config=PipelineConfig(), created_utc=created_utc)  # fmt: skip
    w = SessionWriter(path, header)
    pipe = Pipeline(PipelineConfig())
    for i in range(0, n, 50):
        adc = counts[i : i + 50]
        seq = np.arange(i, i + len(adc), dtype=np.int64)
        w.append(SampleBlock(FrameKind.RAW, seq, seq / fs, 1.7e9,
                             lost_before=np.zeros(len(adc), np.int64), adc=adc),
                 pipe.process(adc))  # fmt: skip
    w.close()
    return path


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, default=Path("assets"))
    args = ap.parse_args()
    xvfb = None
    if not os.environ.get("DISPLAY"):
        xvfb = subprocess.Popen(["Xvfb", ":92", "-screen", "0", "1600x1000x24", "-nolisten",
                                 "tcp"])  # fmt: skip
        os.environ["DISPLAY"] = ":92"
        time.sleep(1.0)
    os.environ.setdefault("QT_QPA_PLATFORM", "xcb")
    try:
        from PySide6.QtCore import QSettings
        from PySide6.QtWidgets import QApplication, QFileDialog

        from gaitmon.ui.review.window import ReviewWindow

        app = QApplication.instance() or QApplication(sys.argv)
        with tempfile.TemporaryDirectory() as d:
            tmp = Path(d)
            files = [write_session(tmp / "DEMO-01_2026-10-05.h5", "stiff-knee",
                                   "2026-10-05T09:10:00Z", 3),  # one seed: one fit of
                     write_session(tmp / "DEMO-01_2026-11-09.h5", "normal",
                                   "2026-11-09T09:40:00Z", 3)]  # the sensors  # fmt: skip
            QFileDialog.getOpenFileNames = staticmethod(  # type: ignore[method-assign]
                lambda *a, **k: ([str(f) for f in files], ""))
            win = ReviewWindow(QSettings(str(tmp / "review.ini"), QSettings.Format.IniFormat))
            win.show()
            win.act["compare_sessions"].trigger()
            deadline = time.monotonic() + 60
            while win.comparer.view is None or win.comparer.view.comparison is None:
                if time.monotonic() > deadline:
                    raise SystemExit("screenshot: the comparison did not arrive")
                app.processEvents()
                time.sleep(0.01)
            view = win.comparer.view
            view.resize(1500, 980)
            end = time.monotonic() + 1.5
            while time.monotonic() < end:
                app.processEvents()
                time.sleep(0.01)
            args.out.mkdir(exist_ok=True)
            out = args.out / "compare.png"
            view.grab().save(str(out))
            print(f"wrote {out} ({out.stat().st_size // 1024} KB) on "
                  f"{app.platformName()}")  # fmt: skip
            win.close()
    finally:
        if xvfb is not None:
            xvfb.terminate()
            xvfb.wait(5)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
