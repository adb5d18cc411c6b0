"""Retake the README's pictures of the live monitor (issue 15: the clinical view and the guided
start), of a link cut (issue 11) and of a dead foot sensor (issue 13).

    python benchmarks/screenshots.py [--out assets]
        [--only live_fsr_fault|live_clinical|live_bilateral]

Starts ``Xvfb :97`` when no ``DISPLAY`` is set, then:

- ``live_gap_during.png``: the live window on the simulated unit (over a pseudo-terminal and the
  real serial transport), walking, 1.5 s into a 3 s cut (Device ▸ Simulator ▸ Cut link);
- ``live_gap_after.png``: the same window 4 s after the link came back;
- ``review_gap.png``: the review window on a recording with a 3 s cut, zoomed on the gap;
- ``report.png``: page 1 of ``gaitmon report`` of that recording (needs ``pdftoppm``);
- ``live_fsr_fault.png``: the live window walking, 10 s after Device ▸ Simulator ▸ Heel sensor
  dead: the force-sensor banner, the gait panel's event source, the tilt filter in the titles;
- ``live_guided_start.png``: a first run (fresh settings: the clinical view) just connected to
  the walking simulated subject: the guided start's "Stand still, then Zero" is the step to do;
- ``screenshot.png``: the same window after the steps were done with the guide's own buttons
  (Device ▸ Simulator ▸ Stand still, Zero, Walk again) and 10 s of walking: Record is next;
- ``live-bilateral.png``: the live window at its default size on a simulated pair of units
  (Device ▸ Connect simulated pair), a hemiparetic walk with the left leg affected, 20 s in.

The pictures are the windows' own rendering (``QWidget.grab``), so ``QT_QPA_PLATFORM=offscreen``
takes the same pictures where no X server can run.

Look at every picture before committing it: a picture not looked at is not done.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def ensure_display() -> subprocess.Popen[bytes] | None:
    if os.environ.get("DISPLAY"):
        return None
    xvfb = subprocess.Popen(["Xvfb", ":97", "-screen", "0", "1600x1000x24", "-nolisten", "tcp"])
    os.environ["DISPLAY"] = ":97"
    time.sleep(1.0)
    return xvfb


def wait(app, cond, timeout_s: float = 60.0) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            raise SystemExit("screenshots: timed out waiting for the window")
        app.processEvents()
        time.sleep(0.01)


def pause(app, seconds: float) -> None:  # type: ignore[no-untyped-def]
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        app.processEvents()
        time.sleep(0.01)


def pick_stride(review, row: int) -> None:  # type: ignore[no-untyped-def]
    """Select stride ``row`` in the review window's table as a click does (the timeline moves
    there)."""
    table = review.table
    table.selectRow(row)
    table.scrollTo(table.model().index(row, 0))
    table.stride_picked.emit(row)


def save(widget, path: Path) -> None:  # type: ignore[no-untyped-def]
    widget.grab().save(str(path))
    if shutil.which("convert") and path.stat().st_size > 300_000:
        subprocess.run(["convert", str(path), "-colors", "256", f"PNG8:{path}"], check=True)
    print(f"wrote {path} ({path.stat().st_size // 1024} KB)")


def record_cut(out: Path) -> None:
    """A 27 s walk with a real 3 s link cut at 12 s of device time and a marker before it."""
    from gaitmon.engine import Engine
    from gaitmon.io.device import Device
    from gaitmon.io.session import SessionMeta
    from gaitmon.io.sim import FaultConfig, GaitConfig, SimulatedUnit
    from gaitmon.io.sim.pty import PtySimulator
    from gaitmon.io.transport import SerialTransport

    unit = SimulatedUnit(
        GaitConfig(seed=3, standing_s=2.0), faults=FaultConfig(link_drops=((12.0, 3.0),)), speed=5
    )
    with PtySimulator(unit) as sim:
        eng = Engine(Device(SerialTransport(str(sim.link_path))), "raw", transport_label="pty")
        with eng:
            eng.start_recording(out, SessionMeta(patient_id="DEMO-01", side="R"))
            deadline = time.monotonic() + 120
            while eng.recording.rows < 400 and time.monotonic() < deadline:
                time.sleep(0.01)
            eng.add_marker("walk start")
            while eng.recording.rows < 2700 and time.monotonic() < deadline:
                time.sleep(0.02)
            eng.stop_recording()


def live_fsr_fault(app, out: Path, tmp: Path) -> None:  # type: ignore[no-untyped-def]
    from PySide6.QtCore import QSettings

    from gaitmon.io.sim.config import SimConfig
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.live import MainWindow

    settings = QSettings(str(tmp / "fsr.ini"), QSettings.Format.IniFormat)
    settings.setValue("view/engineering", True)  # the picture shows every trace
    win = MainWindow(settings, sim=SimConfig(standing_s=1.0), autoconnect=SIMULATED_PORT,
                     mode="raw", confirm_close=False)  # fmt: skip
    win.resize(1400, 880)
    win.show()
    wait(app, lambda: win.engine is not None and win.engine.samples_total >= 1000)
    win.sim_fsr_actions["heel_dead"].trigger()
    pause(app, 10.0)
    save(win, out / "live_fsr_fault.png")
    win.close()


def live_clinical(app, out: Path, tmp: Path) -> None:  # type: ignore[no-untyped-def]
    from PySide6.QtCore import QSettings

    from gaitmon.io.sim.config import SimConfig
    from gaitmon.live.connection import SIMULATED_PORT
    from gaitmon.ui.live import MainWindow

    settings = QSettings(str(tmp / "clinical.ini"), QSettings.Format.IniFormat)
    win = MainWindow(settings, sim=SimConfig(standing_s=0.0), mode="raw", confirm_close=False)
    win.resize(1400, 880)
    win.show()
    win.port_combo.setCurrentIndex(win.port_combo.findData(SIMULATED_PORT))
    win.guide.buttons[0].click()  # Connect
    wait(app, lambda: win.engine is not None and win.engine.samples_total >= 700)
    save(win, out / "live_guided_start.png")
    win.device_part.set_simulated_standing(True)
    at = win.engine.samples_total
    wait(app, lambda: win.engine.samples_total >= at + 600)
    win.guide.buttons[1].click()  # Zero
    wait(app, lambda: win.guide.states[1] == "done")
    win.device_part.set_simulated_standing(False)
    pause(app, 11.0)
    save(win, out / "screenshot.png")
    win.close()


def live_bilateral(app, out: Path, tmp: Path) -> None:  # type: ignore[no-untyped-def]
    from PySide6.QtCore import QSettings

    from gaitmon.io.sim.bilateral import BilateralConfig
    from gaitmon.ui.live import MainWindow

    settings = QSettings(str(tmp / "pair.ini"), QSettings.Format.IniFormat)
    config = BilateralConfig(standing_s=1.0, asymmetry="hemiparetic", affected="L")
    win = MainWindow(settings, pair_sim=config, mode="raw", confirm_close=False)
    win.resize(1400, 860)
    win.show()
    win._actions["pair_sim"].trigger()  # Device ▸ Connect simulated pair
    wait(app, lambda: win.pair is not None
         and min(e.samples_total for e in win.pair.engines.values()) >= 2000)  # fmt: skip
    pause(app, 1.0)
    save(win, out / "live-bilateral.png")
    win.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "assets")
    ap.add_argument("--only", choices=["live_fsr_fault", "live_clinical", "live_bilateral"],
                    help="take only this picture (live_clinical: screenshot.png and "
                    "live_guided_start.png)")  # fmt: skip
    args = ap.parse_args()
    xvfb = None if os.environ.get("QT_QPA_PLATFORM") == "offscreen" else ensure_display()
    try:
        from PySide6.QtCore import QSettings
        from PySide6.QtWidgets import QApplication

        from gaitmon.io.sim.config import SimConfig
        from gaitmon.live.connection import SIMULATED_PORT
        from gaitmon.ui.live import MainWindow
        from gaitmon.ui.review.window import ReviewWindow

        app = QApplication.instance() or QApplication(sys.argv)
        tmp = Path(tempfile.mkdtemp(prefix="gaitmon-shots-"))
        if args.only == "live_fsr_fault":
            live_fsr_fault(app, args.out, tmp)
            return 0
        if args.only == "live_clinical":
            live_clinical(app, args.out, tmp)
            return 0
        if args.only == "live_bilateral":
            live_bilateral(app, args.out, tmp)
            return 0
        settings = QSettings(str(tmp / "gaitmon.ini"), QSettings.Format.IniFormat)
        settings.setValue("view/engineering", True)  # every trace breaks at the gap
        win = MainWindow(settings, sim=SimConfig(standing_s=1.0), autoconnect=SIMULATED_PORT,
                         mode="raw", confirm_close=False)  # fmt: skip
        win.resize(1400, 880)
        win.show()
        wait(app, lambda: win.engine is not None and win.engine.samples_total >= 1100)
        win.device_part.cut_simulated_link(3.0)
        wait(app, lambda: win.status.state_text.startswith("Reconnecting"))
        pause(app, 1.5)
        save(win, args.out / "live_gap_during.png")
        wait(app, lambda: win.status.state_text == "Connected")
        pause(app, 4.0)
        save(win, args.out / "live_gap_after.png")
        win.close()

        rec = tmp / "demo_cut.h5"
        record_cut(rec)
        review = ReviewWindow(QSettings(str(tmp / "review.ini"), QSettings.Format.IniFormat))
        review.resize(1600, 1000)
        review.show()
        review.open_file(rec)
        wait(app, lambda: review.analysis is not None and review.table.model().rowCount() > 0)
        review.timeline.set_view(8.0, 27.5)
        pause(app, 2.0)
        save(review, args.out / "review_gap.png")
        review.close()

        pdf = tmp / "report.pdf"
        subprocess.run([sys.executable, "-m", "gaitmon", "report", str(rec), "-o", str(pdf)],
                       check=True)  # fmt: skip
        if shutil.which("pdftoppm"):
            subprocess.run(["pdftoppm", "-png", "-r", "70", "-f", "1", "-l", "1", "-singlefile",
                            str(pdf), str(args.out / "report")], check=True)  # fmt: skip
            print(f"wrote {args.out / 'report.png'}")
        live_fsr_fault(app, args.out, tmp)
        live_clinical(app, args.out, tmp)
        live_bilateral(app, args.out, tmp)
        return 0
    finally:
        if xvfb is not None:
            xvfb.terminate()


if __name__ == "__main__":
    raise SystemExit(main())
