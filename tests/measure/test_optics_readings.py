"""Direct-optics reading models: signs on hand-built machines, exact vs first order, Jacobian."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import TRAVEL, machine, only
from volcal.measure.optics import (
    OpticSetup,
    optic_exact,
    optic_first_order,
    optic_jacobian,
    reference_columns,
)
from volcal.model.errorfunctions import MachineErrors
from volcal.model.parameters import ParameterLayout
from volcal.session.format import Measurement
from volcal.session.optics import annotate_references

N5 = np.linspace(0.0, 1.0, 5)


def _line(k, kind, target, meta, off=(0, 0, 0), mid="m", n=5):
    p = np.zeros((n, 3))
    p[:, k] = np.linspace(*TRAVEL[k], n)
    return Measurement(mid, kind, target, p, None, np.eye(3)[k], np.array(off, float),
                       meta=dict(meta))


def _ramp(chain, name, end):
    """A machine with one error rising linearly from 0 to ``end`` over its axis' travel."""
    m = MachineErrors.zero(chain, TRAVEL)
    return only(m, {name: np.array([0.0, end])}) if not name.endswith(("0Y", "0Z")) else \
        only(m, {name: end})


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ"])
def test_roll_of_z_seen_by_straightness_at_a_tool_offset(chain):
    """Right-hand rule: a rotation c about +Z moves a point at +x by +c x along +Y and a point
    at +y by -c y along +X."""
    mach = _ramp(chain, "ECZ", 10.0)  # urad at the end of Z
    ecz = 10.0 * N5
    m = _line(2, "straightness", "straightness_optics", {"axis": "z", "error_direction": "y"},
              (150, 0, 0))
    np.testing.assert_allclose(optic_exact(mach, m), ecz * 150e-3, atol=1e-9)
    m = _line(2, "straightness", "straightness_optics", {"axis": "z", "error_direction": "x"},
              (0, 150, 0))
    np.testing.assert_allclose(optic_exact(mach, m), -ecz * 150e-3, atol=1e-9)
    # at no offset the roll is invisible
    m0 = _line(2, "straightness", "straightness_optics", {"axis": "z", "error_direction": "y"})
    np.testing.assert_allclose(optic_exact(mach, m0), 0.0, atol=1e-9)


def test_straightness_reads_its_own_function_and_nothing_else():
    eyx = _ramp("XYFZ", "EYX", 4.0)
    m = _line(0, "straightness", "straightness_optics", {"axis": "x", "error_direction": "y"})
    np.testing.assert_allclose(optic_exact(eyx, m), 4.0 * N5, atol=1e-9)
    mz = _line(0, "straightness", "straightness_optics", {"axis": "x", "error_direction": "z"})
    np.testing.assert_allclose(optic_exact(eyx, mz), 0.0, atol=1e-9)
    # positioning error along the motion: not seen across it
    np.testing.assert_allclose(optic_exact(_ramp("XYFZ", "EXX", 30.0), m), 0.0, atol=1e-9)


def test_squareness_ec0y_in_the_straightness_of_y():
    """EC0Y > 0 leans +Y towards -X (volcal.model.kinematics.axis_directions)."""
    mach = _ramp("XYFZ", "EC0Y", 10.0)
    m = _line(1, "straightness", "straightness_optics", {"axis": "y", "error_direction": "x"})
    np.testing.assert_allclose(optic_exact(mach, m), -10.0 * 600 * N5 * 1e-3, atol=1e-6)


def test_sensor_on_the_table_sees_the_yaw_with_a_moving_lever():
    """XYFZ, X carries the table: a sensor fixed on the table at x = 400 is passed by the tool
    side; the yaw ECX acts on the lever from the tool point to the sensor, 400 - x."""
    mach = _ramp("XYFZ", "ECX", 10.0)
    m = _line(0, "straightness", "straightness_optics",
              {"axis": "x", "error_direction": "y", "sensor_position_mm": [400.0, 0.0, 0.0]})
    x = 800 * N5
    hand = 10.0 * N5 * (400.0 - x) * 1e-3
    np.testing.assert_allclose(optic_exact(mach, m), hand - hand[0], atol=1e-9)
    np.testing.assert_allclose(hand, [0, 0.5, 0, -1.5, -4.0], atol=1e-12)


@pytest.mark.parametrize(("name", "rot", "target"), [
    ("EAX", "a", "level"), ("EBX", "b", "angular_optics"), ("ECX", "c", "angular_optics"),
    ("EBY", "b", "roll_optics")])
