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


@pytest.mark.parametrize("axes,pair,chain,fixed", [
    # a cradle tilting from -120 to +30: the default fixed tilts fit, the sweep is cut
    ("c:0:360:modulo,a:-120:30:limited", "", "XYFZ", [0.0, -45.0, -90.0]),
    # a B cradle from -5 to +110 (a limited C of -180..180): the fixed tilts span the range
    # from the angle nearest 0, 0 -> 110 (hand: the middle 55)
    ("c:-180:180:limited,b:-5:110:limited", ":cb", "FXYZ", [0.0, 55.0, 110.0]),
])
def test_plans_keep_within_the_machines_limited_rotary_axes(tmp_path, axes, pair, chain, fixed):
    """``--rotary-axes`` with a limited axis: both sphere plans command angles within its
    range only (the default plans' -90..+90 deg tilt would overrun a cradle's limit), still
    one configuration inside the travel that locates together, and ``volcal program`` writes
    them."""
    from volcal.plan.rotary import rotary_axis_spec

    given = rotary_axis_spec(axes)
    s = plan_session(TRAVEL, chain, steps=4, tests=(f"probe_sphere{pair}", f"r_test{pair}"),
                     runs=2, rotary={"axes": given})
    probe, rt = s.measurements
    assert probe.meta["pivot_mm"] == rt.meta["pivot_mm"]
    limited = {a.name: a.range_deg for a in given if not a.modulo}
    tilt = (pair[-1] if pair else "a")
    for m in (probe, rt):
        for letter, (lo, hi) in limited.items():
            v = m.columns[f"{letter}_deg"]
            assert v.min() >= lo and v.max() <= hi, (m.id, letter)
        # the tilting axis' whole range is used: both ends reached
        t = m.columns[f"{tilt}_deg"]
        assert t.min() == limited[tilt][0] and t.max() == limited[tilt][1], m.id
    c_turns = rt.columns["c_deg"][:12]
    lo_c = limited["c"][0] if "c" in limited else 0.0
    np.testing.assert_allclose(c_turns, lo_c + 30.0 * np.arange(12))
    assert sorted(set(rt.columns[f"{tilt}_deg"][:36])) == sorted(fixed)
    pts = np.array([p for _, p in rtest_program_positions(rt)]
                   + [p for _, p in probe_program_positions(probe, "linuxcnc")])
    assert (pts >= TRAVEL[:, 0]).all() and (pts <= TRAVEL[:, 1]).all()
    s.meta["rotary_axes"] = [a.to_toml() for a in given]
    write_programs(s, "linuxcnc", tmp_path / "prog", _options())
    # simulated, they still locate together at the noise (one configuration)
    machine = random_machine(TRAVEL, chain, seed=3)
    simulate_session(s, machine, SimulationOptions(seed=9))
    r = locate(s, model=machine).result
    assert r.rms_before_um > 100.0 and r.chi2 / r.dof < 1.5


def test_program_refuses_a_pose_beyond_a_limited_axis(tmp_path):
    """The default R-test sweeps A from -90 to +90 deg at C = 0 after its three C turns
    (36 poses): on a cradle limited to -120..+30 deg its pose 46 (A = -90 + 9 x 15 = 45 deg,
    row 47 under the header) is the first beyond; refused naming file, row and column, no
    folder written. The same axis declared modulo turns freely."""
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("r_test",), runs=2)
    s.meta["rotary_axes"] = [{"name": "a", "range_deg": [-120.0, 30.0], "modulo": False}]
    with pytest.raises(VolcalInputError) as e:
        write_programs(s, "linuxcnc", tmp_path / "p", _options())
    assert ("r_test test 'r_test': pose 46: A = 45 deg lies beyond the range -120..30 deg of "
            "axis A") in str(e.value)
    assert "(4 of 49 poses beyond)" in str(e.value)
    assert (e.value.file, e.value.row, e.value.column) == ("r_test.csv", 47, "a_deg")
    assert not (tmp_path / "p").exists()
    s.meta["rotary_axes"] = [{"name": "a", "range_deg": [-120.0, 30.0], "modulo": True}]
    write_programs(s, "linuxcnc", tmp_path / "p", _options())


@pytest.mark.parametrize("test", ["r_test", "probe_sphere"])
def test_a_cradle_the_machine_does_not_have_is_refused(test):
    """The default pair is C on an A cradle; a machine declaring B (and no A) asks for
    ``:cb``: planning ``:ca`` there would write A moves for a machine without A."""
    from volcal.plan.rotary import rotary_axis_spec

    with pytest.raises(VolcalInputError, match=r"a sphere test of a C table on an A cradle "
                       r"\(:ca\), but the machine's rotary axes .* have B and no A: plan "
                       r"probe_sphere:cb or r_test:cb, or declare A"):
        plan_session(TRAVEL, "XYFZ", steps=4, tests=(test,), runs=2,
                     rotary={"axes": rotary_axis_spec("c:0:360:modulo,b:-10:110:limited")})
    s = plan_session(TRAVEL, "FXYZ", steps=4, tests=(f"{test}:cb",), runs=2,
                     rotary={"axes": rotary_axis_spec("c:0:360:modulo,b:-10:110:limited")})
    assert s.measurements[0].meta["chain"] == "CBFXYZ"


def test_the_range_is_the_controls_angles(tmp_path):
    """``range_deg`` holds the control's limits: a test whose control counts the angles the
    other way (``control_angle_sign = -1``, LinuxCNC's trt kinematics) turns to minus
    volcal's angles, and those are checked. The default R-test's tilts run -90..+90:
    negated, the C turns at volcal's A = -45 are at the control's +45 (pose 13, the first
    beyond +30 on a cradle of -120..+30)."""
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("r_test",), runs=2)
    s.measurements[0].meta["control_angle_sign"] = -1
    s.meta["rotary_axes"] = [{"name": "a", "range_deg": [-120.0, 30.0], "modulo": False}]
    with pytest.raises(VolcalInputError) as e:
        write_programs(s, "linuxcnc", tmp_path / "p", _options())
    assert ("pose 13: A = 45 deg (the control's angle: control_angle_sign = -1) lies beyond "
            "the range -120..30 deg of axis A") in str(e.value)
    assert (e.value.row, e.value.column) == (14, "a_deg")
