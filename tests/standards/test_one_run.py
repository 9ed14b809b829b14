"""A test planned with one run per direction: not evaluated to ISO 230-2, said so, and the
rest of the session is (session 20: `volcal report` and `volcal evaluate session` refused
the whole session, "only 1 run(s) in direction '+'", for a plan `volcal plan --runs 1`
had accepted)."""

from __future__ import annotations

from types import SimpleNamespace

from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.report.completeness import completeness_section
from volcal.session.format import Session
from volcal.standards.session import evaluate_session

TRAVEL = [[0, 400], [0, 300], [0, 200]]
WHY = ("1 run per direction as planned: ISO 230-2 needs at least 2 to estimate the "
       "repeatability (it asks for 5)")


def _session() -> Session:
    one = plan_session(TRAVEL, tests=["linear:x", "rotary:c"], steps=3, runs=1)
    two = plan_session(TRAVEL, tests=["linear:y"], steps=3, runs=2)
    s = Session(one.name, one.chain, one.travel, [*one.measurements, *two.measurements],
                one.meta)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=1), SimulationOptions(seed=2))
    return s


def test_one_run_tests_are_skipped_with_the_reason_and_the_others_evaluated():
    s = _session()
    ev = evaluate_session(s)
    x = [m.id for m in s.measurements if m.kind == "linear" and m.axis == 0]
    y = [m.id for m in s.measurements if m.kind == "linear" and m.axis == 1]
    rot = [m.id for m in s.measurements if m.kind == "rotary"]
    assert sorted(ev.iso230_2) == sorted(y) and not ev.rotary
    assert {k: ev.skipped[k] for k in x} == {
        k: WHY + "; its readings still enter the identification" for k in x}
    assert ev.skipped[rot[0]] == WHY
    # the report says it where it lists what was not measured
    sec = completeness_section(SimpleNamespace(session=s, evaluation=ev, iso230_2=ev.iso230_2,
                                               iso230_6=ev.iso230_6))
    table = next(t for t in sec.tables if t.title.startswith("Tests measured but not"))
    assert [r[0] for r in table.rows] == [*x, *rot]
    assert f"not evaluated to their standard: {', '.join([*x, *rot])}" in sec.warnings
    # with no linear test evaluated the positioning section is left out (it said that its
    # tests were evaluated as ISO 230-2 asks, above no table)
    from volcal.report.sections import positioning_section

    only_x = Session(s.name, s.chain, s.travel, [s.get(k) for k in [*x, *rot]], s.meta)
    ev_x = evaluate_session(only_x)
    assert ev_x.iso230_2 == {} and positioning_section(SimpleNamespace(
        session=only_x, evaluation=ev_x, iso230_2={})) is None


def test_evaluate_iso230_2_of_the_one_run_file_still_refuses(tmp_path, monkeypatch, capsys):
    """Asked for explicitly, the one file's ISO 230-2 is refused as before; the session's
    evaluation names why nothing is left to evaluate when every test has one run."""
    from volcal.session.format import write_session
    from volcal_cli_helpers import run_volcal

    s = _session()
    write_session(s, tmp_path / "S")
    m = next(m for m in s.measurements if m.kind == "linear" and m.axis == 0)
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2",
                                str(tmp_path / "S" / m.file))
    assert code == 2 and "at least 2" in err, err
    one = plan_session(TRAVEL, tests=["linear:x"], steps=3, runs=1)
    simulate_session(one, random_machine(TRAVEL, "XYFZ", seed=1), SimulationOptions(seed=2))
    write_session(one, tmp_path / "ONE")
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "session",
                                str(tmp_path / "ONE"))
    assert code == 2 and "no linear or rotary measurement to evaluate to ISO 230-2:" in err
    # one line per reason, naming the tests it holds (session 21: one long line, the same
    # reason repeated per test)
    assert f"\n  linear-x1, linear-x2, linear-x3: {WHY}" in err.replace("\n    ", " "), err
