"""Render a :class:`~volcal.report.document.Report` as a PDF file with matplotlib.

Why matplotlib's ``PdfPages``: it is already a dependency, pure Python, and needs no
system library (WeasyPrint needs Pango and cairo, wkhtmltopdf and headless browsers are
system binaries); a calibration report must be writable on a locked-down shop-floor PC.
Text and tables are laid out on A4 portrait pages with a simple flow layout and written
straight to the PDF by matplotlib's PDF renderer (no figure or text artists per page: each
line is placed in points, :class:`_Flow`); each figure gets an A4 landscape page with its
caption. The content is the same document as the HTML report.

What the customer reads is never cut: paragraphs and table cells are wrapped at word
boundaries, measured with the font that draws them (a word wider than its column is broken
between characters), and a table row grows to hold its longest cell. Figures are drawn as
vector graphics at the size they are printed (the figure is laid out again on the page,
its fonts kept at their point sizes, so a label set in 6.5 pt prints at 6.5 pt), laid out
and drawn in one pass; the parts matplotlib rasterizes (colour bars) and the heavy artists
(more than :data:`RASTER_POINTS` points) are embedded at :data:`RASTER_DPI`.

Each figure is drawn once: its page is a PDF of one page (:class:`FigurePage`), drawn in a
worker process where a core is spare while this one lays out and prints the text pages,
and put into the report's PDF at its place; the figure's area of that page rasterized is
the figure's PNG for the HTML report and the figures folder (:mod:`volcal.report.raster`).
"""

from __future__ import annotations

import io
import multiprocessing
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.backends.backend_pdf import FigureCanvasPdf, PdfPages, RendererPdf
from matplotlib.collections import Collection
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties, findfont, get_font
from matplotlib.image import AxesImage
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.lines import Line2D
from matplotlib.path import Path as MplPath
from matplotlib.transforms import Affine2D

from volcal.report.document import FigureItem, Report, Table
from volcal.report.drawcache import cached_drawing, text_metrics
from volcal.report.figures import PNG_COMPRESSION, PNG_DPI, draw_all, draw_workers, kept_layout
from volcal.report.raster import insert_pages, page_png
from volcal.report.wording import customer_report

__all__ = ["RASTER_DPI", "RASTER_POINTS", "FigurePage", "write_pdf"]

A4_PORTRAIT = (8.27, 11.69)
A4_LANDSCAPE = (11.69, 8.27)
RASTER_DPI = 300
"""Resolution of the rasterized parts of the figures (colour bars, heavy artists) [dots per
inch]."""
RASTER_POINTS = 2000
"""Artists drawing more points than this (the readings of a dense scatter, the vertices of
a long line, the cells of an error-map image) are rasterized in the PDF at
:data:`RASTER_DPI`, inside otherwise vector figures: their labels, ticks and axes stay
text and vectors."""

_PT = 72.0  # points per inch
_TOP, _BOTTOM, _LEFT = 0.95, 0.06, 0.07
_LINE = 0.0165  # height of a 10 pt text line, fraction of an A4 portrait page
_TEXT_WIDTH_PT = (1 - 2 * _LEFT) * A4_PORTRAIT[0] * _PT  # width of the text column [pt]
_TABLE_SIZES = (8.0, 7.0, 6.5)  # font sizes tried for a table until its words fit [pt]
_PAD_X, _PAD_Y = 3.0, 2.0  # cell padding [pt]
_LINESPACING = 1.2  # matplotlib's default, in units of the font's line height
_FIG_MARGIN = 0.45  # margin of a figure page [inch]
_FIG_PAD = 6.0  # white around a figure's area in its PNG [pt]

_NUMBER = re.compile(r"^[-+−]?(\d[\d.,]*|∞|-)$|^\(.*\)$")


