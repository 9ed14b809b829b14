"""``volcal locate --measurements`` naming a test of another kind says which kind it is and
which tests locate the rotary axes.

Session 22: ``--measurements rotary-c`` said "no probe_sphere test of that id in the
session (nor an r_test test)", as for an id the session does not hold.
"""

from __future__ import annotations

import pytest

from volcal.errors import ParameterError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.steps.locate import locate

TRAVEL = [[0, 800], [0, 600], [0, 500]]


@pytest.fixture(scope="module")
def session():
    s = plan_session(TRAVEL, tests=["rotary:c", "r_test:ca"], steps=2, runs=2)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=1), SimulationOptions(seed=2))
    return s


def test_a_test_of_another_kind_is_named_by_its_kind(session):
    with pytest.raises(ParameterError) as e:
        locate(session, measurements=["rotary-c"])
    assert e.value.message == ("measurements='rotary-c': a rotary test, not a probe_sphere or "
                               "r_test test; the session's tests that locate the rotary axes: "
                               "r_test")
    with pytest.raises(ParameterError, match="'nope': no probe_sphere test of that id in the "
                                             "session .*locate the rotary axes: r_test"):
        locate(session, measurements=["nope"])
