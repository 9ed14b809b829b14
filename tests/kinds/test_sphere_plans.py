"""The default plans of the sphere kinds (probe_sphere, r_test): one layout, inside the travel.

Planned together the two kinds give the same pivots (``volcal locate`` takes them as one
machine configuration without edits); every position the part programs command (poses,
the R-test's following moves, the approach and probing moves) lies inside the session's
travel; ``volcal program`` refuses a test whose program would leave it, naming the pose
and the axis (the values hand-computed from the layout).
"""

from __future__ import annotations

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.spheres import probe_centres
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.program.probe_sphere import probe_program_positions
from volcal.program.r_test import rtest_program_positions
from volcal.program.writer import write_programs
from volcal.session.probe_sphere import five_axis_machine
from volcal.steps.locate import locate

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


@pytest.mark.parametrize("pair", ["", ":cb"])
def test_planned_together_one_configuration_locates_together(pair):
    """The same pivots in both tests; simulated, they locate together without edits and the
    fit is at the noise (chi-square per degree of freedom near 1: one configuration)."""
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=(f"probe_sphere{pair}", f"r_test{pair}"),
                     runs=2)
    probe, rt = s.measurements
    assert probe.meta["pivot_mm"] == rt.meta["pivot_mm"]
    assert probe.meta["chain"] == rt.meta["chain"] == ("CBXYFZ" if pair else "CAXYFZ")
    assert probe.meta["sphere_mm"] == rt.meta["sphere_mm"]
    machine = random_machine(TRAVEL, "XYFZ", seed=3)
    simulate_session(s, machine, SimulationOptions(seed=9))
    loc = locate(s, model=machine)
    assert loc.kinds == ("probe_sphere", "r_test")
    r = loc.result
    assert r.rms_before_um > 100.0
    assert r.chi2 / r.dof < 1.5


@pytest.mark.parametrize("travel", [TRAVEL, np.array([[-300.0, 300.0]] * 3),
                                    np.array([[0.0, 400.0], [0.0, 300.0], [0.0, 250.0]])])
@pytest.mark.parametrize("pair,chain", [("", "XYFZ"), (":cb", "FXYZ")])
def test_default_plans_command_positions_inside_the_travel(tmp_path, travel, pair, chain):
    """Every position the programs command, both kinds, lies inside the travel (a short Z
    travel shrinks the layout instead); the programs are written."""
    s = plan_session(travel, chain, steps=4, tests=(f"probe_sphere{pair}", f"r_test{pair}"),
                     runs=2)
    probe, rt = s.measurements
    pts = [p for _, p in rtest_program_positions(rt)]
    assert len(pts) > 300  # the following moves' points at most 1 deg apart
    for dialect in ("linuxcnc", "heidenhain"):
        pts += [p for _, p in probe_program_positions(probe, dialect)]
    p = np.array(pts)
    assert (p >= travel[:, 0]).all() and (p <= travel[:, 1]).all()
    # the margin kept: 35 mm minus the approach's and probing moves' reach (<= 30 mm)
    assert (p - travel[:, 0]).min() > 4.0 and (travel[:, 1] - p).min() > 4.0
    write_programs(s, "linuxcnc", tmp_path / "prog", _options())


def test_a_travel_too_short_is_refused_at_plan_time():
    with pytest.raises(VolcalInputError, match="too short"):
        plan_session(np.array([[0.0, 100.0], [0.0, 100.0], [0.0, 100.0]]), "XYFZ", steps=4,
                     tests=("r_test",), runs=2)


def _options():
    from volcal.program.steps import ProgramOptions

    return ProgramOptions(safe_z_mm=500.0)


def _old_layout(m, sphere):
    """The layout the plans had before: C pivot (400, 300, z_c), A line 120 mm below it."""
    m.meta["pivot_mm"] = {"c": [400.0, 300.0, sphere[2] - 40.0],
                          "a": [400.0, 300.0, sphere[2] - 160.0]}
    m.meta["sphere_mm"] = list(sphere)
    if m.kind == "r_test":
        m.positions = probe_centres(five_axis_machine(m), {
            "C": m.columns["c_deg"], "A": m.columns["a_deg"]}, sphere)


def test_program_refuses_a_pose_outside_the_travel(tmp_path):
    """The old defaults: the probe's pose 1 (C 0, A -90) puts the sphere centre on the A line's
    height, Z = 40 - 160 = -120 mm; the R-test's C turn at A = -90 reaches
    Z = 200 - 160 - 150 sin(30 deg) = -35 mm at C = 30 deg (pose 26: A = -90, C = 0 is pose
    25); each refused naming the test, pose, axis and travel."""
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("probe_sphere",), runs=2)
    _old_layout(s.measurements[0], [550.0, 300.0, 40.0])
    with pytest.raises(VolcalInputError) as e:
        write_programs(s, "linuxcnc", tmp_path / "p1", _options())
    assert ("probe_sphere test 'probe_sphere': pose 1: Z = -120.000 mm lies outside the "
            "session's travel Z 0..500 mm") in str(e.value)
    assert not (tmp_path / "p1").exists()
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("r_test",), runs=2)
    rt = s.measurements[0]
    _old_layout(rt, [550.0, 300.0, 200.0])
    assert rt.columns["a_deg"][25] == -90.0 and rt.columns["c_deg"][25] == 30.0
    with pytest.raises(VolcalInputError) as e:
        write_programs(s, "linuxcnc", tmp_path / "p2", _options())
    assert ("r_test test 'r_test': pose 26: Z = -35.000 mm lies outside the session's "
            "travel Z 0..500 mm") in str(e.value)