class _Measure:
    """Width of a text line in the font that draws it [pt], as the PDF page measures it.

    The widths are those of matplotlib's PDF renderer (the one that prints the text, so
    a line measured to fit its column prints as wide as measured), shared with the page
    that draws the line (:func:`volcal.report.drawcache.text_metrics`: within
    :func:`write_pdf` a line is measured once).
    """

    def __init__(self) -> None:
        h, w = A4_PORTRAIT[1] * _PT, A4_PORTRAIT[0] * _PT
        self._renderer = RendererPdf(None, _PT, h, w)  # measures only: draws nothing
        self._props: dict[tuple[float, str], FontProperties] = {}
        self._cache: dict[tuple[str, float, str], float] = {}
        self._heights: dict[tuple[float, str], tuple[float, float]] = {}

    def prop(self, size: float, weight: str = "normal") -> FontProperties:
        """The font of a text of this size [pt] and weight (one object per font)."""
        return self._props.setdefault((size, weight), FontProperties(size=size, weight=weight))

    def width(self, text: str, size: float, weight: str = "normal") -> float:
        key = (text, size, weight)
        if key not in self._cache:
            w, _, _ = text_metrics(self._renderer, text, self.prop(size, weight))
            self._cache[key] = w + 0.5  # half a point of slack for rounding
        return self._cache[key]

    def metrics(self, text: str, prop: FontProperties) -> tuple[float, float, float]:
        """Width, height and descent of one line of text [pt], as it prints."""
        return text_metrics(self._renderer, text, prop)

    def ascent_descent(self, prop: FontProperties) -> tuple[float, float]:
        """The font's ascent and descent [pt].

        Its ``OS/2`` typographic metrics, else ``hhea``'s: what matplotlib spaces the lines
        of a text by.
        """
        key = (prop.get_size_in_points(), str(prop.get_weight()))
        if key not in self._heights:
            font = get_font(findfont(prop))
            head = font.get_sfnt_table("head")
            os2, hhea = font.get_sfnt_table("OS/2"), font.get_sfnt_table("hhea")
            if head is not None and (os2 is not None or hhea is not None):
                scale = prop.get_size_in_points() / head["unitsPerEm"]
                a, d = ((os2["sTypoAscender"], -os2["sTypoDescender"]) if os2 is not None
                        else (hhea["ascent"], -hhea["descent"]) if hhea is not None
                        else (0, 0))
                self._heights[key] = (a * scale, d * scale)
            else:  # no table: the ink of "lp"
                _, h, dd = self.metrics("lp", prop)
                self._heights[key] = (h - dd, dd)
        return self._heights[key]

    def line_metrics(self, size: float) -> tuple[float, float]:
        """Pitch of the lines of a table cell and height of one line [pt].

        Each line ``h - d`` times the line spacing plus the descent ``d`` below the
        previous one, ``h`` the height of ``'lp'`` (matplotlib's rule before 3.11; the
        text pages draw their cells' lines with it, :meth:`_Flow._row`, and the figure
        pages' caption band is measured with it).
        """
        _, h, d = text_metrics(self._renderer, "lp", self.prop(size, "normal"))
        return _LINESPACING * (h - d) + d, h

    def wrap(self, text: str, width: float, size: float, weight: str = "normal") -> list[str]:
        """Break ``text`` into lines no wider than ``width`` [pt], at spaces where possible.

        Every character of ``text`` other than the spaces at the breaks is kept: a word
        wider than the line is broken between characters, never shortened.

        The lines are those of the greedy rule (each word on the line if the line with it
        still fits, else on the next), found with few measurements of whole lines: the
        width of a line grows with every word appended to it (its glyphs keep their
        places, the ink only reaches further right), so the words that fit after a line
        are found from an estimate (the widths of the characters) and two exact measurements
        (:meth:`_fit`), instead of measuring the line again after every word.
        """
        lines: list[str] = []
        for para in text.split("\n"):
            words = para.split()
            line = ""
            j = 0
            while j < len(words):
                m = self._fit(line, words, j, width, size, weight)
                if m:
                    line = " ".join(([line] if line else []) + words[j:j + m])
                    j += m
                    if j == len(words):
                        break
                word = words[j]  # does not fit after the line: a new line
                j += 1
                if line:
                    lines.append(line)
                while self.width(word, size, weight) > width and len(word) > 1:
                    k = self._prefix(word, width, size, weight)
                    lines.append(word[:k])
                    word = word[k:]
                line = word
            lines.append(line)
        return lines or [""]

    def _fit(self, line: str, words: list[str], j: int, width: float, size: float,
             weight: str) -> int:
        """How many of ``words[j:]`` fit after ``line``, one space apart, in ``width`` [pt]."""
        head = [line] if line else []

        def fits(m: int) -> bool:
            return self.width(" ".join(head + words[j:j + m]), size, weight) <= width

        n = len(words) - j
        space = 0.32 * size  # DejaVu Sans's space, 0.318 em [pt]
        est = (self.width(line, size, weight) + space) if line else 0.0
        m = 0
        while m < n:
            est += self._estimate(words[j + m], size, weight) + (space if m else 0.0)
            if est > width:
                break
            m += 1
        if m and not fits(m):
            while m and not fits(m):
                m -= 1
        else:
            while m < n and fits(m + 1):
                m += 1
        return m

    def _estimate(self, word: str, size: float, weight: str) -> float:
        """Width of a word from the widths of its characters [pt] (no kerning): a guess."""
        return sum(self.width(c, size, weight) - 0.5 for c in word)

    def _prefix(self, word: str, width: float, size: float, weight: str) -> int:
        """Length of the longest head of ``word`` that fits ``width`` [pt] (at least 1)."""
        lo, hi = 1, len(word) - 1  # the head of length lo is kept even if it is too wide
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self.width(word[:mid], size, weight) <= width:
                lo = mid
            else:
                hi = mid - 1
        return lo


