"""Render the calibration certificate as a PDF with matplotlib (A4 portrait).

Every page carries the title, the report id and "page n of m" (ISO/IEC 17025:2017,
7.8.2.1 c: the certificate is identified on every page, each page as part of the whole,
and its end is recognisable). The pages are laid out first and saved when their number
is known, so the footer can say "of m". Text and table cells are wrapped, never cut.
Fonts are embedded as TrueType (``pdf.fonttype`` 42) so that the text can be searched
and copied (``pdftotext`` reads it back).
"""

from __future__ import annotations

import re
import textwrap
from pathlib import Path
from typing import Any

from volcal.report.certificate import END_MARK
from volcal.report.certificate_layout import Block, layout

__all__ = ["write_certificate_pdf"]

_W, _H = 8.27, 11.69  # A4 portrait [inch]
_LEFT, _RIGHT, _TOP, _BOTTOM = 0.09, 0.91, 0.93, 0.07
_CHAR = 0.56  # average DejaVu Sans character width [em]
_NUMBER = re.compile(r"^[-+−]?\d[\d.,]*$|^–$")


def _chars(width_frac: float, size: float) -> int:
    """How many characters of a font size fit a width (fraction of the page width)."""
    return max(4, int(width_frac * _W * 72 / (_CHAR * size)))


class _Pages:
    """Pages filled from the top; the footers are written once the count is known."""

    def __init__(self) -> None:
        from volcal.plot._figure import new_figure

        self._new = new_figure
        self.figs: list[Any] = []
        self.y = _TOP

    def line_h(self, size: float) -> float:
        return size * 1.32 / (_H * 72)

    def need(self, h: float) -> None:
        if not self.figs or self.y - h < _BOTTOM:
            fig = self._new(_W, _H)
            fig.set_layout_engine(None)
            self.figs.append(fig)
            self.y = _TOP

    @property
    def fig(self) -> Any:
        return self.figs[-1]

    def text(self, s: str, size: float = 9.0, weight: str = "normal", color: str = "black",
             indent: float = 0.0) -> None:
        for line in textwrap.wrap(s, _chars(_RIGHT - _LEFT - indent, size)) or [""]:
            self.need(self.line_h(size))
            self.fig.text(_LEFT + indent, self.y, line, fontsize=size, weight=weight,
                          color=color, va="top")
            self.y -= self.line_h(size)

    def gap(self, size: float = 9.0, lines: float = 0.5) -> None:
        self.y -= self.line_h(size) * lines

    def fields(self, pairs: list[tuple[str, str]], size: float = 9.0) -> None:
        split = 0.36
        for label, value in pairs:
            lines = textwrap.wrap(value, _chars(_RIGHT - _LEFT - split, size)) or [""]
            self.need(self.line_h(size) * len(lines))
            self.fig.text(_LEFT, self.y, label, fontsize=size, color="0.3", va="top")
            for ln in lines:
                self.fig.text(_LEFT + split, self.y, ln, fontsize=size, va="top")
                self.y -= self.line_h(size)

    def table(self, b: Block) -> None:
        size = 7.5 if len(b.columns) <= 7 else 6.5
        cells = [b.columns, *b.rows]
        ncol = len(b.columns)
        natural = [max([int(1.15 * len(b.columns[j]) + 1)]  # the header is bold
                       + [len(r[j]) for r in b.rows]) + 2 for j in range(ncol)]
        least = [max(len(w) for r in cells for w in (r[j].split() or [""])) + 2
                 for j in range(ncol)]
        room = int(_chars(_RIGHT - _LEFT, size) / 1.1)  # digits and capitals are wider
        widths = list(natural)
        while sum(widths) > room:  # shrink the widest column that can still give way
            free = [j for j in range(ncol) if widths[j] > least[j]]
            if not free:
                break
            j = max(free, key=lambda i: widths[i])
            widths[j] -= 1
        xs = [_LEFT]
        for w in widths[:-1]:
            xs.append(xs[-1] + (_RIGHT - _LEFT) * w / sum(widths))
        lh = self.line_h(size)

        numeric = [bool(b.rows) and all(_NUMBER.match(r[j]) for r in b.rows)
                   for j in range(ncol)]

        def wrap(row: list[str]) -> list[list[str]]:
            return [textwrap.wrap(c, max(3, w - 2), break_long_words=False,
                                  break_on_hyphens=False) or [""]
                    for c, w in zip(row, widths, strict=True)]

        def height(row: list[str]) -> float:
            return lh * max(len(w) for w in wrap(row)) + 0.3 * lh

        def draw(row: list[str], bold: bool, flag: bool) -> None:
            h = height(row)
            if bold or flag:
                self.fig.patches.append(_rect(self.y + 0.15 * lh, h,
                                              "#fde2e1" if flag else "#e9eff6", self.fig))
            for j, (x, lines) in enumerate(zip(xs, wrap(row), strict=True)):
                right = numeric[j]
                if right:  # numbers right-aligned in their column, as in the report
                    x = x + (_RIGHT - _LEFT) * (widths[j] - 1.5) / sum(widths)
                for i, ln in enumerate(lines):
                    self.fig.text(x, self.y - i * lh, ln, fontsize=size, va="top",
                                  ha="right" if right else "left",
                                  weight="bold" if bold else "normal",
                                  color="#9b1c1c" if flag else "black")
            self.y -= h

        if b.title:
            self.need(self.line_h(9) + 3 * lh)
            self.text(b.title, size=8.5, weight="bold")
        first = b.rows[0] if b.rows else b.columns
        self.need(height(b.columns) + height(first))
        draw(b.columns, True, False)
        for i, r in enumerate(b.rows):
            if self.y - height(r) < _BOTTOM:  # a new page repeats the header
                self.need(1.0)
                draw(b.columns, True, False)
            draw(r, False, i in b.flagged)
        self.gap(size, 0.6)


