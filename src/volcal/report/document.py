"""The neutral report document: sections of paragraphs, warnings, tables and figures.

Both renderers (:mod:`volcal.report.html`, :mod:`volcal.report.pdf`) take this model, so
the HTML and the PDF report always carry the same content.
"""

from __future__ import annotations

import math
from collections.abc import Callable
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


class _Drawn:
    """One figure, built when first asked for, with its PNG once drawn.

    Shared by the items that show it (the report's and the customer wording's copy).
    """

    def __init__(self, make: Callable[[], Figure]) -> None:
        self._make: Callable[[], Figure] | None = make
        self._figure: Figure | None = None
        self.png: bytes | None = None

    def figure(self) -> Figure:
        if self._figure is None:
            assert self._make is not None
            self._figure = self._make()
            self._make = None
        return self._figure

    def set(self, figure: Figure) -> None:
        self._figure, self._make, self.png = figure, None, None


class FigureItem:
    """A figure with its caption.

    Parameters
    ----------
    figure : Figure or callable
        The figure (Agg canvas), or a function of no arguments that builds it: then it is
        built when first asked for (:attr:`figure`), in the process that draws it (the
        report's figure pages are drawn in worker processes, :mod:`volcal.report.pdf`).
    caption : str
        What the figure shows, in plain words.
    name : str
        Short file-system-safe name (``'error-functions'``).
    weight : float
        How long it takes to draw, relative to the others (the larger are drawn first,
        so that the processes drawing a report's figures end together).
    """

    def __init__(self, figure: Figure | Callable[[], Figure] | _Drawn, caption: str,
                 name: str, weight: float = 1.0) -> None:
        if isinstance(figure, _Drawn):
            self._drawn = figure
        elif isinstance(figure, Figure):
            self._drawn = _Drawn(lambda: figure)
            self._drawn.figure()
        else:
            self._drawn = _Drawn(figure)
        self.caption, self.name, self.weight = caption, name, weight

    @property
    def figure(self) -> Figure:
        """The figure (built now if it was given as a function)."""
        return self._drawn.figure()

    @figure.setter
    def figure(self, figure: Figure) -> None:
        self._drawn.set(figure)

    @property
    def png(self) -> bytes | None:
        """The figure's PNG once a report drew it (its PDF page rasterized), else None."""
        return self._drawn.png

    @png.setter
    def png(self, data: bytes | None) -> None:
        self._drawn.png = data

    def recaptioned(self, caption: str) -> FigureItem:
        """The same figure (built once for both) with another caption.

        Parameters
        ----------
        caption : str
            The new caption.

        Returns
        -------
        FigureItem
        """
        return FigureItem(self._drawn, caption, self.name, self.weight)

    def __repr__(self) -> str:
        return f"FigureItem(name={self.name!r}, caption={self.caption!r})"


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