def _weight(i: int) -> str:
    """Font weight of row ``i`` of a table's cells (row 0 is the header)."""
    return "bold" if i == 0 else "normal"


def _unbreakable(m: _Measure, text: str, size: float, weight: str) -> float:
    """Width of the widest piece of a cell that must stay on one line [pt].

    A number or a vector of numbers counts whole, any other text by its longest word.
    """
    if _NUMBER.match(text):
        return m.width(text, size, weight)
    return max([m.width(w, size, weight) for w in text.split()] or [0.0])


def _column_widths(m: _Measure, cells: list[list[str]], size: float, total: float,
                   force: bool = False) -> list[float] | None:
    """Column widths [pt] filling ``total``, each at least as wide as its longest word.

    When the longest words of the columns do not fit side by side at this size: None, or
    with ``force`` the narrow columns keep their words whole and the columns with the
    widest words share the rest in proportion to their text (their words are then broken
    between characters).
    """
    ncol = len(cells[0])
    natural = [max(m.width(r[j], size, _weight(i)) for i, r in enumerate(cells)) + 2 * _PAD_X
               for j in range(ncol)]
    word = [max(_unbreakable(m, r[j], size, _weight(i)) for i, r in enumerate(cells))
            + 2 * _PAD_X for j in range(ncol)]
    if sum(natural) <= total:
        return [n * total / sum(natural) for n in natural]
    if sum(word) > total:
        if not force:
            return None
        widths = list(word)
        left = total
        order = sorted(range(ncol), key=lambda j: word[j])
        for k, j in enumerate(order):
            if word[j] > left / (ncol - k):  # this and the wider ones share what is left
                rest = order[k:]
                for i in rest:
                    widths[i] = left * natural[i] / sum(natural[r] for r in rest)
                break
            left -= word[j]
        return widths
    slack = [n - w for n, w in zip(natural, word, strict=True)]
    extra = total - sum(word)
    return [w + extra * s / sum(slack) for w, s in zip(word, slack, strict=True)]


@dataclass
class _TextPage:
    """What one text page draws, in drawing order.

    The table cells' boxes, then the lines of text (as a matplotlib figure of the same
    artists would: patches below texts).

    Attributes
    ----------
    boxes : list of tuple
        ``(x, y, width, height, filled)`` of each cell box, lower left corner [pt].
    lines : list of tuple
        ``(x, y, text, font, colour)`` of each line of text, its baseline's left end [pt].
    """

    boxes: list[tuple[float, float, float, float, bool]] = field(default_factory=list)
    lines: list[tuple[float, float, str, FontProperties, str]] = field(default_factory=list)