def test_angular_reads_the_rotation_about_its_axis_only(name, rot, target):
    k = "XYZ".index(name[2])
    mach = _ramp("XYFZ", name, 10.0)
    for r in "abc":
        m = _line(k, "angular", target, {"axis": "xyz"[k], "rotation": r}, (100, -50, 200))
        want = 10.0 * N5 if r == rot else 0.0
        np.testing.assert_allclose(optic_exact(mach, m), want, atol=1e-9)


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ", "ZFYX"])
def test_exact_and_first_order_agree_to_second_order(chain, rng):
    """Halving every error quarters exact minus first order."""
    ms = [_line(0, "straightness", "straightness_optics", {"axis": "x", "error_direction": "z"},
                rng.uniform(-150, 150, 3)),
          _line(1, "straightness", "straightness_optics",
                {"axis": "y", "error_direction": "x", "sensor_position_mm": [200.0, 300.0, 50.0]}),
          _line(2, "angular", "angular_optics", {"axis": "z", "rotation": "a"})]
    big = machine(chain, seed=5, scale=20.0)
    seen = 0
    for m in ms:
        diffs = []
        for f in (1.0, 0.5):
            mm = big.scaled(f)
            diffs.append(np.abs(optic_exact(mm, m) - optic_first_order(mm, m)).max())
        assert np.abs(optic_exact(big, m)).max() > 1.0  # the readings are not small
        if diffs[0] < 1e-9:
            continue  # no second-order term on this line: exact = first order
        seen += 1
        assert diffs[1] == pytest.approx(diffs[0] / 4, rel=0.05), (m.meta, diffs)
    assert seen >= 1


@pytest.mark.parametrize("chain", ["XYFZ", "FYZX"])
def test_optic_jacobian_is_the_first_order_model(chain, rng):
    m = machine(chain, seed=8, n_nodes=6)
    lay = ParameterLayout(tuple(m.nodes))
    theta = lay.pack(m)
    for ms in (_line(0, "straightness", "straightness_optics",
                     {"axis": "x", "error_direction": "y"}, rng.uniform(-80, 80, 3)),
               _line(2, "straightness", "straightness_optics",
                     {"axis": "z", "error_direction": "x", "sensor_position_mm": [10, 20, 30]}),
               _line(1, "angular", "level", {"axis": "y", "rotation": "b"})):
        A = optic_jacobian(m.chain_obj.order, m.nodes, ms).toarray()
        r0 = optic_first_order(m, ms)
        np.testing.assert_allclose(A @ theta, r0, atol=1e-9)
        for j in rng.choice(lay.size, 25, replace=False):
            th = theta.copy()
            th[j] += 1.0
            np.testing.assert_allclose(optic_first_order(lay.unpack(th, chain), ms) - r0, A[:, j],
                                       atol=1e-9)


def test_reference_group_columns_and_the_optical_square():
    """A reference rotation rho about +Z tilts X-along-Y by -rho and Y-along-X by +rho; the
    square's deviation delta (angle between the +X and +Y reference directions minus 90
    degrees) reads delta * (d . e_X) on the turned line."""
    a = _line(0, "straightness", "straightness_optics",
              {"axis": "x", "error_direction": "y", "reference": "xy"}, mid="a")
    b = _line(1, "straightness", "straightness_optics",
              {"axis": "y", "error_direction": "x", "reference": "xy"}, mid="b")
    c = _line(2, "straightness", "straightness_optics", {"axis": "z", "error_direction": "x"},
              mid="c")
    annotate_references([a, b, c], {"xy": {"square_deviation_urad": 3.0}})
    ca, cb, cc = reference_columns(a), reference_columns(b), reference_columns(c)
    ux, uy = 800 * N5 * 1e-3, 600 * N5 * 1e-3
    assert set(ca) == {"reference:xy:rot_z"} and set(cc) == {"c:slope"}
    assert set(cb) == {"reference:xy:rot_z", "reference:xy:square"}
    np.testing.assert_allclose(ca["reference:xy:rot_z"], -ux)
    np.testing.assert_allclose(cb["reference:xy:rot_z"], uy)
    np.testing.assert_allclose(cb["reference:xy:square"], uy)
    np.testing.assert_allclose(cc["c:slope"], 500 * N5 * 1e-3)
    # a perfect machine read through a square 3 urad over 90 degrees: the turned line
    # leans by 3 urad, as a squareness EC0Y = -3 urad would
    setup = OpticSetup(nuisances={"reference:xy:square": 3.0})
    zero = MachineErrors.zero("XYFZ", TRAVEL)
    np.testing.assert_allclose(optic_exact(zero, b, setup),
                               optic_exact(_ramp("XYFZ", "EC0Y", -3.0), b), atol=1e-9)
