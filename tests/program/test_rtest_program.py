"""The r_test part program, run through LinuxCNC's own interpreter ``rs274``.

What LinuxCNC would do with it: Z retracts first (machine coordinates), the rotary axes turn
only there or while the linear axes follow; every following move ends where the configured
kinematics put the nest centre on the nominal sphere, and its chord (a straight line of the
five joints) stays within 20 um of it; the program dwells once at each pose, at that pose's
angles and commanded positions; the nest is lowered onto the sphere and lifted off along the
tool axis, slowly, from the approach distance.
"""

from __future__ import annotations

import numpy as np
import pytest

from program.replay import CANON, RS274, rs274_output
from volcal.errors import VolcalInputError
from volcal.kinds import kind_of
from volcal.model.fiveaxis import exact_pose5
from volcal.plan.planner import plan_session
from volcal.program.r_test import APPROACH_FEED_MM_MIN, CLEARANCE_MM
from volcal.program.steps import ProgramOptions
from volcal.session.r_test import rtest_angles
from volcal.session.r_test import rtest_machine as _machine

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
SAFE_Z = 500.0


def _measurement():
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("r_test",), runs=2)
    return s.measurements[0]


def test_safe_z_below_the_approach_is_refused():
    m = _measurement()
    with pytest.raises(VolcalInputError,
                       match="safe_z_mm=0: below the approach point 405.353 mm"):
        kind_of("r_test").program_text(m, "linuxcnc", "R", 1, ProgramOptions(safe_z_mm=0.0))


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is not installed "
                    "(make linuxcnc-deps)")
def test_path_in_rs274(tmp_path):
    m = _measurement()
    text, warnings = kind_of("r_test").program_text(m, "linuxcnc", "R", 1,
                                                    ProgramOptions(safe_z_mm=SAFE_Z))
    assert not warnings
    out = rs274_output(tmp_path, text)
    canon = []
    for g in map(CANON.match, out.splitlines()):
        if g and g.group(1) in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "DWELL",
                                "SET_FEED_RATE", "PROGRAM_STOP"):
            canon.append((g.group(1), [float(x) for x in g.group(2).split(",") if x.strip()]))
    nominal = _machine(m)
    sphere = np.array(m.meta["sphere_mm"])
    angles = rtest_angles(m)

    # the nest centre at every move's end and chord midpoint, in one batch
    ends, mids, prev = [], [], np.zeros(6)
    for name, v in canon:
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            cur = np.array(v[:6])
            ends.append(cur)
            mids.append(0.5 * (prev + cur))
            prev = cur
    J = np.array(ends + mids)
    P, RR = exact_pose5(nominal, J[:, :3], {"A": J[:, 3], "C": J[:, 5]}, m.tool_offset)
    table = {tuple(j): (P[i], RR[i]) for i, j in enumerate(J)}

    def tool_point(xyz, abc):
        return table[tuple(np.concatenate([xyz, abc]))]

    pos = (np.zeros(3), np.zeros(3))
    feed = 0.0
    dwells, stopped, following = 0, False, False
    lowered = lifted = False
    for name, v in canon:
        if name == "SET_FEED_RATE":
            feed = v[0]
            continue
        if name == "PROGRAM_STOP":
            stopped = True
            continue
        if name == "DWELL":
            # at a pose: its angles and the session file's positions, the nest on the
            # sphere (rs274 prints 4 decimals; the program's 3 decimals were up to 0.5 um off
            # the file, read by the sensors as a location error)
            np.testing.assert_allclose(pos[0], m.positions[dwells], atol=6e-5)
            np.testing.assert_allclose([pos[1][2], pos[1][0]],
                                       [angles["C"][dwells], angles["A"][dwells]], atol=1e-3)
            dwells += 1
            continue
        xyz, abc = np.array(v[:3]), np.array(v[3:6])
        if name == "STRAIGHT_TRAVERSE":
            assert not following, "a rapid move while the nest is around the sphere"
            if np.any(abc != pos[1]):  # the rotary axes turn only at the safe Z, X Y held
                assert xyz[2] == pytest.approx(SAFE_Z) and pos[0][2] == pytest.approx(SAFE_Z)
                assert np.allclose(xyz[:2], pos[0][:2])
            if dwells == 0 and not stopped and np.all(pos[0] == 0):
                assert xyz[2] == pytest.approx(SAFE_Z)  # the first move retracts Z
        else:
            end, R = tool_point(xyz, abc)
            gap = np.linalg.norm(end - sphere)
            if not following and not lifted:
                # lowering the nest: slowly, along the tool axis, from the approach distance
                start, _ = tool_point(*pos)
                assert feed == APPROACH_FEED_MM_MIN
                assert np.linalg.norm(start - sphere) == pytest.approx(CLEARANCE_MM, abs=1e-3)
                np.testing.assert_allclose((start - end) / CLEARANCE_MM, R[:, 2], atol=1e-6)
                assert gap < 2e-3
                lowered, following = True, True
            elif gap > 1.0:  # lifting off along the tool axis: the end of the path
                assert following and dwells == m.n and feed == APPROACH_FEED_MM_MIN
                assert gap == pytest.approx(CLEARANCE_MM, abs=1e-3)
                np.testing.assert_allclose((end - sphere) / CLEARANCE_MM, R[:, 2], atol=1e-6)
                following, lifted = False, True
            else:
                # following: the end on the sphere (rounding of 0.001 mm and 0.001 deg), the
                # chord of the five joints close to it
                assert stopped and gap < 5e-3
                mid, _ = tool_point(0.5 * (pos[0] + xyz), 0.5 * (pos[1] + abc))
                assert np.linalg.norm(mid - sphere) < 0.02
        pos = (xyz, abc)
    assert lowered and lifted and dwells == m.n
    assert pos[0][2] == pytest.approx(SAFE_Z)  # ends retracted


