"""Decision rules (ILAC-G8, ISO 14253-1): simple and guarded acceptance, all three outcomes."""

import pytest

from volcal.errors import VolcalInputError
from volcal.standards.decision import combine, decide
from volcal.standards.tolerance import Verdict, parse_parameter_tolerance, parse_tolerance

T, U = 10.0, 2.0


@pytest.mark.parametrize("value,simple,guarded", [
    (10.0, "pass", "conditional"),        # at T
    (8.0, "pass", "pass"),                # at T - U
    (9.0, "pass", "conditional"),         # between T - U and T
    (7.99, "pass", "pass"),
    (10.01, "fail", "fail"),              # above T
])
def test_rules_at_the_limits(value, simple, guarded):
    assert decide(value, T).verdict == simple
    d = decide(value, T, "guarded", U=U)
    assert d.verdict == guarded and d.acceptance_limit == pytest.approx(8.0)
    assert d.rule == "guarded" and d.guard_band == U


def test_simple_never_conditional_guarded_gives_all_three():
    simple = {decide(v, T, U=U).verdict for v in (0.0, 8.0, 9.0, 10.0, 11.0)}
    guarded = {decide(v, T, "guarded", U=U).verdict for v in (0.0, 8.0, 9.0, 10.0, 11.0)}
    assert simple == {"pass", "fail"}
    assert guarded == {"pass", "conditional", "fail"}


def test_U_larger_than_T_no_pass_possible():
    d = decide(0.5, 1.0, "guarded", U=1.5)
    assert d.verdict == "conditional" and "no pass is possible" in d.note
    assert decide(1.2, 1.0, "guarded", U=1.5).verdict == "fail"
    assert decide(0.0, 1.0, "guarded", U=1.0).verdict == "conditional"   # U = T


def test_guard_band_overrides_U_and_errors():
    assert decide(9.0, T, "guarded", U=2.0, guard_band=0.5).verdict == "pass"
    with pytest.raises(VolcalInputError, match="guard band"):
        decide(9.0, T, "guarded")
    with pytest.raises(VolcalInputError, match="simple, guarded"):
        decide(9.0, T, "strict")
    with pytest.raises(VolcalInputError, match=">= 0"):
        decide(9.0, T, "guarded", guard_band=-1.0)


def test_combine_and_verdict_words():
    assert combine(["pass", "conditional", "pass"]) == "conditional"
    assert combine(["conditional", "fail"]) == "fail"
    assert combine(["pass", "-"]) == "pass"
    v = Verdict("q", 10.0, 9.0, 7.0, "guarded", 2.0, 2.0)
    assert (v.before, v.after) == ("conditional", "pass")
    d = v.to_dict()
    assert d["rule"] == "guarded" and d["before"] == "conditional" and d["after"] == "pass"
    assert Verdict("q", 10.0, 9.0).to_dict()["after"] is None


def test_parameter_tolerances():
    assert parse_parameter_tolerance("12") == {"A": 12.0}
    assert parse_parameter_tolerance("A=10, e=6,R=4,b_mean=1") == {
        "A": 10.0, "E": 6.0, "R": 4.0, "B_mean": 1.0}
    for bad in ("Q=3", "A=1,A=2", "A=-1", "A"):
        with pytest.raises(VolcalInputError, match="tolerance-um"):
            parse_parameter_tolerance(bad)
    t = parse_tolerance("X=10,X.E=6,Y.R=3,V=20")
    assert t.axis_um == {"X": 10.0} and t.parameters == {"X": {"E": 6.0}, "Y": {"R": 3.0}}
    assert t.volumetric_um == 20.0 and t.text() == "X=10,X.E=6,Y.R=3,V=20"
    assert parse_tolerance("Z.A=4").axis_um == {"Z": 4.0}
    with pytest.raises(VolcalInputError, match="unknown ISO 230-2 parameter"):
        parse_tolerance("X.Q=1")