_CELL_EDGE, _HEAD_FILL = "0.6", "#eef3f8"
_UNIT_SQUARE = MplPath.unit_rectangle()


def _draw_text_page(pdf: PdfPages, page: _TextPage) -> None:
    """Write a text page straight to the PDF: its boxes as paths, its lines as text.

    No matplotlib figure, no artists, no layout: each line is drawn by matplotlib's PDF
    renderer (``RendererPdf.draw_text``: the fonts, their embedding and the text objects
    those of the figure pages) at the place :class:`_Flow` computed for it.
    """
    file = pdf._ensure_file()  # PdfPages's file: the pages, fonts and objects of the PDF
    w, h = A4_PORTRAIT
    file.newPage(w, h)
    renderer = RendererPdf(file, _PT, h * _PT, w * _PT)
    edge = to_rgb(_CELL_EDGE)
    fill = to_rgb(_HEAD_FILL)
    for x, y, bw, bh, filled in page.boxes:
        gc = renderer.new_gc()
        gc.set_linewidth(0.3)
        gc.set_foreground(edge)
        gc.set_joinstyle("miter")
        gc.set_capstyle("butt")
        renderer.draw_path(gc, _UNIT_SQUARE, Affine2D().scale(bw, bh).translate(x, y),
                           fill if filled else None)
        gc.restore()
    for x, y, text, prop, color in page.lines:
        gc = renderer.new_gc()
        gc.set_foreground(color)
        renderer.draw_text(gc, x, y, text, prop, 0.0)
        gc.restore()
    renderer.finalize()
    file.endStream()


