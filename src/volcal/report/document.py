"""The neutral report document: sections of paragraphs, warnings, tables and figures.

Both renderers (:mod:`volcal.report.html`, :mod:`volcal.report.pdf`) take this model, so
the HTML and the PDF report always carry the same content.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime

from matplotlib.figure import Figure

__all__ = ["FigureItem", "Report", "Section", "Table", "fmt"]


def fmt(v: float | None, digits: int = 2) -> str:
    """Format a number for a table cell (fixed point, ``-`` for missing, ``∞``).

    Parameters
    ----------
    v : float or None
        The value, in the unit of its column; None or NaN means missing.
    digits : int
        Number of decimals.

    Returns
    -------
    str
        ``v`` with ``digits`` decimals, ``'-'`` when missing, ``'∞'`` when infinite.
    """
    if v is None:
        return "-"
    v = float(v)
    if math.isnan(v):
        return "-"
    if math.isinf(v):
        return "∞"
    return f"{v:.{digits}f}"


@dataclass
class Table:
    """A table of preformatted cells.

    Attributes
    ----------
    columns : list of str
        Column headings, units in brackets (``'A [µm]'``).
    rows : list of list of str
        Cells, already formatted.
    title : str
        Caption.
    note : str
        Text under the table.
    """

    columns: list[str]
    rows: list[list[str]]
    title: str = ""
    note: str = ""

    def __post_init__(self) -> None:
        for i, r in enumerate(self.rows):
            if len(r) != len(self.columns):
                raise ValueError(f"table {self.title!r}: row {i} has {len(r)} cells, "
                                 f"expected {len(self.columns)}")


@dataclass
class FigureItem:
    """A figure with its caption.

    Attributes
    ----------
    figure : matplotlib.figure.Figure
        The figure (Agg canvas).
    caption : str
        What the figure shows, in plain words.
    name : str
        Short file-system-safe name (``'error-functions'``).
    """

    figure: Figure
    caption: str
    name: str


@dataclass
class Section:
    """One section of the report.

    Attributes
    ----------
    id : str
        Anchor (``'machine'``).
    title : str
        Heading.
    paragraphs : list of str
        Plain text paragraphs.
    warnings : list of str
        Plain-word warnings, shown highlighted.
    tables : list of Table
    figures : list of FigureItem
    """

    id: str
    title: str
    paragraphs: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)
    figures: list[FigureItem] = field(default_factory=list)


@dataclass
class Report:
    """The whole report.

    Attributes
    ----------
    title : str
        Title (machine name and purpose).
    sections : list of Section
    created : str
        Creation time, ISO 8601 UTC.
    generator : str
        Software and version that wrote the report.
    """

    title: str
    sections: list[Section] = field(default_factory=list)
    created: str = field(
        default_factory=lambda: datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"))
    generator: str = ""

    @property
    def figures(self) -> list[FigureItem]:
        """All figures in document order."""
        return [f for s in self.sections for f in s.figures]
