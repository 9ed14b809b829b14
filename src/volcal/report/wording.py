"""Customer wording of the report: one unit spelling, full citations instead of internal names.

The report is the document a customer gets. Text reaches it from many modules (the
identification's messages, the standards' warnings, the console's wording), some of which
write units in ASCII (``um``, ``urad``) or name the project's source documents by their
internal seed numbers. Both renderers pass every string of the document through
:func:`customer_text`, so the HTML and the PDF spell the units ``µm`` and ``µrad``
(SI prefix micro, U+00B5 as ISO 80000-1 typesetting allows) and cite the sources by author
and year, listed in full in the References section (:func:`references_section`).
Identifiers such as the CSV column ``deviation_um`` are left as they are.
"""

from __future__ import annotations

import dataclasses
import re

from volcal.report.document import Report, Section, Table

__all__ = ["CITED_AS", "REFERENCES", "REFERENCE_TABLE", "SOURCE_NAMES", "customer_report",
           "customer_text", "references_section"]

REFERENCE_TABLE: tuple[tuple[str, str], ...] = (
    ("ISO 230-1:2012, Test code for machine tools - Part 1: Geometric accuracy of machines "
     "operating under no-load or quasi-static conditions (ISO, Geneva).",
     r"ISO 230-1\b"),
    ("ISO 230-2:2014, Test code for machine tools - Part 2: Determination of accuracy and "
     "repeatability of positioning of numerically controlled axes (ISO, Geneva).",
     r"ISO 230-2\b"),
    ("ISO 230-6:2002, Test code for machine tools - Part 6: Determination of positioning "
     "accuracy on body and face diagonals (Diagonal displacement tests) (ISO, Geneva).",
     r"ISO 230-6\b"),
    ("ASME B5.54-2005, Methods for performance evaluation of computer numerically controlled "
     "machining centers (ASME, New York).",
     r"ASME B5\.54"),
    ("JCGM 100:2008, Evaluation of measurement data - Guide to the expression of uncertainty "
     "in measurement (GUM).",
     r"\bGUM\b|JCGM 100"),
    ("C. Wang, G. Liotto, \"A theoretical analysis of 4 body diagonal displacement "
     "measurement and sequential step diagonal measurement\", Proceedings of the 6th "
     "LAMDAMAP Conference, Huddersfield, 2003, pp. 463-471.",
     r"Wang & Liotto"),
    ("Optodyne, Inc., application note \"Pitch and yaw angular error measurement using a "
     "MCV-500 laser calibration system\" (pitch and yaw from three linear measurements at "
     "different Abbe offsets).",
     r"Optodyne application note"),
    ("C. Wang, Optodyne, Inc., body diagonal displacement errors as a quick volumetric check "
     "and the definitions of volumetric error (ELv, the root sum of squares of the three "
     "axes' positioning ranges).",
     r"Wang, Optodyne"),
    ("J. A. Soons, \"Analysis of the step-diagonal test\", National Institute of Standards "
     "and Technology (NIST), Proceedings of LAMDAMAP 2005.",
     r"\bSoons\b"),
    ("ISO 10791-6:2014, Test conditions for machining centres - Part 6: Accuracy of speeds "
     "and interpolations (ISO, Geneva); its five-axis kinematic tests, whose clauses and "
     "tolerances are not public, are followed in style (\"ISO 10791-6-style\").",
     r"ISO 10791-6"),
    ("S. Weikert, \"R-Test, a new device for accuracy measurements on five axis machine "
     "tools\", CIRP Annals 53(1) (2004) 429-432.",
     r"\bWeikert\b"),
    ("S. Ibaraki, C. Oyama, H. Otsubo, \"Construction of an error map of rotary axes on a "
     "five-axis machining center by static R-test\", International Journal of Machine Tools "
     "and Manufacture 51 (2011) 190-200.",
     r"\bIbaraki\b"),
)
"""The standards and papers the report's methods and wording rest on: each one's full
citation and how the report's text cites it (a regular expression, matched after
:func:`customer_text`, which turns the seed numbers into the :data:`SOURCE_NAMES`)."""

REFERENCES: tuple[str, ...] = tuple(r for r, _ in REFERENCE_TABLE)
"""Full citations of the standards and papers the report's methods and wording rest on."""

CITED_AS: tuple[str, ...] = tuple(c for _, c in REFERENCE_TABLE)
"""How the report's text cites each entry of :data:`REFERENCES` (:data:`REFERENCE_TABLE`)."""

