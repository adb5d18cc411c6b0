"""The review window's ways out of the window: File ▸ Export…, Report (PDF)…, Save reprocessed
as…, Analysis ▸ Reprocess with settings…, View ▸ Filters… and every plot's right-click Save plot
as. Each dialog is opened for the document shown (the leg shown, the angles shown) and hands
the work to :class:`~gaitmon.ui.review.jobs.ReviewJobs` (report, reprocess, save) or does it
itself (export, the Filters window)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from PySide6.QtWidgets import QFileDialog, QWidget

from gaitmon.dsp.channel_table import JOINTS
from gaitmon.ui.actions import guarded
from gaitmon.ui.review.actions import available
from gaitmon.ui.review.cycles import ReviewCyclePlots
from gaitmon.ui.review.jobs import ReviewJobs
from gaitmon.ui.review.legs import NOT_SAVED
from gaitmon.ui.review.part import Host, Part
from gaitmon.ui.review.timeline import Timeline
from gaitmon.ui.theme import Colours

if TYPE_CHECKING:
    from gaitmon.ui.review.export_dialog import ExportDialog
    from gaitmon.ui.review.filters_view import FiltersView
    from gaitmon.ui.review.reprocess_dialog import ReprocessDialog

FILE_FILTER = "gaitmon sessions (*.h5 *.hdf5);;All files (*)"


class Outputs(Part):
    """The dialogs of the document shown (see the module docstring); ``window`` is their
    parent."""

    def __init__(self, host: Host, window: QWidget, jobs: ReviewJobs, timeline: Timeline,
                 colours: Colours) -> None:  # fmt: skip
        super().__init__(host, window)
        self.window, self.jobs, self.timeline, self.colours = window, jobs, timeline, colours
        self.filters_window: FiltersView | None = None
        self.export: ExportDialog | None = None
        self.settings_dialog: ReprocessDialog | None = None

    def attach_plot_export(self, cycles: ReviewCyclePlots) -> None:
        """Right-click any plot ▸ Save plot as PNG / SVG (the plot as shown)."""
        if not available("gaitmon.ui.review.plot_export"):
            return
        from gaitmon.ui.review.plot_export import attach_export_action

        tl, w = self.timeline, self.window
        attach_export_action(tl.overview, w, "overview.png")
        for key, lane in tl.lanes.items():
            attach_export_action(lane.plot, w, f"{key}.png")
        for plot, key in zip(cycles.plots, JOINTS, strict=True):
            attach_export_action(plot, w, f"cycle_{key}.png")

    @guarded
    def reprocess_dialog(self) -> None:
        doc = self.doc
        if doc is None:
            return
        from gaitmon.ui.review.reprocess_dialog import ReprocessDialog, review_notes

        note, angles_note = review_notes(doc.angle_source == "smoothed", doc.bilateral)
        dlg = ReprocessDialog(self.window, doc.current.config, note=note, angles_note=angles_note)
        dlg.accepted.connect(lambda: self._reprocess_accepted(dlg))
        dlg.open()
        self.settings_dialog = dlg

    def _reprocess_accepted(self, dlg: ReprocessDialog) -> None:
        if dlg.config is not None:
            self.jobs.start_reprocess(dlg.config)

    @guarded
    def save_reprocessed_dialog(self) -> None:
        doc = self.doc
        if doc is None or doc.reprocessed is None:
            return
        if doc.bilateral:
            self.status.message(NOT_SAVED, 10_000)
            return
        suggestion = doc.path.with_name(doc.path.stem + "_reprocessed.h5")
        path, _ = QFileDialog.getSaveFileName(
            self.window, "Save reprocessed session as", str(suggestion), FILE_FILTER
        )
        if path:
            self.jobs.save_reprocessed(path)

    @guarded
    def export_dialog(self) -> None:
        doc = self.doc
        if doc is None:
            return
        from gaitmon.ui.review.export_dialog import ExportDialog

        # the angles shown are the ones exported (and named in the export's metadata)
        dlg = ExportDialog(doc.path, self.window, angles=doc.angle_source,
                           angle_method=doc.angle_method_of(doc.angle_source),
                           side=doc.side or None)  # fmt: skip
        # the status line repeats the dialog's own summary ("Exported N samples to 8 files in
        # DIR"), not the tuple of paths
        dlg.export_finished.connect(
            lambda _r: self.status.message(dlg.status_label.text(), 10_000)
        )
        dlg.open()
        self.export = dlg

    @guarded
    def report_dialog(self) -> None:
        doc = self.doc
        if doc is None:
            return
        # the report is of the leg shown: both.h5 -> both_L.pdf, as export names its files
        stem = f"{doc.path.stem}_{doc.side}" if doc.bilateral else doc.path.stem
        suggestion = doc.path.with_name(stem + ".pdf")
        path, _ = QFileDialog.getSaveFileName(
            self.window, "Save the report as", str(suggestion), "PDF (*.pdf)"
        )
        if path:
            self.jobs.write_report(path)

    @guarded
    def show_filters(self) -> None:
        doc = self.doc
        if doc is None:
            return
        from gaitmon.ui.review.filters_view import filters_window

        if self.filters_window is None:
            self.filters_window = filters_window(
                self.colours, lambda m: self.status.message(f"Filters: {m}", 10_000))
        fw = self.filters_window
        if fw.source != (doc.path, doc.side or None):  # the leg shown, of a bilateral file
            fw.load_session(doc.path, side=doc.side or None)
        fw.set_range(*self.timeline.view_range())
        fw.show()
        fw.raise_()

    def shutdown(self) -> None:
        if self.filters_window is not None:
            self.filters_window.close()
