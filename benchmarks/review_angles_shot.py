"""Take the README/docs picture of the review window showing the smoothed angles (issue 13).

    python benchmarks/review_angles_shot.py [--out assets] [--live]

Starts ``Xvfb :96`` when no ``DISPLAY`` is set, writes a 60 s simulated walk whose heel force
sensor breaks at 30 s (so the foot-gyro cross-check flags it and review shows the note), opens
it in the review window (the default angles: smoothed, zero-lag) and saves
``review_smoothed.png``; with ``--live`` also ``review_live.png`` after View ▸ Angles ▸ Live.

Look at every picture before committing it: a picture not looked at is not done.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np
from screenshots import pause, pick_stride, save, wait


def ensure_display():  # type: ignore[no-untyped-def]
    import subprocess
    import time

    if os.environ.get("DISPLAY"):
        return None
    xvfb = subprocess.Popen(["Xvfb", ":96", "-screen", "0", "1600x1000x24", "-nolisten", "tcp"])
    os.environ["DISPLAY"] = ":96"
    time.sleep(1.0)
    return xvfb


def write_walk(path: Path, n: int = 6000, dead_from: int = 3000, fs: float = 100.0) -> None:
    """A raw-mode session of the simulator's walk; the heel sensor reads ~0 from ``dead_from``."""
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import FSR_IDX
    from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import realistic_sensors, simulate

    counts = simulate(n, GaitModel(GaitConfig(seed=11)), realistic_sensors(11)).counts.copy()
    counts[dead_from:, FSR_IDX[0]] = 15
    header = SessionHeader("raw", fs, meta=SessionMeta(patient_id="DEMO-02", side="R"),
                           config=PipelineConfig(), calibration=Calibration.identity())
    w = SessionWriter(path, header)
    pipe = Pipeline(PipelineConfig())
    for i in range(0, n, 25):
        seq = np.arange(i, min(n, i + 25), dtype=np.int64)
        adc = counts[seq]
        w.append(SampleBlock(FrameKind.RAW, seq, seq / fs, 1.7e9,
                             lost_before=np.zeros(len(seq), np.int64), adc=adc),
                 pipe.process(adc))  # fmt: skip
    w.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "assets")
    ap.add_argument("--live", action="store_true", help="also the live angles' picture")
    args = ap.parse_args()
    xvfb = ensure_display()
    try:
        from PySide6.QtCore import QSettings
        from PySide6.QtWidgets import QApplication

        from gaitmon.ui.review.window import ReviewWindow

        app = QApplication.instance() or QApplication(sys.argv)
        tmp = Path(tempfile.mkdtemp(prefix="gaitmon-shots-"))
        rec = tmp / "demo_walk.h5"
        write_walk(rec)
        review = ReviewWindow(QSettings(str(tmp / "review.ini"), QSettings.Format.IniFormat))
        review.resize(1600, 1000)
        review.show()
        review.open_file(rec)
        wait(app, lambda: review.analysis is not None and review.table.model().rowCount() > 0)
        pick_stride(review, 31)  # after the heel sensor broke: events from the foot gyro
        pause(app, 2.0)
        save(review, args.out / "review_smoothed.png")
        if args.live:
            done = []
            review.analysis_done.connect(lambda: done.append(1))
            review.act["angles_live"].trigger()
            wait(app, lambda: bool(done) and review.doc.angle_source == "live")
            pause(app, 2.0)
            save(review, args.out / "review_live.png")
        review.close()
        return 0
    finally:
        if xvfb is not None:
            xvfb.terminate()


if __name__ == "__main__":
    raise SystemExit(main())
