"""``volcal capture`` takes the kinds it can, and says how the others' readings come in.

Session 20: a rotary test captured on the simulated control recorded 1 of its 8 readings
(the control reports X, Y, Z only, every dwell at the same position) and asked to "run the
same command again"; a probe_sphere or r_test test ended in a traceback of the simulated
laser. Session 21: rotary tests are captured (tests/capture/test_capture_rotary.py), then
R-tests (tests/capture/test_capture_rtest.py); the kinds still passed over are the
tracker's and probe_sphere.
"""

from __future__ import annotations

import pytest

from volcal.errors import ParameterError, VolcalInputError
from volcal.steps.capture import capture
from volcal.steps.plan import plan

from .conftest import FAST

TRAVEL = ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0))


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    out = tmp_path_factory.mktemp("kinds") / "S"
    plan(TRAVEL, steps=2, tests="linear:x,probe_sphere:ca", runs=1, output=out)
    return out


def test_a_kind_not_captured_is_passed_over_with_how_its_readings_come(mixed, tmp_path):
    """(A rotary test was passed over so until session 21: rotary tests are captured now,
    tests/capture/test_capture_rotary.py.)"""
    before = (mixed / "probe_sphere.csv").read_text()
    r = capture(mixed, control="sim", laser="sim", output=tmp_path / "C",
                measurement=None, **FAST)
    assert r.complete and [o.measurement for o in r.outcomes] == \
        ["linear-x1", "linear-x2", "linear-x3"]
    assert [n for n in r.notes if n.startswith("probe_sphere (probe_sphere) is not")] == [
        "probe_sphere (probe_sphere) is not captured by volcal capture, which takes one "
        "reading per dwell at a position of the linear axes, an angle of a rotary axis or a "
        "pose of an R-test: "
        "its readings are its probe program's log (volcal import LOG --session S "
        "--measurement ID; docs/fiveaxis.md); passed over"]
    assert (tmp_path / "C" / "probe_sphere.csv").read_text() == before  # nothing made up
    assert not (tmp_path / "C" / "capture" / "probe_sphere.jsonl").exists()


def test_naming_it_is_refused_before_anything_is_written(mixed, tmp_path):
    with pytest.raises(ParameterError, match=r"measurement=probe_sphere \(probe_sphere\) is "
                                             "not captured by volcal capture"):
        capture(mixed, control="sim", laser="sim", output=tmp_path / "C",
                measurement=["probe_sphere"], **FAST)
    assert not (tmp_path / "C").exists()


def test_nothing_to_capture(tmp_path):
    """(An r_test alone was "nothing to capture" until session 21: R-tests are captured now,
    tests/capture/test_capture_rtest.py.)"""
    s = tmp_path / "S"
    plan(((0.0, 800.0), (0.0, 600.0), (0.0, 500.0)), steps=2, tests="probe_sphere:ca",
         output=s)
    with pytest.raises(VolcalInputError, match="nothing to capture: .* is not captured"):
        capture(s, control="sim", laser="sim", output=tmp_path / "C", **FAST)
    assert not (tmp_path / "C").exists()


def test_direct_optics_reverse_with_an_overrun_and_are_captured(tmp_path):
    """Session 20: the straightness optic's program dwelt twice at each reversal without a
    move between (its kind is not ISO 230-2 bidirectional, its rows have directions): the
    capture refused reading 5 ("the control stands at ... the target of reading 3")."""
    from volcal.program.steps import ProgramOptions, build_steps
    from volcal.session.format import read_session

    s = tmp_path / "S"
    plan(((0.0, 200.0), (0.0, 150.0), (0.0, 100.0)), steps=2, tests="direct:x", runs=1,
         output=s)
    planned = read_session(s, require_deviation=False)
    m = planned.get("str-xy")
    steps = [st for st in build_steps(m, planned.travel, ProgramOptions()).steps
             if st.kind in ("move", "dwell")]
    assert "dwell, dwell" not in ", ".join(st.kind for st in steps)  # a move between
    assert any(st.text == "overrun" for st in steps)
    r = capture(s, control="sim", laser="sim", output=tmp_path / "C",
                measurement=["str-xy", "ang-xb"], **FAST)
    assert r.complete
    assert [(o.accepted, o.missed) for o in r.outcomes] == [(m.n, []), (m.n, [])]