class _Flow:
    """Text pages filled from the top; a new page when the current one is full.

    Positions are fractions of the page (``y`` from the bottom) while the page fills, as
    matplotlib's figure coordinates; the lines are placed in points when they are added.
    """

    def __init__(self, report: Report, measure: _Measure, jobs: list[_FigureJob]) -> None:
        self.report = report
        self.jobs = jobs
        self.page = 0
        self.current: _TextPage | None = None
        #: the pages in order, with their footers once their number is known (:meth:`close`)
        self.pages: list[_TextPage | _FigureJob] = []
        self.y = _TOP
        self.measure = measure

    def new_page(self) -> None:
        self.flush()
        self.current = _TextPage()
        self.y = _TOP

    def flush(self) -> None:
        if self.current is not None:
            self.page += 1
            self.pages.append(self.current)
            self.current = None

    def footer(self, k: int) -> str:
        """The footer of page ``k`` (from 1): the title and "page k of n"."""
        return f"{self.report.title}  ·  page {k} of {len(self.pages)}"

    def close(self, footers: _Footers) -> list[_TextPage | _FigureJob]:
        """Every page in order, each with "page k of n" in its footer.

        The figure pages' footers are given to ``footers`` (their pages draw them).
        """
        self.flush()
        where = [0] * len(self.jobs)
        for k, page in enumerate(self.pages, start=1):
            if isinstance(page, _TextPage):
                footer = self.footer(k)
                prop = self.measure.prop(7, "normal")
                w = self.measure.metrics(footer, prop)[0]
                # centred, its baseline 2.5 % of the page above the bottom edge
                page.lines.append((0.5 * A4_PORTRAIT[0] * _PT - w / 2,
                                   0.025 * A4_PORTRAIT[1] * _PT, footer, prop, "0.4"))
            else:
                where[page.number - 1] = k
        footers.set(where, len(self.pages))
        return self.pages

    def need(self, height: float) -> None:
        if self.current is None or self.y - height < _BOTTOM:
            self.new_page()

    def _line(self, x: float, top: float, text: str, prop: FontProperties, color: str,
              right: bool = False) -> None:
        """One line of text, the top of its line box at ``top`` [pt].

        As matplotlib's ``va='top'``: the baseline the font's ascent below, or the line's
        own ascent if taller; its left end (``right``: its right end) at ``x`` [pt].
        """
        assert self.current is not None
        w, h, d = self.measure.metrics(text, prop) if text else (0.0, 0.0, 0.0)
        ascent = max(h - d, self.measure.ascent_descent(prop)[0])
        if text:
            self.current.lines.append((x - w if right else x, top - ascent, text, prop, color))

    def text(self, s: str, size: float = 9.5, weight: str = "normal", color: str = "black",
             indent: float = 0.0) -> None:
        width = _TEXT_WIDTH_PT - indent * A4_PORTRAIT[0] * _PT
        prop = self.measure.prop(size, weight)
        for line in self.measure.wrap(s, width, size):
            self.need(_LINE * size / 9.5)
            self._line((_LEFT + indent) * A4_PORTRAIT[0] * _PT, self.y * A4_PORTRAIT[1] * _PT,
                       line, prop, color)
            self.y -= _LINE * size / 9.5

    def gap(self, lines: float = 0.6) -> None:
        self.y -= _LINE * lines

    def table(self, t: Table) -> None:
        """Draw a table over the text width, cells wrapped, rows split across pages."""
        m = self.measure
        cells = [list(t.columns)] + [list(r) for r in t.rows]
        widths = None
        for size in _TABLE_SIZES:
            widths = _column_widths(m, cells, size, _TEXT_WIDTH_PT,
                                    force=size == _TABLE_SIZES[-1])
            if widths is not None:
                break
        assert widths is not None
        pitch, one = m.line_metrics(size)
        page_h = A4_PORTRAIT[1] * _PT

        def lay(row: list[str], weight: str = "normal") -> tuple[list[list[str]], float]:
            lines = [m.wrap(c, w - 2 * _PAD_X, size, weight)
                     for c, w in zip(row, widths, strict=True)]
            return lines, (max(map(len, lines)) - 1) * pitch + one + 2 * _PAD_Y + 1.0

        header, header_h = lay(cells[0], "bold")
        title_h = _LINE * 9 / 9.5
        first = True
        for row in cells[1:] or [[""] * len(t.columns)]:
            lines, h = lay(row)
            h_frac = h / page_h
            if first or self.y - h_frac < _BOTTOM:
                self.need((header_h + h) / page_h + title_h + _LINE)
                if t.title:
                    self.text(t.title + ("" if first else " (continued)"), weight="bold",
                              size=9)
                self._row(header, widths, header_h / page_h, size, head=True)
                first = False
            self._row(lines, widths, h_frac, size)
        self.y -= 0.5 * _LINE
        if t.note:
            self.text(t.note, size=8, color="0.3")
        self.gap()

    def _row(self, lines: list[list[str]], widths: list[float], h: float, size: float,
             head: bool = False) -> None:
        """A table row: a box per cell, the cell's lines ``pitch`` apart from its top."""
        assert self.current is not None
        page_w = A4_PORTRAIT[0] * _PT
        page_h = A4_PORTRAIT[1] * _PT
        prop = self.measure.prop(size, "bold" if head else "normal")
        pitch, _ = self.measure.line_metrics(size)
        x = _LEFT * page_w
        top = self.y * page_h
        for cell, w in zip(lines, widths, strict=True):
            self.current.boxes.append((x, top - h * page_h, w, h * page_h, head))
            right = not head and bool(_NUMBER.match("\n".join(cell)))
            for k, line in enumerate(cell):
                self._line(x + w - _PAD_X if right else x + _PAD_X, top - _PAD_Y - k * pitch,
                           line, prop, "black", right)
            x += w
        self.y -= h

    def figure_page(self, number: int) -> None:
        """The page of figure ``number`` (from 1) next."""
        self.flush()
        self.page += 1
        self.pages.append(self.jobs[number - 1])


