"""The rows-in-reverse-order warning only for kinds whose poses run along their beam."""

from __future__ import annotations

import numpy as np
import pytest

from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.plausibility import plausibility_warnings

TRAVEL = [[0, 800], [0, 600], [0, 500]]


def _session(tests):
    s = plan_session(TRAVEL, tests=tests, steps=4, runs=2)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=1), SimulationOptions(seed=2))
    return s


@pytest.mark.parametrize("tests", [["multilateration"], ["r_test:ca"]])
def test_no_order_warning_for_poses_around(tests):
    """Session 20: every tracker measurement but one and the R-test warned "the poses move
    against the beam direction of session.toml: rows ... in reverse order?" on sessions
    volcal itself planned and simulated (their poses spread around, no beam runs along)."""
    assert not [w for w in plausibility_warnings(_session(tests)) if "against the beam" in w]


def test_a_reversed_diagonal_still_warns():
    s = _session(["diagonal"])
    m = s.measurements[0]
    for name in ("positions", "deviation"):
        setattr(m, name, np.asarray(getattr(m, name))[::-1].copy())
    w = [x for x in plausibility_warnings(s) if "against the beam" in x]
    assert w and w[0].startswith(f"{m.id}: the poses move against the beam direction")


def test_first_reading_far_from_zero_only_for_laser_displacements():
    """Session 20: an imported rotary calibrator's export warned "the first reading is -4.85
    um, not ~0 (readings count from the first row)": a rotary deviation (in urad) does not
    count from the first row. A linear test's still warns."""
    s = _session(["rotary:c", "linear:x"])
    for m in s.measurements:
        m.deviation = np.asarray(m.deviation, dtype=float) + 50.0
    w = [x for x in plausibility_warnings(s) if "the first reading is" in x]
    rot = next(m.id for m in s.measurements if m.kind == "rotary")
    assert w and not [x for x in w if x.startswith(rot)]
    assert {x.split(":")[0] for x in w} == {m.id for m in s.measurements if m.kind == "linear"}


def test_no_scale_warning_for_an_r_test_beside_linear_tests():
    """Session 22: ``volcal report`` of a 5-axis session (linear tests, step diagonals and
    an R-test, planned and simulated by volcal) warned "r_test: deviations ~697x larger
    than the session's other r test tests (1.06e+04 um/m against a median of 15.2 um/m):
    mm entered as um?": the nest's displacements while the axes circle divided by the
    poses' extent, compared with the linear tests' errors per metre. A linear test entered
    in mm still warns, naming the tests it was compared with."""
    s = _session(["linear", "step-diagonal", "r_test:ca"])
    assert not [w for w in plausibility_warnings(s) if "larger than" in w or
                "smaller than" in w]
    m = next(m for m in s.measurements if m.kind == "linear")
    m.deviation = np.asarray(m.deviation, dtype=float) * 1000.0
    w = [x for x in plausibility_warnings(s) if "larger than" in x]
    assert [x.split(":")[0] for x in w] == [m.id]
    assert "larger than the session's other linear tests" in w[0]
