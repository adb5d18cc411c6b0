"""Review-window pieces driven as a user would: the export dialog, plot export, the Filters view.

The session is recorded from the simulator, so it carries ground truth (``/truth``): the
Filters view's RMSE is checked against a plain-numpy computation from the file's datasets.
"""

from __future__ import annotations

import csv
import json
import threading
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pyqtgraph as pg
import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QImage

from gaitmon.dsp.lab_filters import TILT_FILTERS, make_tilt_filter
from gaitmon.export import export_session
from gaitmon.finish import open_session

PATIENT = "P-0042"


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory, record_simulated) -> Path:
    return record_simulated(
        tmp_path_factory.mktemp("widgets") / "walk.h5", "--patient", PATIENT, "--loss-pct", "0.5"
    )


def _rgb(img) -> np.ndarray:
    """(pixels, 3) int array of a QImage (kept alive while its bits are copied; rows unpadded)."""
    from PySide6.QtGui import QImage

    conv = img.convertToFormat(QImage.Format.Format_RGB888)
    raw = np.frombuffer(conv.constBits(), np.uint8, count=conv.sizeInBytes()).copy()
    rows = raw.reshape(conv.height(), conv.bytesPerLine())[:, : conv.width() * 3]
    return rows.reshape(-1, 3).astype(int)


# ---- export dialog ----------------------------------------------------------------------------


def _dialog(qtbot, session: Path, **kw):
    from gaitmon.ui.review.export_dialog import ExportDialog

    dlg = ExportDialog(session, **kw)
    qtbot.addWidget(dlg)
    dlg.show()
    return dlg


def test_export_dialog_writes_a_csv_that_reads_back(qtbot, session: Path, tmp_path: Path) -> None:
    dlg = _dialog(qtbot, session)
    dlg.set_format("csv")
    out = tmp_path / "walk.csv"
    dlg.output_edit.setText(str(out))
    qtbot.mouseClick(dlg.deidentify_check, Qt.MouseButton.LeftButton)
    assert dlg.deidentify_check.isChecked()
    with qtbot.waitSignal(dlg.export_finished, timeout=30_000):
        qtbot.mouseClick(dlg.export_button, Qt.MouseButton.LeftButton)
    assert not dlg.is_running and dlg.progress_bar.value() == 1000
    assert "Exported" in dlg.status_label.text()
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    with open_session(session) as s:
        knee = s.read("processed/joint_deg")[:, 1]
        t = s.read("timeline/t_s")
    assert len(rows) == len(knee)
    np.testing.assert_allclose([float(r["knee_flexion_deg"]) for r in rows], knee, atol=6e-5)
    np.testing.assert_allclose([float(r["t_s"]) for r in rows], t, atol=6e-7)
    meta = json.loads(out.with_name("walk.meta.json").read_text())
    assert meta["deidentified"] is True and meta["session"]["patient_id"] == ""
    assert PATIENT not in out.with_name("walk.meta.json").read_text()


def test_export_dialog_mat_and_format_switch(qtbot, session: Path, tmp_path: Path) -> None:
    from scipy.io import loadmat

    dlg = _dialog(qtbot, session)
    dlg.output_edit.setText(str(tmp_path / "x.csv"))
    dlg.set_format("mat")
    assert dlg.output_edit.text() == str(tmp_path / "x.mat")  # extension follows the format
    with qtbot.waitSignal(dlg.export_finished, timeout=30_000) as sig:
        dlg.export_button.click()
    assert sig.args[0].paths == (tmp_path / "x.mat",)
    m = loadmat(tmp_path / "x.mat", squeeze_me=False, struct_as_record=False)["session"][0, 0]
    with open_session(session) as s:
        np.testing.assert_array_equal(m.joint_deg, s.read("processed/joint_deg"))
        assert str(m.meta[0, 0].session[0, 0].patient_id[0]) == PATIENT


def test_export_dialog_refuses_to_overwrite_unless_asked(qtbot, session, tmp_path) -> None:
    out = tmp_path / "walk.csv"
    out.write_text("keep")
    dlg = _dialog(qtbot, session)
    dlg.set_format("csv")
    dlg.output_edit.setText(str(out))
    with qtbot.waitSignal(dlg.export_failed, timeout=30_000) as sig:
        dlg.export_button.click()
    assert "exists" in sig.args[0] and "\n" not in sig.args[0]
    assert out.read_text() == "keep"
    dlg.overwrite_check.setChecked(True)
    with qtbot.waitSignal(dlg.export_finished, timeout=30_000):
        dlg.export_button.click()
    assert out.read_text().startswith("t_s,")


