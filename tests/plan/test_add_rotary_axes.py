"""``volcal plan --add`` of a rotary test lists its axis among the machine's."""

from __future__ import annotations

from volcal.plan.extend import add_planned_tests
from volcal.session.format import read_session
from volcal.session.rotary import read_rotary_axes
from volcal.steps.plan import plan

TRAVEL = ((0.0, 400.0), (0.0, 300.0), (0.0, 200.0))


def _axes(folder):
    return [(a.name, a.range_deg, a.modulo)
            for a in read_rotary_axes(read_session(folder, require_deviation=False).meta)]


def test_an_added_rotary_axis_joins_the_machines(tmp_path):
    """Session 20: adding rotary:a to a session whose machine lists C left A unlisted."""
    s = tmp_path / "S"
    plan(TRAVEL, steps=2, runs=2, tests="linear:x,rotary:c",
         rotary_axes="c:-180:180:modulo", output=s)
    assert _axes(s) == [("c", (-180.0, 180.0), True)]
    text = (s / "session.toml").read_text()
    add_planned_tests(s, ["rotary:a"], runs=2)
    assert _axes(s) == [("c", (-180.0, 180.0), True), ("a", (0.0, 360.0), True)]
    assert (s / "session.toml").read_text().startswith(text.rstrip("\n"))  # text kept
    # an axis the machine lists is not listed twice; its test takes the machine's range
    r = add_planned_tests(s, ["rotary:c"], runs=2)
    assert len(_axes(s)) == 2
    assert tuple(r.added[0].meta["range_deg"]) == (-180.0, 180.0)


def test_a_linear_session_gains_its_first_rotary_axis(tmp_path):
    s = tmp_path / "S"
    plan(TRAVEL, steps=2, runs=2, tests="linear:x", output=s)
    assert _axes(s) == []
    add_planned_tests(s, ["rotary:b"], runs=2)
    assert _axes(s) == [("b", (0.0, 360.0), True)]