class _Footers:
    """The figure pages' footers, "page k of n", known once the pages are laid out.

    Shared with the worker processes, forked before the text is laid out: a worker
    drawing a figure page asks for its footer only once the figure is drawn, and waits
    there if the pages are not laid out yet.

    Parameters
    ----------
    title : str
        The report's title, the footers' first words.
    count : int
        Number of figures.
    shared : bool
        Whether worker processes will be forked (shared memory) or not.
    """

    def __init__(self, title: str, count: int, shared: bool) -> None:
        self.title, self.count = title, count
        self._pages: Any
        self._ready: Any
        if shared:
            ctx = multiprocessing.get_context("fork")
            self._pages = ctx.Array("i", count + 1, lock=False)
            self._ready = ctx.Event()
        else:
            self._pages = [0] * (count + 1)
            self._ready = threading.Event()

    def set(self, pages: list[int], total: int) -> None:
        """Figure ``j``'s page is ``pages[j]`` (from 1) of ``total``."""
        for j, k in enumerate(pages):
            self._pages[j] = k
        self._pages[self.count] = total
        self._ready.set()

    def get(self, j: int) -> str:
        """The footer of figure ``j``'s page (from 0), once the pages are laid out."""
        self._ready.wait()
        return f"{self.title}  ·  page {self._pages[j]} of {self._pages[self.count]}"


@dataclass
class _FigureJob:
    """A figure page to draw: the figure with its caption, its number, the page's footer."""

    item: FigureItem
    number: int
    measure: _Measure
    footers: _Footers

    def footer(self) -> str:
        return self.footers.get(self.number - 1)


@dataclass(frozen=True)
class FigurePage:
    """A figure page drawn: the page as a one-page PDF, the figure's area as PNG.

    Attributes
    ----------
    pdf : bytes
        The A4 landscape page (figure, caption, footer), a PDF file of one page.
    png : bytes
        The figure's area of that page (its caption and footer left out) at
        :data:`volcal.report.figures.PNG_DPI`.
    """

    pdf: bytes
    png: bytes


def _draw_figure_job(job: _FigureJob) -> FigurePage:
    """Draw a figure page once as vector PDF and rasterize its figure area as PNG."""
    buf = io.BytesIO()
    with PdfPages(buf) as pdf:
        box = _figure_page(pdf, job.item.figure, job.item.caption, job.number, job.footer,
                           job.measure)
    data = buf.getvalue()
    return FigurePage(data, page_png(data, box, PNG_DPI, PNG_COMPRESSION))


