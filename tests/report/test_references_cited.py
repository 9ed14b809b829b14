"""The References section lists what the report cites, numbered in the list's order.

Session 21: every report listed the same nine entries (a report of rotary tests alone cited
the diagonal and step-diagonal papers) and none of the five-axis sources its location
section cites (ISO 10791-6, Weikert 2004, Ibaraki et al. 2011).
"""

from __future__ import annotations

from volcal.report.document import Section, Table
from volcal.report.wording import CITED_AS, REFERENCES, references_section


def _numbers(sec: Section) -> list[str]:
    return [p.split("] ", 1)[0] + "]" for p in sec.paragraphs]


def test_seed_numbers_and_table_cells_count_as_citations():
    a = Section("a", "A", paragraphs=["The step diagonals (seed 004 section 3) ..."])
    b = Section("b", "B", tables=[Table(["test"], [["ISO 230-2 bidirectional"]])])
    refs = references_section([a, b])
    assert _numbers(refs) == ["[1]", "[2]"]
    assert refs.paragraphs[0].startswith("[1] ISO 230-2:2014")
    assert "Analysis of the step-diagonal test" in refs.paragraphs[1]


def test_nothing_cited_nothing_listed_and_none_lists_all():
    assert references_section([Section("a", "Rotary", paragraphs=["C at 0 deg"])]).paragraphs == []
    assert len(references_section().paragraphs) == len(REFERENCES) == len(CITED_AS)


def test_each_entry_is_found_by_its_own_citation_only():
    cites = ["ISO 230-1", "ISO 230-2", "ISO 230-6", "ASME B5.54", "GUM", "Wang & Liotto 2003",
             "Optodyne application note", "Wang, Optodyne", "Soons 2005", "ISO 10791-6",
             "Weikert 2004", "Ibaraki et al. 2011"]
    for i, c in enumerate(cites):
        (p,) = references_section([Section("s", "S", paragraphs=[f"as {c} says"])]).paragraphs
        assert p == f"[1] {REFERENCES[i]}", c
    # ISO 230-2 does not cite ISO 230-20 (no such part yet, but the pattern must not match it)
    assert references_section([Section("s", "S", paragraphs=["ISO 230-20"])]).paragraphs == []
