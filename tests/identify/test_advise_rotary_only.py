"""``volcal advise`` on a session with rotary tests only (issue 27).

advise ranks the tests for the identification of the linear axes; a rotary test is
evaluated by ISO 230-2 alone. On a rotary-only session it refuses, as its other refusals
do (exit code 2, the session named, no traceback), saying so plainly instead of the
identification's "no measurements selected"; a session with a linear test beside the
rotary one is advised as before.
"""

from __future__ import annotations

import pytest

from volcal_cli_helpers import run_volcal


@pytest.fixture(scope="module")
def rotary_only(tmp_path_factory):
    from volcal.steps.plan import plan

    s = tmp_path_factory.mktemp("advrot") / "session"
    plan([[0, 400], [0, 300], [0, 200]], tests="rotary:c", steps=6, runs=2, output=s)
    return s


def test_advise_on_a_rotary_only_session_says_why_and_exits_2(rotary_only, monkeypatch,
                                                              capsys):
    code, out, err = run_volcal(monkeypatch, capsys, "advise", str(rotary_only))
    assert code == 2 and out == ""
    text = " ".join(err.split())
    assert f"{rotary_only / 'session.toml'}:" in text  # the session named
    assert ("advise ranks the tests for the identification of the linear axes (the model "
            f"of volcal identify), and session {rotary_only} has none (its tests: "
            "rotary-c (rotary))") in text
    assert ("the rotary axes are evaluated by ISO 230-2 alone: volcal evaluate session "
            f"{rotary_only}") in text
    assert "no measurements selected" not in text and "Traceback" not in text


def test_advise_step_and_calibration_refuse_the_same(rotary_only):
    from volcal.errors import VolcalInputError
    from volcal.flow import Calibration
    from volcal.steps.advise import advise

    with pytest.raises(VolcalInputError, match="has none .its tests: rotary-c .rotary.."):
        advise(rotary_only)
    with pytest.raises(VolcalInputError, match="evaluated by ISO 230-2 alone"):
        Calibration.open(rotary_only).advise()


def test_a_linear_test_beside_the_rotary_one_is_advised(tmp_path, monkeypatch, capsys):
    from volcal.steps.plan import plan

    s = tmp_path / "mixed"
    plan([[0, 400], [0, 300], [0, 200]], tests="linear:x,rotary:c", steps=6, runs=2,
         output=s)
    code, out, err = run_volcal(monkeypatch, capsys, "advise", str(s))
    assert code == 0, err
    assert out.startswith("- Before measuring") and "measurements (linear) determine" in out