def _figure_page(pdf: PdfPages, fig: Figure, caption: str, number: int,
                 footer: Callable[[], str],
                 measure: _Measure) -> tuple[float, float, float, float]:
    """Print a figure on an A4 landscape page as vector graphics, its caption below.

    The figure is laid out again in the page's free area (its aspect ratio kept, its fonts
    at their point sizes) and restored afterwards (the figure object as it was built).
    ``footer()`` gives the page's footer when it is drawn, after the figure.
    Returns the figure's area on the page, its title included, ``(x0, y0, x1, y1)``
    from the page's lower left corner [pt].
    """
    pw, ph = A4_LANDSCAPE
    size = 9.0
    lines = measure.wrap(f"Figure {number}: {caption}", (pw - 2 * _FIG_MARGIN) * _PT, size)
    pitch, _ = measure.line_metrics(size)
    band = (len(lines) * pitch + 24.0) / _PT  # caption and footer [in]
    sup = getattr(fig, "_suptitle", None)  # placed by hand at the top of the free area
    sup_h = 0.0
    if sup is not None and sup.get_visible() and sup.get_text():
        sup_h = (sup.get_text().count("\n") + 1) * measure.line_metrics(sup.get_fontsize())[0]
        sup_h = (sup_h + 6.0) / _PT
    top = ph - _FIG_MARGIN - sup_h  # top of the figure's axes area [in]
    avail_w, avail_h = pw - 2 * _FIG_MARGIN, top - band - 0.1
    w, h = fig.get_size_inches()
    scale = min(avail_w / w, avail_h / h)
    fw, fh = w * scale, h * scale
    rect = ((pw - fw) / 2 / pw, (top - fh) / ph, fw / pw, fh / ph)
    engine = fig.get_layout_engine()
    if not isinstance(engine, ConstrainedLayoutEngine):
        engine = None  # a figure without constrained layout is scaled as a whole
    old_size, old_rect = fig.get_size_inches().copy(), engine.get()["rect"] if engine else None
    old_pos = [(ax, ax.get_position(original=True)) for ax in fig.axes] if not engine else []
    old_sup = ((sup, sup.get_position(), getattr(sup, "_autopos", False), sup.get_in_layout())
               if sup is not None and sup_h else None)
    fig.set_size_inches(pw, ph, forward=False)
    if engine is not None:
        engine.set(rect=rect)
    else:
        for ax, p in old_pos:
            ax.set_position((rect[0] + p.x0 * rect[2], rect[1] + p.y0 * rect[3],
                             p.width * rect[2], p.height * rect[3]))
    if old_sup is not None:
        old_sup[0].set_position((0.5, (ph - _FIG_MARGIN) / ph))
        old_sup[0]._autopos = False
        old_sup[0].set_in_layout(False)
    y = (top - fh - 0.1) / ph
    added = [fig.text(_FIG_MARGIN / pw, y, "\n".join(lines), fontsize=size, va="top",
                      linespacing=_LINESPACING, parse_math=False)]

    def draw_footer(renderer: Any) -> None:
        """The footer, centred, its baseline 2 % of the page above the bottom edge.

        As ``fig.text(0.5, 0.02, ha='center')``; known only once the pages are laid out,
        it is drawn last.
        """
        text = footer()
        prop = measure.prop(7, "normal")
        gc = renderer.new_gc()
        gc.set_foreground("0.4")
        renderer.draw_text(gc, 0.5 * pw * _PT - measure.metrics(text, prop)[0] / 2,
                           0.02 * ph * _PT, text, prop, 0.0)
        gc.restore()

    heavy = [a for a in _heavy_artists(fig) if not a.get_rasterized()]
    try:
        for a in heavy:
            a.set_rasterized(True)
        with kept_layout(fig):  # the figure as built afterwards
            _print_page(pdf, fig, draw_footer)
    finally:
        for a in heavy:
            a.set_rasterized(False)
        for a in added:
            a.remove()
        fig.set_size_inches(float(old_size[0]), float(old_size[1]), forward=False)
        if engine is not None:
            engine.set(rect=old_rect)
        for ax, p in old_pos:
            ax.set_position(p)
        if old_sup is not None:
            title, position, autopos, in_layout = old_sup
            title.set_position(position)
            title._autopos = autopos
            title.set_in_layout(in_layout)
    pad = _FIG_PAD  # the title's ascenders and the outermost labels not cut
    return ((pw - fw) / 2 * _PT - pad, (top - fh) * _PT - pad, (pw + fw) / 2 * _PT + pad,
            (ph - _FIG_MARGIN) * _PT + pad)


def _points(a: Artist) -> int:
    """Number of points an artist draws (vertices, markers, arrows, image cells)."""
    if isinstance(a, Line2D):
        return int(np.shape(a.get_xydata())[0])
    if isinstance(a, Collection):
        return max(int(np.shape(a.get_offsets())[0]), len(a.get_paths()))
    if isinstance(a, AxesImage):
        data = a.get_array()
        return 0 if data is None else int(np.prod(np.shape(data)[:2]))
    return 0


def _heavy_artists(fig: Figure) -> list[Artist]:
    """The artists of a figure with more than :data:`RASTER_POINTS` points."""
    return [a for ax in fig.axes for a in ax.get_children() if _points(a) > RASTER_POINTS]


class _PageCanvas(FigureCanvasPdf):
    """A PDF canvas whose layout engine measures with the renderer that prints the page."""

    def __init__(self, figure: Figure) -> None:
        super().__init__(figure)
        self.renderer: Any = None
        self._is_saving = True  # as savefig: what is printed, not what is shown

    def get_renderer(self) -> Any:
        return self.renderer


