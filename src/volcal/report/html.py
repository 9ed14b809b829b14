"""Render a :class:`~volcal.report.document.Report` as one self-contained HTML file.

Figures are embedded as base64 PNG ``data:`` URIs (RFC 2397), the style sheet is inline;
the file opens offline in any browser and can be mailed as one attachment. The page is
rendered with a jinja2 template with autoescaping on.
"""

from __future__ import annotations

import base64
import re
from dataclasses import dataclass

import jinja2

from volcal.report.document import FigureItem, Report
from volcal.report.figures import png_data_uri
from volcal.report.wording import customer_report

__all__ = ["render_html"]

_ENV = jinja2.Environment(
    loader=jinja2.PackageLoader("volcal.report", "templates"),
    autoescape=jinja2.select_autoescape(["html", "j2"]),
    undefined=jinja2.StrictUndefined,
    keep_trailing_newline=True,
)


_NUMBER = re.compile(r"^[-+−]?(\d[\d.,]*|∞|-)$|^\(.*\)$")
"""Cells that are numbers (or vectors of numbers) are right-aligned."""


@dataclass
class _Rendered:
    item: FigureItem
    uri: str
    number: int


def render_html(report: Report) -> str:
    """Render the report as HTML text.

    Parameters
    ----------
    report : Report
        The document; its text is shown as :func:`volcal.report.wording.customer_text`
        spells it.

    Returns
    -------
    str
        A complete HTML5 document with embedded figures.
    """
    report = customer_report(report)
    number = 0
    sections = []
    for s in report.sections:
        figs = []
        for f in s.figures:
            number += 1
            uri = (png_data_uri(f.figure) if f.png is None  # drawn here, at its own size
                   else "data:image/png;base64," + base64.b64encode(f.png).decode("ascii"))
            figs.append(_Rendered(f, uri, number))
        tables = [{"title": t.title, "note": t.note, "columns": t.columns,
                   "rows": [[(c, bool(_NUMBER.match(c))) for c in r] for r in t.rows]}
                  for t in s.tables]
        sections.append({"id": s.id, "title": s.title, "paragraphs": s.paragraphs,
                         "warnings": s.warnings, "tables": tables, "figures": figs})
    view = {"title": report.title, "created": report.created, "generator": report.generator,
            "sections": sections}
    return _ENV.get_template("report.html.j2").render(report=view)