def test_tcp_program_holds_the_sphere_and_turns_the_rotary_axes_only():
    """control_kinematics = "tcp" (LinuxCNC's trt kinematics follows): X Y Z stay at the
    sphere's table coordinates, the following moves program the rotary axes alone, in the
    control's angles (control_angle_sign = -1), and the listing of another dialect."""
    m = _measurement()
    m.meta["control_kinematics"] = "tcp"
    m.meta["control_angle_sign"] = -1
    text, _ = kind_of("r_test").program_text(m, "linuxcnc", "R", 1,
                                             ProgramOptions(safe_z_mm=SAFE_Z))
    lines = text.splitlines()
    s = m.meta["sphere_mm"]
    onto = f"G1 X{s[0]:.6f} Y{s[1]:.6f} Z{s[2]:.6f} F{APPROACH_FEED_MM_MIN:g}"  # a pose's
    i = lines.index(onto)
    assert lines[i - 1] == f"G0 Z{s[2] + CLEARANCE_MM:.3f}" and lines[1 + i].startswith("M0")
    follow = [ln for ln in lines[i + 1:] if ln.startswith("G1 C")]
    assert follow and all(not any(w in ln for w in ("X", "Y", "Z")) for ln in follow)
    assert "G1 C-30.000000 A0.000000 F1000" in follow  # pose 2, C = 30 in volcal's sense
    assert "G1 C-29.000 A0.000 F1000" in follow  # on the way: the program's decimals
    assert text.count("G4 P") == m.n
    assert lines[-3:] == [f"G1 X{s[0]:.3f} Y{s[1]:.3f} Z{s[2] + CLEARANCE_MM:.3f} F200",
                          f"G0 Z{SAFE_Z:.3f}", "M2"]
    listing, warnings = kind_of("r_test").program_text(m, "heidenhain", "R", 1,
                                                       ProgramOptions(safe_z_mm=SAFE_Z))
    assert "(POSE 2: C=-30.000 A=0.000 LINEAR AXES X=529.904 Y=225.000 Z=375.353)" in listing
    assert warnings and "LinuxCNC only" in warnings[0]


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is not installed "
                    "(make linuxcnc-deps installs linuxcnc-uspace)")
def test_linuxcnc_reads_a_path_within_a_limited_cradle(tmp_path):
    """Planned with the machine's cradle limited to -120..+30 deg, the R-test's program as
    LinuxCNC's own interpreter reads it turns A over exactly that range (both ends, and
    nothing beyond: the default plan's sweep reached +90 deg)."""
    from program.replay import run_rs274
    from volcal.plan.rotary import rotary_axis_spec
    from volcal.program.writer import write_programs

    s = plan_session(np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]]), "XYFZ", steps=4,
                     tests=("r_test",), runs=2,
                     rotary={"axes": rotary_axis_spec("c:0:360:modulo,a:-120:30:limited")})
    s.meta["rotary_axes"] = [{"name": "a", "range_deg": [-120.0, 30.0], "modulo": False}]
    write_programs(s, "linuxcnc", tmp_path / "p", ProgramOptions(safe_z_mm=480.0))
    cmds = run_rs274((tmp_path / "p" / "r_test.ngc").read_text(), axes=6)
    a = [v[3] for name, v in cmds if "STRAIGHT" in name]
    assert len(a) > 300 and min(a) == pytest.approx(-120.0) and max(a) == pytest.approx(30.0)