def test_export_dialog_cancel_leaves_no_file(qtbot, session: Path, tmp_path: Path) -> None:
    """Cancel while the export is between two chunks: nothing is left, the GUI stays live."""
    reached, release = threading.Event(), threading.Event()

    def gated_export(src, fmt, out, **kw):
        progress = kw.pop("progress")

        def slow_progress(fraction: float) -> None:
            if not reached.is_set():
                reached.set()
                release.wait(30)  # the user clicks Cancel meanwhile
            progress(fraction)

        # small chunks so the CSV writer reports progress several times
        return export_session(src, fmt, out, progress=slow_progress, chunk_rows=500, **kw)

    dlg = _dialog(qtbot, session, export_fn=gated_export)
    dlg.set_format("csv")
    out = tmp_path / "c.csv"
    dlg.output_edit.setText(str(out))
    dlg.export_button.click()
    qtbot.waitUntil(reached.is_set, timeout=30_000)
    assert dlg.is_running and dlg.cancel_button.isEnabled() and not dlg.export_button.isEnabled()
    qtbot.mouseClick(dlg.cancel_button, Qt.MouseButton.LeftButton)  # the GUI thread is free
    assert dlg.status_label.text() == "Cancelling…"
    with qtbot.waitSignal(dlg.export_failed, timeout=30_000) as sig:
        release.set()
    assert "cancelled" in sig.args[0]
    assert not dlg.is_running and dlg.export_button.isEnabled()
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no output, no temporary file


# ---- export dialog: BIDS ------------------------------------------------------------------------

# gaitmon export's default without --deidentify/--no-deidentify, format by format (its --help:
# "default: on for bids, off for the others")
CLI_DEIDENTIFY_DEFAULT = {"csv": False, "mat": False, "c3d": False, "strides": False,
                          "bids": True}  # fmt: skip


def _tree_text(root: Path) -> str:
    """Every path under ``root`` and every file's bytes (as text), to search for the patient."""
    parts = []
    for p in sorted(root.rglob("*")):
        parts.append(p.relative_to(root).as_posix())
        if p.is_file():
            parts.append(p.read_bytes().decode("utf-8", errors="replace"))
    return "\n".join(parts)


def _bids_files(root: Path, sub: str, ses: str | None, task: str = "walk") -> set[str]:
    folder = f"sub-{sub}/" + (f"ses-{ses}/" if ses else "") + "motion/"
    stem = f"sub-{sub}" + (f"_ses-{ses}" if ses else "") + f"_task-{task}_"
    unit = stem + "tracksys-imu_"  # the unit, by its leg: the fixture has no side
    return {"README", "dataset_description.json", "participants.tsv", ".bidsignore",
            *(folder + unit + s for s in ("motion.tsv", "channels.tsv", "channels.json",
                                          "motion.json", "gaitmon.json")),
            *(folder + stem + s for s in ("events.tsv", "events.json"))}  # fmt: skip


def _export_bids(qtbot, dlg, out: Path):
    dlg.output_edit.setText(str(out))
    with qtbot.waitSignal(dlg.export_finished, timeout=60_000) as sig:
        qtbot.mouseClick(dlg.export_button, Qt.MouseButton.LeftButton)
    return sig.args[0]


def test_export_dialog_deidentify_defaults_agree_with_the_command_line(qtbot, session) -> None:
    from gaitmon.cli import build_parser
    from gaitmon.export import FORMATS

    dlg = _dialog(qtbot, session)
    assert set(CLI_DEIDENTIFY_DEFAULT) == set(FORMATS)
    for fmt in ("bids", "csv", "mat", "c3d", "strides", "bids"):  # there and back again
        dlg.set_format(fmt)
        assert dlg.deidentify_check.isChecked() is CLI_DEIDENTIFY_DEFAULT[fmt], fmt
        assert FORMATS[fmt].deidentify_default is CLI_DEIDENTIFY_DEFAULT[fmt], fmt
        assert dlg.bids_box.isVisibleTo(dlg) is (fmt == "bids"), fmt
    # the command line leaves the choice to the format (None) unless told
    args = build_parser("export").parse_args(["export", str(session), "--format", "bids"])
    assert args.deidentify is None