def _print_page(pdf: PdfPages, fig: Figure,
                after: Callable[[Any], None] | None = None) -> None:
    """Print a figure as the next page of ``pdf``, laid out and drawn in one pass.

    ``PdfPages.savefig`` lays a figure with a layout engine out in a drawing pass of its
    own, with a renderer of its own, before the drawing it prints; here the layout engine
    runs inside the one drawing (as ``Figure.draw`` does) and measures the texts with the
    renderer that prints them, so each text is measured once. The rasterized parts are
    drawn at :data:`RASTER_DPI`. ``after(renderer)`` draws more on the page, in points,
    after the figure.
    """
    canvas, dpi = fig.canvas, fig.dpi
    page = _PageCanvas(fig)

    def draw(renderer: Any) -> None:
        page.renderer = renderer
        Figure.draw(fig, renderer)
        if after is not None:
            after(renderer)

    try:
        fig.dpi = RASTER_DPI  # the resolution of the rasterized parts; the page is in points
        fig.draw = draw  # type: ignore[method-assign]
        page.print_pdf(pdf)
    finally:
        del fig.draw
        fig.set_canvas(canvas)
        fig.dpi = dpi


def write_pdf(report: Report, path: str | Path, *, pngs: dict[int, bytes] | None = None,
              meanwhile: Callable[[], None] | None = None, workers: int | None = None) -> int:
    """Write the report as PDF (the caller makes the write atomic).

    Parameters
    ----------
    report : Report
        The document; its text is printed as :func:`volcal.report.wording.customer_text`
        spells it.
    path : str or Path
        Output file.
    pngs : dict, optional
        Filled with each figure's PNG, the figure's area of its page rasterized
        (:class:`FigurePage`), by its index in ``report.figures``.
    meanwhile : callable, optional
        Called once the text pages are printed, while workers may still draw figure
        pages (the certificate).
    workers : int, optional
        Processes drawing the figure pages beside this one;
        :func:`volcal.report.figures.draw_workers` by default.

    Returns
    -------
    int
        Number of pages written.

    Notes
    -----
    The pages are laid out first (the text wrapped and paged, so that every footer says
    "page k of n"); then the figure pages are drawn, each as a PDF of one page, in worker
    processes where cores are spare, while this process prints the text pages; they are
    put in at their places (:func:`volcal.report.raster.insert_pages`).
    """
    report = customer_report(report)
    with cached_drawing():
        measure = _Measure()
        items = report.figures
        if workers is None:
            workers = draw_workers(len(items))
        footers = _Footers(report.title, len(items), shared=workers > 0 and bool(items))
        jobs = [_FigureJob(item, j + 1, measure, footers) for j, item in enumerate(items)]
        # the figure pages start now, in workers, while this process lays the text out; a
        # figure given as a function is built by the process that draws it
        drawing = draw_all(jobs, _draw_figure_job, workers, weight=lambda p: p.item.weight)
        try:
            flow = _Flow(report, measure, jobs)
            flow.new_page()
            flow.text(report.title, size=18, weight="bold")
            flow.text(f"Created {report.created} by {report.generator}", size=8.5,
                      color="0.35")
            flow.gap(1.0)
            for k, s in enumerate(report.sections, start=1):
                flow.text(f"{k}. {s.title}", size=10, indent=0.02)
            number = 0
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
                    for _ in s.figures:
                        number += 1
                        flow.figure_page(number)
            pages = flow.close(footers)
            text = io.BytesIO()
            with PdfPages(text, metadata={"Title": report.title,
                                          "Creator": report.generator}) as pdf:
                for page in pages:
                    if isinstance(page, _TextPage):
                        _draw_text_page(pdf, page)
            if meanwhile is not None:
                meanwhile()
            drawn = drawing.result()
        finally:
            drawing.close()
    # drawn[j] is figure j + 1's page (the jobs are in figure order)
    Path(path).write_bytes(insert_pages(text.getvalue(),
                                        [(k, drawn[page.number - 1].pdf)
                                         for k, page in enumerate(pages)
                                         if isinstance(page, _FigureJob)]))
    if pngs is not None:
        pngs.update(enumerate(d.png for d in drawn))
    return len(pages)
