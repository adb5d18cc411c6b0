"""The report's flowing part: text broken into lines, rows and headings as blocks of known
height, and the pagination that places them on as many A4 pages as they need.

The head of page 1 (title, header grid, cycle plots, summary) has a fixed size; everything
after it (session notes, data quality with every gap and excluded range, markers, settings)
is a list of :class:`Block` s. A block is never split, and a wrapped paragraph is one block per
line, so long text continues on the next page instead of being cut. A heading keeps with the
block after it. Lines are broken by Qt's text layout at word boundaries, or anywhere inside a
word longer than the column (a pasted path or URL), so no text is ever drawn outside its
column.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor, QFontMetricsF, QTextLayout, QTextOption

from gaitmon.ui.report_pdf.page import INK, MUTED, PAGE_H_MM, PAGE_W_MM, RULE, SHADE, Page

Draw = Callable[[Page, float], None]  # draws the block with its top at y (mm)


@dataclass
class Block:
    height_mm: float
    draw: Draw
    keep_with_next: bool = False


def split_lines(
    p: Page, text: str, w_mm: float, size_pt: float, *, bold: bool = False
) -> list[str]:
    """``text`` broken into lines that fit ``w_mm`` (explicit newlines kept)."""
    font = p.font(size_pt, bold)
    out: list[str] = []
    opt = QTextOption()
    opt.setWrapMode(QTextOption.WrapMode.WrapAtWordBoundaryOrAnywhere)
    for para in text.split("\n") or [""]:
        if not para.strip():
            out.append("")
            continue
        layout = QTextLayout(para, font, p.dev)
        layout.setTextOption(opt)
        layout.beginLayout()
        while True:
            line = layout.createLine()
            if not line.isValid():
                break
            line.setLineWidth(p.mm(w_mm - 0.3))  # a hair of slack for rounding
            out.append(para[line.textStart() : line.textStart() + line.textLength()].rstrip())
        layout.endLayout()
    return out


def line_height_mm(p: Page, size_pt: float) -> float:
    return QFontMetricsF(p.font(size_pt), p.dev).lineSpacing() / p.k + 0.15


def _line(x: float, w: float, h: float, text: str, size_pt: float, colour: QColor,
          bold: bool = False) -> Draw:  # fmt: skip
    def draw(p: Page, y: float) -> None:
        p.text(x, y, w, h, text, size_pt, colour=colour, bold=bold, elide=False)

    return draw


def paragraph(p: Page, x: float, w: float, text: str, size_pt: float = 7.5, *,
              colour: QColor = INK, after_mm: float = 0.0) -> list[Block]:  # fmt: skip
    """A wrapped paragraph: one block per line."""
    h = line_height_mm(p, size_pt)
    lines = split_lines(p, text, w, size_pt)
    blocks = [Block(h, _line(x, w, h, ln, size_pt, colour)) for ln in lines]
    if blocks and after_mm:
        blocks[-1].height_mm += after_mm
    return blocks


def heading(p: Page, x: float, w: float, title: str) -> Block:
    """A section heading with a rule under it; kept with what follows."""

    def draw(p: Page, y: float) -> None:
        p.section(x, y, w, title)

    return Block(6.6, draw, keep_with_next=True)


def subheading(x: float, w: float, title: str) -> Block:
    def draw(p: Page, y: float) -> None:
        p.text(x + 1.2, y + 0.6, w - 2.4, 4.2, title, 7.5, bold=True, colour=INK, elide=False)

    return Block(4.8, draw, keep_with_next=True)


def kv_row(p: Page, x: float, w: float, label: str, value: str, *, label_w: float = 29.0,
           shaded: bool = False, size_pt: float = 7.5) -> list[Block]:  # fmt: skip
    """A label and its wrapped value; one block per line of the value (the label on the first)."""
    h = line_height_mm(p, size_pt)
    pad = 0.35
    lines = split_lines(p, value, w - label_w - 2.4, size_pt) or [""]
    blocks = []
    for k, ln in enumerate(lines):
        first, last = k == 0, k == len(lines) - 1
        bh = h + (pad if first else 0.0) + (pad if last else 0.0)
        top = pad if first else 0.0

        def draw(p: Page, y: float, ln: str = ln, first: bool = first, bh: float = bh,
                 top: float = top) -> None:  # fmt: skip
            if shaded:
                p.fill(x, y, w, bh, SHADE)
            if first:
                p.text(x + 1.2, y + top, label_w, h, label, size_pt - 0.3, colour=MUTED,
                       elide=False)  # fmt: skip
            p.text(x + 1.2 + label_w, y + top, w - label_w - 2.4, h, ln, size_pt, elide=False)

        blocks.append(Block(bh, draw))
    return blocks


@dataclass(frozen=True)
class TableColumn:
    title: str
    width_mm: float
    right: bool = False  # numbers are right-aligned


def table(p: Page, x: float, columns: Sequence[TableColumn], rows: Sequence[Sequence[str]],
          size_pt: float = 7.5) -> list[Block]:  # fmt: skip
    """A header row (repeated nowhere: kept with the first row) and one block per row; cells
    wrap inside their column and the row is as tall as its tallest cell."""
    h = line_height_mm(p, size_pt)
    total = float(sum(c.width_mm for c in columns))
    left = Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter
    right = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter

    def header(p: Page, y: float) -> None:
        cx = x
        for c in columns:
            p.text(cx + 1.2, y, c.width_mm - 2.4, h, c.title, size_pt - 0.5, bold=True,
                   colour=MUTED, align=right if c.right else left, elide=False)  # fmt: skip
            cx += c.width_mm
        p.hline(x, x + total, y + h + 0.1, RULE, 0.25)

    blocks = [Block(h + 0.5, header, keep_with_next=True)]
    for r, row in enumerate(rows):
        cells = [split_lines(p, text, c.width_mm - 2.4, size_pt) or [""]
                 for c, text in zip(columns, row, strict=True)]  # fmt: skip
        n_lines = max(len(c) for c in cells)
        bh = n_lines * h + 0.4

        def draw(p: Page, y: float, cells: list[list[str]] = cells, r: int = r,
                 bh: float = bh) -> None:  # fmt: skip
            if r % 2 == 1:
                p.fill(x, y, total, bh, SHADE)
            cx = x
            for c, lines in zip(columns, cells, strict=True):
                for k, ln in enumerate(lines):
                    p.text(cx + 1.2, y + 0.2 + k * h, c.width_mm - 2.4, h, ln, size_pt,
                           align=right if c.right else left, elide=False)  # fmt: skip
                cx += c.width_mm

        blocks.append(Block(bh, draw))
    return blocks


def gap(height_mm: float) -> Block:
    return Block(height_mm, lambda _p, _y: None)


# --------------------------------------------------------------------------------------------
# pagination


def paginate(blocks: Sequence[Block], first_top: float, next_top: float,
             bottom: float) -> list[list[tuple[float, Block]]]:  # fmt: skip
    """Place the blocks: page 0 from ``first_top``, further pages from ``next_top``, never
    below ``bottom`` (a block taller than a page is placed alone at the top of one)."""
    pages: list[list[tuple[float, Block]]] = [[]]
    y = first_top
    # where a page's flow starts: only there does a block too tall for the rest of a page stay
    # (on page 0 the flow starts below the fixed head, so a block that does not fit below it
    # moves on to page 1 like anywhere else)
    top = min(first_top, next_top)
    k = 0
    while k < len(blocks):
        b = blocks[k]
        need = b.height_mm
        j = k
        while blocks[j].keep_with_next and j + 1 < len(blocks):  # heading + what follows
            j += 1
            need += blocks[j].height_mm
        if y + need > bottom and y > top:
            pages.append([])
            y = top = next_top
        pages[-1].append((y, b))
        y += b.height_mm
        k += 1
    return pages


__all__ = [
    "Block",
    "TableColumn",
    "gap",
    "heading",
    "kv_row",
    "line_height_mm",
    "paginate",
    "paragraph",
    "split_lines",
    "subheading",
    "table",
]


def paint_pages(
    p: Page, pages: list[list[tuple[float, Block]]], new_page: Callable[[], object] | None,
    continued: Callable[[], object], footer: Callable[[int, int], object],
    last: Callable[[], object] | None = None,
) -> None:  # fmt: skip
    """Draw paginated blocks: a new white page with its ``continued`` header from the second
    on (only the first when ``new_page`` is None, i.e. one image), ``last`` on the last page,
    and every page's ``footer(page, n_pages)``."""
    p.n_pages = len(pages)
    for k, placed in enumerate(pages):
        if k:
            if new_page is None:
                break
            new_page()
            p.page = k
            p.p.fillRect(p.rect(0, 0, PAGE_W_MM, PAGE_H_MM), QColor("#ffffff"))
            continued()
        for by, block in placed:
            block.draw(p, by)
        if last is not None and k == len(pages) - 1:
            last()
        footer(k, len(pages))