def test_export_dialog_bids_asks_for_a_folder_not_a_file(qtbot, session, tmp_path) -> None:
    dlg = _dialog(qtbot, session)
    dlg.output_edit.setText(str(tmp_path / "mine.csv"))
    dlg.set_format("bids")
    folder = Path(dlg.output_edit.text())
    assert dlg.save_label.text() == "Folder" and folder.suffix == ""
    assert folder.parent == session.parent and session.stem not in folder.name  # de-identified
    assert (dlg.subject_edit.text(), dlg.session_edit.text(), dlg.task_edit.text()) == (
        "01", "", "walk")
    dlg.output_edit.setText(str(tmp_path / "study"))
    dlg.set_format("csv")  # back to a file: the file chosen before, not the folder
    assert dlg.output_edit.text() == str(tmp_path / "mine.csv")
    dlg.set_format("bids")
    assert dlg.output_edit.text() == str(tmp_path / "study")


def test_export_dialog_writes_a_deidentified_bids_dataset(qtbot, session, tmp_path) -> None:
    dlg = _dialog(qtbot, session)
    dlg.set_format("bids")
    dlg.session_edit.setText("pre")
    out = tmp_path / "study"
    result = _export_bids(qtbot, dlg, out)
    got = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert got == _bids_files(out, "01", "pre")  # no scans.tsv: it would date the recording
    assert {p.relative_to(out).as_posix() for p in result.paths} == got
    assert "files in" in dlg.status_label.text()
    text = _tree_text(out)
    assert PATIENT not in text and PATIENT.replace("-", "") not in text
    motion = out / "sub-01/ses-pre/motion/sub-01_ses-pre_task-walk_tracksys-imu_motion.tsv"
    chans = (out / "sub-01/ses-pre/motion/sub-01_ses-pre_task-walk_tracksys-imu_channels.tsv")
    lines = motion.read_text().splitlines()
    n_channels = len(chans.read_text().splitlines()) - 1
    with open_session(session) as s:
        t = s.read("timeline/t_s")
        knee = s.read("processed/joint_deg")[:, 1]
    # one row per 1/fs from the first sample (lost frames are n/a rows), no header
    assert len(lines) == round((t[-1] - t[0]) * 100) + 1
    assert all(len(line.split("\t")) == n_channels for line in lines)
    names = [r.split("\t")[0] for r in chans.read_text().splitlines()[1:]]
    assert float(lines[0].split("\t")[names.index("knee_flexion")]) == pytest.approx(
        knee[0], abs=6e-5)


def test_export_dialog_bids_subject_from_a_map_file(qtbot, session, tmp_path) -> None:
    mapping = tmp_path / "subjects.tsv"
    mapping.write_text(f"patient_id\tlabel\nsomeone-else\t03\n{PATIENT}\t07\n")
    dlg = _dialog(qtbot, session)
    dlg.set_format("bids")
    dlg.subject_map_edit.setText(str(mapping))
    assert not dlg.subject_edit.isEnabled()  # the map decides the label
    out = tmp_path / "study"
    _export_bids(qtbot, dlg, out)
    assert {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()} == (
        _bids_files(out, "07", None))
    assert PATIENT not in _tree_text(out)
    # a patient the map does not know: the command line's message, one line, nothing written
    mapping.write_text("patient_id\tlabel\nsomeone-else\t03\n")
    dlg.output_edit.setText(str(tmp_path / "other"))
    with qtbot.waitSignal(dlg.export_failed, timeout=60_000) as sig:
        dlg.export_button.click()
    assert "no row" in sig.args[0] and "\n" not in sig.args[0] and PATIENT not in sig.args[0]
    assert not (tmp_path / "other").exists()


def test_export_dialog_bids_patient_id_only_when_ticked(qtbot, session, tmp_path) -> None:
    dlg = _dialog(qtbot, session)
    dlg.set_format("bids")
    assert not dlg.patient_id_warning.isVisibleTo(dlg)
    qtbot.mouseClick(dlg.patient_id_check, Qt.MouseButton.LeftButton)
    assert dlg.patient_id_check.isChecked() and dlg.patient_id_warning.isVisibleTo(dlg)
    assert "identify the patient" in dlg.patient_id_warning.text()
    assert not dlg.subject_edit.isEnabled() and not dlg.subject_map_edit.isEnabled()
    out = tmp_path / "named"
    _export_bids(qtbot, dlg, out)
    label = PATIENT.replace("-", "")  # letters and digits of the id, as --subject-from-patient-id
    assert {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()} == (
        _bids_files(out, label, None))
    # asked for: the label is the id, but the other identifying fields are still left out
    motion_json = next(out.rglob("*_motion.json")).read_text()
    assert PATIENT not in motion_json
    qtbot.mouseClick(dlg.patient_id_check, Qt.MouseButton.LeftButton)
    assert not dlg.patient_id_warning.isVisibleTo(dlg) and dlg.subject_edit.isEnabled()


