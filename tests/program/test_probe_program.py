"""The probe_sphere part program, run through LinuxCNC's own interpreter ``rs274``.

Every ``G38.2`` move must start outside the sphere (plus the tip), travel the clearance
before the expected contact and end the overtravel beyond it, around the centre the
configured kinematics predict; the rotary axes turn only with Z retracted in machine
coordinates; the probe log is opened and closed.
"""

from __future__ import annotations

import numpy as np
import pytest

from program.replay import CANON, RS274, rs274_output
from volcal.measure.spheres import probe_centres
from volcal.plan.planner import plan_session
from volcal.program.probe_sphere import CLEARANCE_MM, OVERTRAVEL_MM
from volcal.program.steps import ProgramOptions
from volcal.session.probe_sphere import _angles, _keys, five_axis_machine

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


SAFE_Z = 500.0
"""Retract height of the tests [mm]: clears the planned sphere (its top, tip and clearance
at every pose and while the rotary axes turn: 120.1 mm, by
:func:`volcal.program.probe_sphere_controls.safe_height`)."""


def _planned():
    return plan_session(TRAVEL, "XYFZ", steps=4, tests=("probe_sphere",),
                        runs=2).measurements[0]


def _program(dialect="linuxcnc", safe_z_mm=SAFE_Z):
    from volcal.kinds import kind_of

    m = _planned()
    text, warnings = kind_of("probe_sphere").program_text(m, dialect, "P", 1,
                                                            ProgramOptions(safe_z_mm=safe_z_mm))
    return m, text, warnings


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is not installed "
                    "(make linuxcnc-deps)")
def test_probe_moves_in_rs274(tmp_path):
    m, text, _ = _program()
    out = rs274_output(tmp_path, text)
    canon = [(g.group(1), [float(x) for x in g.group(2).split(",") if x.strip()])
             for g in map(CANON.match, out.splitlines())
             if g and g.group(1) in ("STRAIGHT_TRAVERSE", "STRAIGHT_PROBE")]
    k = _keys(m)
    centres = probe_centres(five_axis_machine(m), _angles(m), k["sphere_mm"])
    angles = np.column_stack([_angles(m)[a] for a in ("C", "A")])
    r_eff = 0.5 * (25.0 + 3.0)
    pos = None
    probes = 0
    pose = -1
    for name, v in canon:
        xyz, abc = np.array(v[:3]), np.array(v[3:6])  # X Y Z A B C
        if name == "STRAIGHT_TRAVERSE" and pos is not None and np.any(abc != pos[1]):
            # the rotary axes turn only at the machine's safe Z (G53 Z150), X Y held
            assert xyz[2] == pytest.approx(SAFE_Z) and np.allclose(xyz[:2], pos[0][:2])
            pose += 1
            np.testing.assert_allclose([abc[2], abc[0]], angles[pose], atol=1e-3)
        if name == "STRAIGHT_PROBE":
            probes += 1
            # the expected contact along the move: |start + t u - c| = r_eff, first root
            c, start = centres[pose], pos[0]
            length = np.linalg.norm(xyz - start)
            u = (xyz - start) / length
            b = u @ (start - c)
            t = -b - np.sqrt(b * b - (start - c) @ (start - c) + r_eff**2)
            assert np.linalg.norm(start - c) > r_eff
            assert t == pytest.approx(CLEARANCE_MM, abs=2e-3)  # free travel before contact
            assert length - t == pytest.approx(OVERTRAVEL_MM, abs=2e-3)  # overtravel after
        pos = (xyz, abc)
    assert pose == m.n - 1 and probes >= 4 * m.n
    assert "(PROBEOPEN probe_sphere.txt)" in text and "(PROBECLOSE)" in text


def test_other_dialects_list_the_poses():
    m, text, warnings = _program("fanuc")  # HEIDENHAIN, Siemens: test_probe_program_controls
    assert "G38" not in text and text.count("POSE ") == m.n
    assert warnings and "LinuxCNC, HEIDENHAIN and Siemens" in warnings[0]


def test_linuxcnc_safe_z_below_the_swept_sphere_is_refused():
    """The LinuxCNC program retracts to --safe-z-mm before every rotary move and moves X, Y
    there: a height that does not clear the sphere is refused, naming the height needed."""
    from volcal.errors import VolcalInputError
    from volcal.program.probe_sphere_controls import safe_height

    m = _planned()
    need = safe_height(m, _angles(m), 0.5 * (25.0 + 3.0) + CLEARANCE_MM)
    # the planned sphere: centre Z at the poses and between them at most 99.3 mm above the
    # C pivot (z 335.353 mm), + 14 mm (radii) + clearance
    assert 400.0 < need <= 335.353 + 99.3 + 14.0 + CLEARANCE_MM < SAFE_Z
    with pytest.raises(VolcalInputError, match=f"safe_z_mm=0: below {need:.3f} mm"):
        _program(safe_z_mm=0.0)
    _program(safe_z_mm=need)  # exactly clear: accepted