def _rect(top: float, h: float, color: str, fig: Any) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle((_LEFT - 0.005, top - h), _RIGHT - _LEFT + 0.01, h, color=color,
                     transform=fig.transFigure, figure=fig, zorder=-1)


def write_certificate_pdf(doc: dict[str, Any], path: str | Path, angle_units: str = "urad"
                          ) -> int:
    """Write the certificate as PDF (the caller makes the write atomic).

    Parameters
    ----------
    doc : dict
        A ``volcal-certificate/1`` document (:func:`volcal.report.certificate.build_certificate`).
    path : str or Path
        Output file.
    angle_units : str
        ``'urad'`` or ``'arcsec'``: the printed unit of the rotary axes' results.

    Returns
    -------
    int
        Number of pages.
    """
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    p = _Pages()
    rid = doc["report_id"]
    p.need(0)
    lab = doc["laboratory"]
    p.text(lab.get("name") or "Calibration laboratory (not stated)", size=12, weight="bold")
    if lab.get("address"):
        p.text(lab["address"], size=9, color="0.3")
    p.gap(9, 1.0)
    p.text(doc["title"], size=20, weight="bold")
    p.text(f"Certificate number {rid}", size=11)
    p.text(f"Issued {doc['issued']} by {doc['generator']}", size=8.5, color="0.35")
    p.gap(9, 1.0)
    for k, s in enumerate(layout(doc, angle_units), start=1):
        p.need(p.line_h(11) * 4)
        p.gap(9, 0.6)
        p.text(f"{k}. {s.title}", size=11.5, weight="bold")
        p.gap(9, 0.3)
        for b in s.blocks:
            if b.kind == "p":
                p.text(b.text)
                p.gap(9, 0.4)
            elif b.kind == "note":
                p.text(b.text, size=7.5, color="0.3")
                p.gap(9, 0.3)
            elif b.kind == "flag":
                p.text("(!) " + b.text, weight="bold", color="#9b1c1c")
                p.gap(9, 0.4)
            elif b.kind == "fields":
                p.fields(b.fields)
                p.gap(9, 0.4)
            elif b.kind == "table":
                p.table(b)
    sig = doc["signatures"]
    p.need(p.line_h(9) * 12)
    p.gap(9, 1.5)
    p.text("Signatures", size=11.5, weight="bold")
    p.gap(9, 2.5)
    for label, name in (("Performed by", sig.get("performed_by")),
                        ("Approved by", sig.get("approved_by"))):
        p.fig.text(_LEFT, p.y, "_" * 40, fontsize=9, va="top")
        p.fig.text(0.55, p.y, "_" * 24, fontsize=9, va="top")
        p.y -= p.line_h(9) * 1.2
        p.fig.text(_LEFT, p.y, f"{label}: {name or '(name not stated)'}", fontsize=9,
                   va="top")
        p.fig.text(0.55, p.y, "Date", fontsize=9, va="top")
        p.y -= p.line_h(9) * 3
    p.text(f"— {END_MARK} —", size=10, weight="bold")
    n = len(p.figs)
    lab_name = lab.get("name") or ""
    with matplotlib.rc_context({"pdf.fonttype": 42}), PdfPages(
            path, metadata={"Title": f"{doc['title']} {rid}",
                            "Creator": doc["generator"]}) as pdf:
        for i, fig in enumerate(p.figs, start=1):
            fig.text(_LEFT, 0.965, f"{doc['title']} {rid}", fontsize=7.5, color="0.35")
            fig.text(_RIGHT, 0.965, lab_name, fontsize=7.5, color="0.35", ha="right")
            fig.text(0.5, 0.035, f"Certificate {rid}  ·  page {i} of {n}", ha="center",
                     fontsize=8, color="0.25")
            pdf.savefig(fig)
    return n