@pytest.mark.parametrize(("field", "value", "option"), [
    ("subject_edit", "P-01", "--subject"), ("session_edit", "a b", "--session"),
    ("task_edit", "walk_fast", "--task"),
])  # fmt: skip
def test_export_dialog_bad_bids_label_is_the_command_lines_message(
    qtbot, session, tmp_path, capsys, field, value, option
) -> None:
    from gaitmon.cli import main

    assert main(["export", str(session), "--format", "bids", "-o", str(tmp_path / "cli"), "-q",
                 option, value]) == 2  # fmt: skip
    cli_message = capsys.readouterr().err.strip()
    dlg = _dialog(qtbot, session)
    dlg.set_format("bids")
    getattr(dlg, field).setText(value)
    dlg.output_edit.setText(str(tmp_path / "gui"))
    with qtbot.waitSignal(dlg.export_failed, timeout=5_000) as sig:
        dlg.export_button.click()
    message = sig.args[0]
    assert "letters and digits" in message and "\n" not in message
    assert cli_message.endswith(message)  # the same words, from the same check
    assert not dlg.is_running and dlg.status_label.text() == message
    assert not (tmp_path / "gui").exists() and not (tmp_path / "cli").exists()


# ---- plot export ------------------------------------------------------------------------------


def _plot(qtbot) -> pg.PlotWidget:
    w = pg.PlotWidget()
    qtbot.addWidget(w)
    w.resize(500, 300)
    w.plot(np.arange(50.0), np.sin(np.arange(50) / 5.0), pen="r")
    fill_lo = pg.PlotDataItem(np.arange(50.0), np.full(50, -0.5))
    fill_hi = pg.PlotDataItem(np.arange(50.0), np.full(50, 0.5))
    w.addItem(pg.FillBetweenItem(fill_lo, fill_hi, brush=(0, 0, 255, 50)))  # a closed path
    w.show()
    qtbot.waitExposed(w)
    return w


def test_export_plot_png_and_svg(qtbot, tmp_path: Path) -> None:
    from PySide6.QtSvg import QSvgRenderer

    from gaitmon.ui.review.plot_export import PlotExportError, export_plot

    w = _plot(qtbot)
    png = export_plot(w, tmp_path / "p.png", width_px=900)
    img = QImage(str(png))
    assert not img.isNull() and img.width() == 900
    # the red trace is in the picture
    rgb = _rgb(img)
    assert np.sum((rgb[:, 0] > 200) & (rgb[:, 1] < 60) & (rgb[:, 2] < 60)) > 100
    svg = export_plot(w.getPlotItem(), tmp_path / "p.svg")
    root = ET.parse(svg).getroot()
    assert root.tag.endswith("svg")
    shapes = [el for el in root.iter() if el.tag.split("}")[-1] in ("path", "polyline")]
    assert len(shapes) >= 3
    assert QSvgRenderer(str(svg)).isValid()
    layout = pg.GraphicsLayoutWidget()
    qtbot.addWidget(layout)
    layout.addPlot().plot([1, 2, 3])
    layout.nextRow()
    layout.addPlot().plot([3, 2, 1])
    assert QImage(str(export_plot(layout, tmp_path / "l.png"))).height() > 0
    with pytest.raises(PlotExportError, match=r"\.png or \.svg"):
        export_plot(w, tmp_path / "p.jpg")
    with pytest.raises(PlotExportError, match="does not exist"):
        export_plot(w, tmp_path / "no" / "p.png")


def test_export_action_in_the_plot_menu(qtbot, tmp_path: Path, monkeypatch) -> None:
    from PySide6.QtWidgets import QFileDialog

    from gaitmon.ui.review.plot_export import attach_export_action

    w = _plot(qtbot)
    action = attach_export_action(w, w)
    assert action in w.getPlotItem().getViewBox().menu.actions()
    target = tmp_path / "menu"  # no extension: the chosen filter decides
    monkeypatch.setattr(
        QFileDialog,
        "getSaveFileName",
        staticmethod(lambda *a, **k: (str(target), "SVG vector image (*.svg)")),
    )
    action.trigger()
    assert (tmp_path / "menu.svg").stat().st_size > 0


# ---- Filters view -----------------------------------------------------------------------------


def _view(qtbot):
    from gaitmon.ui.review.filters_view import FiltersView

    v = FiltersView()
    qtbot.addWidget(v)
    v.resize(1000, 600)
    v.show()
    return v


