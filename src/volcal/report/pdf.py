"""Render a :class:`~volcal.report.document.Report` as a PDF file with matplotlib.

Why matplotlib's ``PdfPages``: it is already a dependency, pure Python, and needs no
system library (WeasyPrint needs Pango and cairo, wkhtmltopdf and headless browsers are
system binaries); a calibration report must be writable on a locked-down shop-floor PC.
Text and tables are laid out on A4 portrait pages with a simple flow layout; each figure
gets an A4 landscape page with its caption. The content is the same document as the HTML
report.
"""

from __future__ import annotations

import io
import re
import textwrap
from pathlib import Path

import matplotlib.image as mpimg
from matplotlib.backends.backend_pdf import PdfPages

from volcal.plot._figure import new_figure
from volcal.report.document import Report, Table
from volcal.report.figures import png_bytes

__all__ = ["write_pdf"]

A4_PORTRAIT = (8.27, 11.69)
A4_LANDSCAPE = (11.69, 8.27)
_TOP, _BOTTOM, _LEFT = 0.95, 0.06, 0.07
_LINE = 0.0165  # height of a 10 pt text line, fraction of an A4 portrait page
_ROW = 0.0175  # height of a table row
_WRAP = 100  # characters per text line


_NUMBER = re.compile(r"^[-+−]?(\d[\d.,]*|∞|-)$|^\(.*\)$")
_MAX_CELL = 48  # characters of a table cell on paper; longer text is shortened


def _clip(text: str) -> str:
    return text if len(text) <= _MAX_CELL else text[:_MAX_CELL - 1] + "…"


class _Flow:
    """Text pages filled from the top; a new page when the current one is full."""

    def __init__(self, pdf: PdfPages, report: Report) -> None:
        self.pdf = pdf
        self.report = report
        self.page = 0
        self.fig = None
        self.y = _TOP

    def new_page(self) -> None:
        self.flush()
        self.fig = new_figure(*A4_PORTRAIT)
        self.fig.set_layout_engine(None)
        self.y = _TOP

    def flush(self) -> None:
        if self.fig is not None:
            self.page += 1
            self.fig.text(0.5, 0.025, f"{self.report.title}  ·  page {self.page}", ha="center",
                          fontsize=7, color="0.4")
            self.pdf.savefig(self.fig)
            self.fig = None

    def need(self, height: float) -> None:
        if self.fig is None or self.y - height < _BOTTOM:
            self.new_page()

    def text(self, s: str, size: float = 9.5, weight: str = "normal", color: str = "black",
             indent: float = 0.0, wrap: int = _WRAP) -> None:
        for line in textwrap.wrap(s, wrap) or [""]:
            self.need(_LINE * size / 9.5)
            assert self.fig is not None
            self.fig.text(_LEFT + indent, self.y, line, fontsize=size, weight=weight,
                          color=color, va="top")
            self.y -= _LINE * size / 9.5

    def gap(self, lines: float = 0.6) -> None:
        self.y -= _LINE * lines

    def table(self, t: Table) -> None:
        per_page = int((_TOP - _BOTTOM) / _ROW) - 3
        chunks = [t.rows[i:i + per_page] for i in range(0, len(t.rows), per_page)] or [[]]
        for i, rows in enumerate(chunks):
            h = _ROW * (len(rows) + 1)
            self.need(h + 2 * _LINE)
            if t.title:
                self.text(t.title + (" (continued)" if i else ""), weight="bold", size=9)
            assert self.fig is not None
            ax = self.fig.add_axes((_LEFT, self.y - h, 1 - 2 * _LEFT, h))
            ax.axis("off")
            cells = [[_clip(c) for c in r] for r in rows] or [[""] * len(t.columns)]
            chars = [max([len(t.columns[j]) * 0.8] + [len(r[j]) for r in cells]) + 2
                     for j in range(len(t.columns))]
            tab = ax.table(cellText=cells, colLabels=t.columns, bbox=(0, 0, 1, 1),
                           colLoc="center", colWidths=[c / sum(chars) for c in chars])
            tab.auto_set_font_size(False)
            tab.set_fontsize(6.5 if sum(chars) > 110 else 8)
            for (r, c), cell in tab.get_celld().items():
                cell.set_linewidth(0.3)
                if r == 0:
                    cell.set_facecolor("#eef3f8")
                else:
                    cell.set_text_props(ha="right" if _NUMBER.match(cells[r - 1][c])
                                        else "left")
            self.y -= h + 0.5 * _LINE
        if t.note:
            self.text(t.note, size=8, color="0.3")
        self.gap()


    def figure_page(self, png: bytes, caption: str, number: int) -> None:
        self.flush()
        self.page += 1
        _figure_page(self.pdf, png, caption, number,
                     f"{self.report.title}  ·  page {self.page}")


def _figure_page(pdf: PdfPages, png: bytes, caption: str, number: int, footer: str) -> None:
    fig = new_figure(*A4_LANDSCAPE)
    fig.set_layout_engine(None)
    ax = fig.add_axes((0.03, 0.1, 0.94, 0.86))
    ax.imshow(mpimg.imread(io.BytesIO(png), format="png"), interpolation="antialiased")
    ax.axis("off")
    fig.text(0.05, 0.06, "\n".join(textwrap.wrap(f"Figure {number}: {caption}", 150)),
             fontsize=9, va="top")
    fig.text(0.5, 0.02, footer, ha="center", fontsize=7, color="0.4")
    pdf.savefig(fig)


def write_pdf(report: Report, path: str | Path) -> int:
    """Write the report as PDF (the caller makes the write atomic).

    Parameters
    ----------
    report : Report
        The document.
    path : str or Path
        Output file.

    Returns
    -------
    int
        Number of pages written.
    """
    number = 0
    with PdfPages(path, metadata={"Title": report.title, "Creator": report.generator}) as pdf:
        flow = _Flow(pdf, report)
        flow.new_page()
        flow.text(report.title, size=18, weight="bold", wrap=60)
        flow.text(f"Created {report.created} by {report.generator}", size=8.5, color="0.35")
        flow.gap(1.0)
        for k, s in enumerate(report.sections, start=1):
            flow.text(f"{k}. {s.title}", size=10, indent=0.02)
        for k, s in enumerate(report.sections, start=1):
            flow.gap(1.2)
            flow.need(4 * _LINE)
            flow.text(f"{k}. {s.title}", size=13, weight="bold")
            flow.gap(0.3)
            for p in s.paragraphs:
                flow.text(p)
                flow.gap(0.4)
            for w in s.warnings:
                flow.text("(!) " + w, color="#8a5a00")
                flow.gap(0.3)
            for t in s.tables:
                flow.table(t)
            if s.figures:
                flow.flush()
                for f in s.figures:
                    number += 1
                    flow.figure_page(png_bytes(f.figure), f.caption, number)
        flow.flush()
        pages = flow.page
    return pages
