"""probe_sphere on a tool centre point control (``control_kinematics = "tcp"``, LinuxCNC's
trt kinematics): the program probes the sphere where it sits on the table, the same points
at every pose; the importer turns the log's table coordinates back into machine ones."""

from __future__ import annotations

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.kinds import kind_of
from volcal.measure.fiveaxis_virtual import random_location
from volcal.measure.spheres import probe_centres
from volcal.model.fiveaxis import exact_pose5, location_parameter_names
from volcal.plan.planner import plan_session
from volcal.program.steps import ProgramOptions
from volcal.session.format import read_session, write_session
from volcal.session.probe_sphere import _angles, five_axis_machine

TRAVEL = np.array([[-300.0, 300.0], [-300.0, 300.0], [-300.0, 300.0]])


def _test(**meta):
    s = plan_session(TRAVEL, "FXYZ", steps=4, tests=("probe_sphere",), runs=2)
    m = s.measurements[0]
    m.meta.update({"control_kinematics": "tcp", "control_angle_sign": -1, **meta})
    return s, m


def test_tcp_program_probes_the_same_table_points_at_every_pose():
    _, m = _test()
    text, _ = kind_of("probe_sphere").program_text(m, "linuxcnc", "P", 1,
                                                   ProgramOptions(safe_z_mm=300.0))
    poses = text.split("(POSE ")[1:]
    assert len(poses) == m.n
    sphere = np.array(m.meta["sphere_mm"], dtype=float)
    probes = [[ln for ln in p.splitlines() if ln.startswith("G38.2")] for p in poses]
    assert all(p == probes[0] for p in probes) and len(probes[0]) == 5
    # the top probe: from clearance 5 mm above contact (sphere 25 + tip 3 mm) to 5 mm inside
    top = float(probes[0][0].split("Z")[1].split()[0])
    assert top == pytest.approx(sphere[2] + 14.0 - 5.0, abs=1e-3)
    ang = _angles(m)
    first = poses[0].splitlines()
    c0, a0 = 0.0 - ang["C"][0], 0.0 - ang["A"][0]
    assert first[1] == "G0 Z300.000" and first[2] == f"G0 C{c0:.3f} A{a0:.3f}"
    assert "(PROBEOPEN probe_sphere.txt)" in text and "(PROBECLOSE)" in text


def test_tcp_program_refuses_a_retract_below_the_sphere_and_a_bad_key():
    _, m = _test(sphere_mm=[100.0, 0.0, 40.0])
    with pytest.raises(VolcalInputError, match="safe_z_mm=-10: below the top approach"):
        kind_of("probe_sphere").program_text(m, "linuxcnc", "P", 1,
                                             ProgramOptions(safe_z_mm=-10.0))
    _, m = _test(control_kinematics="rtcp")
    with pytest.raises(VolcalInputError, match="control_kinematics 'rtcp'"):
        kind_of("probe_sphere").program_text(m, "linuxcnc", "P", 1, ProgramOptions())
    _, m = _test(probe_feed_mm_min=5000.0)
    with pytest.raises(VolcalInputError, match="probe_feed_mm_min 5000"):
        kind_of("probe_sphere").program_text(m, "linuxcnc", "P", 1, ProgramOptions())


def test_tcp_log_is_turned_back_into_machine_coordinates(tmp_path):
    """A machine off by mm: the control (configured kinematics) logs table coordinates of
    points on the sphere; the imported centres are the machine coordinates the true
    machine touched the sphere at (1 nm), and locate finds the truth's positions."""
    from volcal.importer.probe_log import import_probe_log
    from volcal.steps.locate import locate

    s, m = _test()
    nominal = five_axis_machine(m)
    code = nominal.chain_obj.code
    rng = np.random.default_rng(5)
    loc = random_location(code, rng)
    loc = {n: (v if n[1] in "XYZ" else 0.0) for n, v in loc.items()}
    true_m = nominal.with_location([loc[n] for n in location_parameter_names(code)])
    ang = _angles(m)
    sphere = np.array(m.meta["sphere_mm"], dtype=float) + [0.3, -0.2, 0.1]
    q = probe_centres(true_m, ang, sphere)  # where the true machine touches it
    world, _ = exact_pose5(nominal, q, ang)  # what the configured control computes
    r = 14.0
    dirs = np.array([[0, 0, 1], [1, 0, .5], [-1, 0, .5], [0, 1, .5], [0, -1, .5]], float)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    lines = []
    for i in range(m.n):
        for d in dirs:
            p = world[i] + r * d
            lines.append(" ".join(f"{v:.6f}" for v in (*p, -ang["A"][i], 0.0, -ang["C"][i],
                                                       0, 0, 0)))
    folder = tmp_path / "s"
    write_session(s, folder)
    log = tmp_path / "probe.txt"
    log.write_text("\n".join(lines) + "\n")
    import_probe_log(log, folder, m.id)
    got = read_session(folder).measurements[0].positions
    np.testing.assert_allclose(got, q, atol=1e-5)
    res = locate(folder).result.machine
    for name in ("EX0C", "EY0C", "EY0A", "EZ0A"):
        assert res.location_vector()[location_parameter_names(code).index(name)] == \
            pytest.approx(loc[name], abs=0.5), name
