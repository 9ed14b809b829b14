"""identify says which measurements it leaves out for their kind, and what evaluates them."""

from __future__ import annotations

from volcal.identify import IdentifyOptions, identify
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session

TRAVEL = [[0, 400], [0, 300], [0, 200]]


def _session(tests):
    s = plan_session(TRAVEL, tests=tests, steps=4, runs=2)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=3), SimulationOptions(seed=4))
    return s


def test_a_rotary_test_is_named_with_its_evaluation():
    """Session 20: the identification said "810 readings" of a 900-reading session and
    nothing of the rotary test it left out."""
    s = _session(["linear", "rotary:c"])
    rot = next(m for m in s.measurements if m.kind == "rotary")
    said = identify(s, IdentifyOptions(suggest=False)).report.messages
    left = [x for x in said if x.startswith("Left out")]
    assert left == [f"Left out of this identification of the linear axes: {rot.id} (rotary, "
                    f"{rot.n} readings): ISO 230-2 per axis, volcal evaluate session (its "
                    "table: volcal compensate --session)."]
    # chosen away by the user: nothing to say
    ids = [m.id for m in s.measurements if m.kind == "linear"]
    said = identify(s, IdentifyOptions(suggest=False, measurement_ids=ids)).report.messages
    assert not [x for x in said if x.startswith("Left out")]