ISO230_2_HEADS: dict[str, str] = {
    "A": "A", "A_up": "A↑", "A_down": "A↓", "E": "E", "M": "M", "R": "R", "R_up": "R↑",
    "R_down": "R↓", "B": "B", "B_mean": "B̄"}
"""The report's column head of each ISO 230-2 parameter, linear and rotary axes alike."""

ISO230_2_LEGEND = ("A accuracy, E systematic error, M range of the mean bidirectional "
                   "deviation, R repeatability, B reversal value, B̄ mean reversal value; "
                   "↑/↓ one approach direction only.")
"""The legend under the report's tables of ISO 230-2 parameters."""

SOURCE_NAMES: dict[str, str] = {
    "000": "Wang & Liotto 2003",
    "001": "Optodyne application note",
    "002": "Wang, Optodyne",
    "004": "Soons 2005",
}
"""Author-year name of each source document the code's comments call by number."""

_UM = re.compile(r"(?<![A-Za-z_µ])um(?![A-Za-z_0-9])")
_URAD = re.compile(r"(?<![A-Za-z_µ])urad(?![A-Za-z_0-9])")
_SEED = re.compile(r"\b[Ss]eeds? (00\d)(?:\s*/\s*(00\d))?('s)?")


def _seed(m: re.Match[str]) -> str:
    names = [SOURCE_NAMES.get(n, "see References") for n in m.groups()[:2] if n]
    return " and ".join(names) + (m.group(3) or "")


def customer_text(text: str) -> str:
    """Spell units and cite sources as the customer's document does.

    Parameters
    ----------
    text : str
        Any text of the report (paragraph, warning, table cell, caption).

    Returns
    -------
    str
        ``um`` -> ``µm``, ``urad`` -> ``µrad`` where they stand as units (not inside
        identifiers such as ``deviation_um``), and ``seed 00N`` -> the source's author and
        year (:data:`SOURCE_NAMES`).

    Examples
    --------
    >>> customer_text("ambiguity 1.15 -> 0.03 um RMS; EAX 13.1 urad (seed 004)")
    'ambiguity 1.15 -> 0.03 µm RMS; EAX 13.1 µrad (Soons 2005)'
    """
    text = _UM.sub("µm", text)
    text = _URAD.sub("µrad", text)
    return _SEED.sub(_seed, text)


def _table(t: Table) -> Table:
    return Table([customer_text(c) for c in t.columns],
                 [[customer_text(c) for c in r] for r in t.rows],
                 customer_text(t.title), customer_text(t.note))


def _section(s: Section) -> Section:
    return dataclasses.replace(
        s, title=customer_text(s.title),
        paragraphs=[customer_text(p) for p in s.paragraphs],
        warnings=[customer_text(w) for w in s.warnings],
        tables=[_table(t) for t in s.tables],
        figures=[f.recaptioned(customer_text(f.caption)) for f in s.figures])


def customer_report(report: Report) -> Report:
    """A copy of the report with every text passed through :func:`customer_text`.

    Parameters
    ----------
    report : Report
        The document (not changed; the figures are shared, not copied).

    Returns
    -------
    Report
    """
    return dataclasses.replace(report, title=customer_text(report.title),
                               sections=[_section(s) for s in report.sections])


def _texts(s: Section) -> list[str]:
    out = [s.title, *s.paragraphs, *s.warnings, *(f.caption for f in s.figures)]
    for t in s.tables:
        out.extend([t.title, t.note, *t.columns, *(c for r in t.rows for c in r)])
    return out


def references_section(sections: list[Section] | None = None) -> Section:
    """The References section: full citations of the standards and papers the report cites.

    Parameters
    ----------
    sections : list of Section, optional
        The report's other sections. An entry of :data:`REFERENCES` is listed when their
        text (titles, paragraphs, warnings, tables, captions, after :func:`customer_text`)
        cites it (:data:`CITED_AS`): a report of rotary tests alone does not list the
        diagonal papers. None lists every entry.

    Returns
    -------
    Section
        One numbered paragraph per entry listed, in the order of :data:`REFERENCES`.
    """
    if sections is None:
        listed = list(REFERENCES)
    else:
        text = "\n".join(customer_text(t) for s in sections for t in _texts(s))
        listed = [r for r, cite in REFERENCE_TABLE if re.search(cite, text)]
    sec = Section("references", "References")
    sec.paragraphs.extend(f"[{i}] {r}" for i, r in enumerate(listed, start=1))
    return sec
