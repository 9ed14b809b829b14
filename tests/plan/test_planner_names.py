"""Test names as users type them: case, and '-' or '_' between the words."""

from __future__ import annotations

import pytest

from volcal.errors import VolcalInputError
from volcal.plan.planner import canonical_test, plan_session

TRAVEL = [[0, 400], [0, 300], [0, 200]]


@pytest.mark.parametrize(("typed", "name"), [
    ("probe-sphere:ca", "probe_sphere:ca"), ("R-Test", "r_test"), ("r_test:cb", "r_test:cb"),
    ("step_diagonal", "step-diagonal"), ("Face_Step_Diagonal:XY", "face-step-diagonal:XY"),
    ("LINEAR:x", "linear:x"), ("spiral", "spiral")])
def test_canonical_names(typed, name):
    assert canonical_test(typed) == name


def test_plan_takes_either_spelling_and_refuses_the_unknown():
    a = plan_session(TRAVEL, tests=["probe-sphere:ca", "Linear:X", "step_diagonal"], steps=3)
    b = plan_session(TRAVEL, tests=["probe_sphere:ca", "linear:x", "step-diagonal"], steps=3)
    assert [m.kind for m in a.measurements] == [m.kind for m in b.measurements]
    assert [m.id for m in a.measurements] == [m.id for m in b.measurements]
    assert {m.kind for m in a.measurements} >= {"probe_sphere", "linear", "step_diagonal"}
    with pytest.raises(VolcalInputError, match="unknown test.*spiral"):
        plan_session(TRAVEL, tests=["spiral"])


@pytest.mark.parametrize(("tests", "message"), [
    (["linear", "linear:x"], "tests: 'linear' and 'linear:x' both plan the measurement "
                             "'linear-x1': name each test once \\('linear' alone plans every "
                             "axis"),
    (["Face_Step_Diagonal:YZ", "face-step-diagonal"],
     "'face-step-diagonal:YZ' and 'face-step-diagonal' both plan the measurement "
     "'fstep-yz-pp'"),
    (["diagonal", "Diagonal"], "tests names 'diagonal' twice"),
    (["linear:x", "linear:X"], "tests names 'linear:x' twice")])
def test_a_test_named_twice_or_inside_another_is_refused_naming_both(tests, message):
    """A user's ``--tests linear,linear:x``: both plan linear-x1. The refusal names the two
    tests (it named only the duplicate id, from deep in the session's checks)."""
    with pytest.raises(VolcalInputError, match=message):
        plan_session(TRAVEL, tests=tests, steps=3)


def test_each_face_names_the_tests_its_own_way(tmp_path):
    """The command line says ``--tests``, Python ``tests`` (one message, spelled by each)."""
    from volcal import Calibration
    from volcal_cli_helpers import volcal_process

    p = volcal_process("plan", "-o", str(tmp_path / "S"), "--tests", "linear,linear:x")
    assert p.returncode == 2 and "--tests: 'linear' and 'linear:x' both plan" in p.stderr
    with pytest.raises(VolcalInputError, match=r"^Calibration.plan: tests: 'linear' and"):
        Calibration.plan(TRAVEL, tests=["linear", "linear:x"])
