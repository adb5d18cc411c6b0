"""Writing a painted A4 page set: the PDF, a page as an image, the image as a PNG.

Shared by the clinical report and the session comparison: each supplies a ``paint(painter,
device, new_page)`` function (``new_page`` is None when painting one image); these write the
files atomically (a temporary file renamed at the end) and turn a failure into ``OSError``.
"""

from __future__ import annotations

import html
import os
import re
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QByteArray, QMarginsF, QSizeF
from PySide6.QtGui import (
    QColor,
    QImage,
    QImageWriter,
    QPageLayout,
    QPageSize,
    QPaintDevice,
    QPainter,
    QPdfWriter,
)

from gaitmon.ui.report_pdf.page import PAGE_H_MM, PAGE_W_MM, ensure_gui_app

Paint = Callable[[QPainter, QPaintDevice, Callable[[], object] | None], object]


def tmp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _writable_tmp(path: Path) -> Path:
    """Create the temporary file beside ``path`` ourselves, before Qt opens it: a read-only
    drive, a full disk or a missing permission is then an ``OSError`` with its errno, naming
    ``path`` (the file asked for, not the temporary one), and Qt prints no warning of its own
    ("QPainter::begin(): Returned false")."""
    tmp = tmp_path(path)
    try:
        with open(tmp, "wb"):
            pass
    except OSError as e:
        raise OSError(e.errno, e.strerror, str(path)) from None
    return tmp


def _failed(path: Path, tmp: Path) -> OSError:
    tmp.unlink(missing_ok=True)
    return OSError(f"cannot write {path} (the drive may be full or was removed)")


# Qt (6.11) has no setter for the document information's dates and stamps them with the
# current time; its XMP packet can be replaced (setDocumentXmpMetadata). Undated: our packet,
# without dates, and the two dates of the information dictionary overwritten by spaces of the
# same length (so every offset in the cross-reference table stays right; a dictionary may hold
# any whitespace between its entries). If Qt ever writes them otherwise, the PDF is refused.
_PDF_DATE = re.compile(rb"/(?:CreationDate|ModDate)\s*\(D:\d{4,14}[^()]{0,12}\)")
_XMP = """<?xpacket begin="\ufeff" id="W5M0MpCehiHzreSzNTczkc9d"?>
<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">
<rdf:Description rdf:about="" xmlns:dc="http://purl.org/dc/elements/1.1/"
 xmlns:xmp="http://ns.adobe.com/xap/1.0/" xmp:CreatorTool="{creator}">
<dc:title><rdf:Alt><rdf:li xml:lang="x-default">{title}</rdf:li></rdf:Alt></dc:title>
</rdf:Description></rdf:RDF></x:xmpmeta>
<?xpacket end="w"?>"""


def _undate_pdf(tmp: Path, path: Path) -> None:
    """Blank the information dictionary's CreationDate and ModDate in place (same length)."""
    data = tmp.read_bytes()
    undated, n = _PDF_DATE.subn(lambda m: b" " * len(m.group(0)), data)
    if n != 2 or re.search(rb"D:\d{8}", undated) or b"CreateDate" in undated:
        tmp.unlink(missing_ok=True)
        raise OSError(f"cannot write {path} without its date with this Qt (its PDF writer "
                      "changed); the report was not written")
    with open(tmp, "r+b") as f:
        f.write(undated)


def write_a4_pdf(path: str | os.PathLike[str], paint: Paint, *, creator: str, title: str,
                 dpi: int = 600, dated: bool = True) -> Path:  # fmt: skip
    """Paint A4 pages into the PDF ``path``. ``dated=False`` (a de-identified report): the
    PDF does not say when it was made (no CreationDate, ModDate or XMP dates)."""
    ensure_gui_app()
    path = Path(path)
    tmp = _writable_tmp(path)
    writer = QPdfWriter(str(tmp))
    writer.setResolution(dpi)
    writer.setPageLayout(QPageLayout(QPageSize(QPageSize.PageSizeId.A4),
                                     QPageLayout.Orientation.Portrait, QMarginsF(0, 0, 0, 0),
                                     QPageLayout.Unit.Millimeter))  # fmt: skip
    writer.setCreator(creator)
    writer.setTitle(title)
    if not dated:
        writer.setDocumentXmpMetadata(QByteArray(_XMP.format(
            creator=html.escape(creator), title=html.escape(title)).encode("utf-8")))
    painter = QPainter()
    if not painter.begin(writer):
        raise _failed(path, tmp)
    try:
        paint(painter, writer, writer.newPage)
    finally:
        painter.end()
    del writer
    if not tmp.exists() or tmp.stat().st_size == 0:
        raise _failed(path, tmp)
    if not dated:
        _undate_pdf(tmp, path)
    os.replace(tmp, path)
    return path


def pdf_title(what: str, patient_id: str, deidentified: bool) -> str:
    """The PDF's title: ``what`` and the patient identifier, unless withheld."""
    return what + (f" {patient_id}" if patient_id and not deidentified else "")


def render_a4_image(paint: Paint, dpi: float = 150.0) -> QImage:
    """The first page as an image, antialiased, on white."""
    ensure_gui_app()
    size = QSizeF(PAGE_W_MM / 25.4 * dpi, PAGE_H_MM / 25.4 * dpi)
    img = QImage(round(size.width()), round(size.height()), QImage.Format.Format_RGB32)
    dpm = round(dpi / 0.0254)
    img.setDotsPerMeterX(dpm)
    img.setDotsPerMeterY(dpm)
    img.fill(QColor("#ffffff"))
    painter = QPainter(img)
    try:
        painter.setRenderHint(QPainter.RenderHint.Antialiasing, True)
        paint(painter, img, None)
    finally:
        painter.end()
    return img


def write_png(path: str | os.PathLike[str], image: QImage) -> Path:
    """Write ``image`` as a PNG (atomically, like the PDF)."""
    path = Path(path)
    tmp = _writable_tmp(path)
    # QImageWriter: QImage.save's format argument is typed as bytes but only takes a str
    if not QImageWriter(str(tmp), b"PNG").write(image):
        raise _failed(path, tmp)
    os.replace(tmp, path)
    return path
