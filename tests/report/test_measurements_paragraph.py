"""The report's "Measurements and set-ups" explains the kinds the session holds, no others."""

from __future__ import annotations

from types import SimpleNamespace

from volcal.plan.planner import plan_session
from volcal.report.sections import measurements_section

TRAVEL = [[0, 800], [0, 600], [0, 500]]


def _paragraph(tests):
    s = plan_session(TRAVEL, tests=tests, steps=3, runs=2)
    return measurements_section(SimpleNamespace(session=s)).paragraphs[0]


def test_default_tests_explained_in_their_order():
    p = _paragraph(["step-diagonal", "diagonal", "linear"])
    assert p.startswith("The measurements by kind: step diagonal (4): sequential step "
                        "diagonal (Wang & Liotto 2003)")
    # the target is each measurement's (the table beside it), not the kind's
    assert "mirror" not in p and "retroreflector" not in p
    assert "diagonal (4): body or face diagonal (ISO 230-6)" in p
    assert "linear (9): positioning of one axis on a line" in p
    assert p.index("step diagonal (4)") < p.index("; diagonal (4)") < p.index("linear (9)")


def test_rotary_alone_says_nothing_of_linear_tests_or_diagonals():
    """Session 20: a report of one rotary test explained linear tests, body and step
    diagonals, none of which it held."""
    p = _paragraph(["rotary:c"])
    assert p == ("The measurements by kind: rotary (1): angular positioning of a rotary "
                 "axis: angular interferometer on a rotary calibrator or index table.")


def test_the_table_gives_a_beam_only_to_tests_along_a_line():
    """Session 22: a rotary test and an R-test were listed with a beam direction (0, 0, 1),
    and the machine section counted their readings as "laser readings"."""
    from volcal.report.sections import machine_section

    s = plan_session(TRAVEL, tests=["linear:x", "rotary:c", "r_test:ca"], steps=3, runs=2)
    t = measurements_section(SimpleNamespace(session=s)).tables[0]
    beams = {r[0]: r[t.columns.index("beam direction")] for r in t.rows}
    assert beams["linear-x1"] == "(1, 0, 0)"
    assert {k: v for k, v in beams.items() if not k.startswith("linear")} == {
        "rotary-c": "-", "r_test": "-"}
    text = machine_section(SimpleNamespace(session=s, truth=None)).paragraphs[1]
    n = sum(m.n for m in s.measurements)
    assert text.startswith(f"The session holds {len(s.measurements)} measurements with {n} "
                           "readings")