def _knee_rmse_by_hand(session: Path) -> dict[str, float]:
    """Accelerometer and gyro-integration knee angles vs the simulator's true knee angle."""
    from gaitmon.finish import open_session

    with open_session(session) as s:  # (the format derives the gyro, quantises the acc)
        acc = s.read("processed/acc_ms2").astype(np.float64)
        gyro = s.read("processed/gyro_rad_s").astype(np.float64)
    with h5py.File(session) as f:
        true_knee = f["truth/joint_deg"][()][:, 1].astype(np.float64)
        mount = np.radians(f["truth"].attrs["mount_offset_deg"])
        fs = float(f.attrs["sample_rate_hz"])
    acc_tilt = np.arctan2(acc[:, :, 1], acc[:, :, 0])
    gyro_tilt = acc_tilt[0] + np.cumsum(gyro, axis=0) / fs  # theta(-1) = first acc tilt
    out = {}
    for name, tilt in (("accelerometer", acc_tilt), ("gyro", gyro_tilt)):
        aligned = tilt - mount
        knee = np.degrees(aligned[:, 1] - aligned[:, 2])  # thigh - shank
        err = (knee - true_knee + 180.0) % 360.0 - 180.0
        ok = np.isfinite(true_knee)
        out[name] = float(np.sqrt(np.mean(err[ok] ** 2)))
    return out


def test_filters_view_lists_registry_and_rmse_matches_hand_computation(qtbot, session) -> None:
    v = _view(qtbot)
    assert v.filter_names() == list(TILT_FILTERS)
    v.load_session(session)
    v.set_checked(["accelerometer", "gyro"])
    v.target_combo.setCurrentText("knee flexion (deg)")
    v.set_range(0.0, 1e6)  # the whole session: the filters start at row 0, as by hand
    with qtbot.waitSignal(v.computed, timeout=30_000):
        v.compute_now()
    v.wait_idle()
    expected = _knee_rmse_by_hand(session)
    r = v.result
    assert r is not None and r.alignment_used.startswith("mounting offset")
    assert len(r.t_s) == open_session(session).n_samples
    for name, rmse in expected.items():
        assert r.rmse_deg[name] == pytest.approx(rmse, abs=2e-3), name
    shown = v.table_values()
    assert set(shown) == {"accelerometer", "gyro"}
    for name, rmse in expected.items():
        assert abs(float(shown[name]) - rmse) <= 0.0051  # two decimals on screen
    # the paper's finding holds on this walk: the accelerometer alone is far off
    assert expected["accelerometer"] > 10


def test_filters_view_parameters_change_the_result(qtbot, session) -> None:
    from gaitmon.review.filters import build_filter

    rng = np.random.default_rng(0)
    z = np.cumsum(rng.normal(0, 0.01, (300, 4)), axis=0)
    w = rng.normal(0, 0.5, (300, 4))
    for name in TILT_FILTERS:  # the view's defaults are the registry's own filters
        np.testing.assert_array_equal(
            build_filter(name, 0.01, {}).process(z, w), make_tilt_filter(name, 0.01).process(z, w)
        )
    v = _view(qtbot)
    v.load_session(session)
    v.set_checked(["kalman (paper 000)"])
    v.set_range(5.0, 25.0)
    with qtbot.waitSignal(v.computed, timeout=30_000):
        v.compute_now()
    default = v.result.rmse_deg["kalman (paper 000)"]
    v.filter_list.setCurrentRow(list(TILT_FILTERS).index("kalman (paper 000)"))
    assert "kalman (paper 000)" in v.params_box.title()
    v.set_param("kalman (paper 000)", "r", 30.0)  # trust the accelerometer much less
    with qtbot.waitSignal(v.computed, timeout=30_000):
        v.compute_now()
    v.wait_idle()
    changed = v.result.rmse_deg["kalman (paper 000)"]
    assert np.isfinite(default) and np.isfinite(changed) and changed != pytest.approx(default)
    assert v.result.t_s[0] >= 5.0 - 0.011 and v.result.t_s[-1] <= 25.0 + 0.011


def test_filters_view_reports_a_bad_file_in_one_line(qtbot, tmp_path: Path) -> None:
    v = _view(qtbot)
    with qtbot.waitSignal(v.failed, timeout=5_000) as sig:
        v.load_session(tmp_path / "none.h5")
    assert "does not exist" in sig.args[0] and "\n" not in sig.args[0]
    assert not v.update_button.isEnabled()
