"""Kinematic model: exact vs first order, Soons eq. (1), sign conventions, lever arms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import ALL_CHAINS, TRAVEL, machine, only
from volcal.model.kinematics import (
    exact_pose,
    first_order_pose,
    volumetric_error,
    volumetric_error_exact,
)


def _points(rng, m=60):
    return rng.uniform(TRAVEL[:, 0], TRAVEL[:, 1], (m, 3))


@pytest.mark.parametrize("chain", ALL_CHAINS)
def test_exact_and_first_order_agree_to_second_order(chain, rng):
    """Halving every error quarters the difference between exact and first-order models."""
    q = _points(rng)
    t = rng.uniform(-200, 200, 3)
    big = machine(chain, seed=ALL_CHAINS.index(chain), scale=20.0)
    diffs, odiffs = [], []
    for m in (big, big.scaled(0.5)):
        d = volumetric_error_exact(m, q, t) - volumetric_error(m, q, t)
        diffs.append(np.abs(d).max())
        _, R = exact_pose(m, q, t)
        w_exact = Rotation.from_matrix(R).as_rotvec() * 1e6
        odiffs.append(np.abs(w_exact - first_order_pose(m, q, t)[1]).max())
    # the difference is second order: not zero, and it scales with the square
    assert diffs[0] > 1e-3
    assert diffs[0] / diffs[1] == pytest.approx(4.0, rel=0.02)
    assert odiffs[0] > 1e-6
    assert odiffs[0] / odiffs[1] == pytest.approx(4.0, rel=0.02)


def test_soons_eq1_chain_fxyz(rng):
    """Soons (2005) eq. (1), written out here with EC0Y = S_xy, EB0Z = -S_xz, EA0Z = S_yz."""
    m = machine("FXYZ", seed=3)
    q = _points(rng, 25)
    x, y, z = q.T
    f = {n: m.function(n, q[:, "XYZ".index(n[-1])]) * (1e-3 if n[1] in "ABC" else 1.0)
         for n in ("EXX", "EYX", "EZX", "EAX", "EBX", "ECX", "EXY", "EYY", "EZY",
                   "EAY", "EBY", "ECY", "EXZ", "EYZ", "EZZ", "EAZ", "EBZ", "ECZ")}
    # angles in um/mm (= 1e-3 * urad) so that angle * mm gives um
    s_xy, s_xz, s_yz = m.squareness[0] * 1e-3, -m.squareness[1] * 1e-3, m.squareness[2] * 1e-3
    ex = (f["EXX"] + f["EXY"] + f["EXZ"] + (f["EBX"] + f["EBY"] - s_xz) * z
          - (f["ECX"] + s_xy) * y)
    ey = f["EYX"] + f["EYY"] + f["EYZ"] - (f["EAX"] + f["EAY"] + s_yz) * z
    ez = f["EZX"] + f["EZY"] + f["EZZ"] + f["EAX"] * y
    e, w = first_order_pose(m, q)
    np.testing.assert_allclose(e, np.c_[ex, ey, ez], atol=1e-9)
    wx = (f["EAX"] + f["EAY"] + f["EAZ"]) * 1e3
    wy = (f["EBX"] + f["EBY"] + f["EBZ"]) * 1e3
    wz = (f["ECX"] + f["ECY"] + f["ECZ"]) * 1e3
    np.testing.assert_allclose(w, np.c_[wx, wy, wz], atol=1e-9)


def test_squareness_signs_exact_model():
    """EC0Y > 0: angle(+X, +Y) > 90 deg; EB0Z > 0: Z leans to +X; EA0Z > 0: Z leans to -Y."""
    base = machine("XYFZ").scaled(0.0)
    m = only(base, {"EC0Y": 100.0})
    px, _ = exact_pose(m, [[500.0, 0, 0]])
    py, _ = exact_pose(m, [[0, 500.0, 0]])
    cos = (px[0] @ py[0]) / np.linalg.norm(px[0]) / np.linalg.norm(py[0])
    assert np.degrees(np.arccos(cos)) == pytest.approx(90.0 + np.degrees(100e-6), abs=1e-9)
    # e_x = -EC0Y * y: 100 urad over 500 mm = -50 um
    assert volumetric_error_exact(m, [[0, 500.0, 0]])[0, 0] == pytest.approx(-50.0, abs=1e-4)
    m = only(base, {"EB0Z": 100.0})
    assert volumetric_error_exact(m, [[0, 0, 400.0]])[0, 0] == pytest.approx(40.0, abs=1e-4)
    m = only(base, {"EA0Z": 100.0})
    assert volumetric_error_exact(m, [[0, 0, 400.0]])[0, 1] == pytest.approx(-40.0, abs=1e-4)


def test_lever_arm_hand_values():
    """Constant yaw ECX = 10 urad; chain FXYZ: e = ECX x (t + y e_y + z e_z)."""
    base = machine("FXYZ").scaled(0.0)
    m = only(base, {"ECX": 10.0})
    q = np.array([[100.0, 300.0, 200.0]])
    t = np.array([5.0, 20.0, -50.0])
    # rotation about Z by 10 urad of the lever (5, 320, 150): (-10e-6 * 320, 10e-6 * 5, 0) mm
    np.testing.assert_allclose(volumetric_error(m, q, t), [[-3.2, 0.05, 0.0]], atol=1e-12)
    np.testing.assert_allclose(volumetric_error_exact(m, q, t), [[-3.2, 0.05, 0.0]], atol=1e-4)
    # chain ZYXF: X is next to the tool, its lever arm is the tool offset only
    m2 = only(machine("ZYXF").scaled(0.0), {"ECX": 10.0})
    np.testing.assert_allclose(volumetric_error(m2, q, t), [[-0.2, 0.05, 0.0]], atol=1e-12)
    # pitch EBY of Y in FXYZ acts on z + t_z only: e_x = EBY * (z + t_z)
    m3 = only(base, {"EBY": 10.0})
    np.testing.assert_allclose(volumetric_error(m3, q, t), [[1.5, 0.0, -0.05]], atol=1e-12)


@pytest.mark.parametrize("codes", [("FXYZ", "XFYZ", "XYFZ", "XYZF"),
                                   ("FYXZ", "YFXZ", "YXFZ", "YXZF")])
def test_only_the_axis_order_matters(codes, rng):
    """Tool-relative-to-workpiece errors: the frame's place in the chain changes nothing."""
    q = _points(rng, 20)
    t = rng.uniform(-100, 100, 3)
    m0 = machine(codes[0], seed=9)
    ref = exact_pose(m0, q, t)
    for c in codes[1:]:
        m = machine(c, seed=9)
        p, R = exact_pose(m, q, t)
        np.testing.assert_array_equal(p, ref[0])
        np.testing.assert_array_equal(R, ref[1])


def test_perfect_machine_has_no_error(rng):
    q = _points(rng, 10)
    for chain in ALL_CHAINS[:6]:
        m = machine(chain).scaled(0.0)
        np.testing.assert_array_equal(volumetric_error(m, q, [1, 2, 3]), 0.0)
        np.testing.assert_allclose(volumetric_error_exact(m, q, [1, 2, 3]), 0.0, atol=1e-9)


def test_interpolation_between_nodes():
    """Linear between nodes, constant outside (the documented convention)."""
    m = machine("XYFZ").scaled(0.0)
    m.nodes[0] = np.array([0.0, 100.0, 300.0])
    m.values[0] = np.array([[0, 0, 0, 0, 0, 0], [2, 0, 0, 0, 0, 0], [-2, 0, 0, 0, 0, 0.0]])
    v = m.function("EXX", [-50, 0, 50, 100, 200, 300, 400])
    np.testing.assert_allclose(v, [0, 0, 1, 2, 0, -2, -2])
    np.testing.assert_allclose(m.component(0, [150.0])[0], [1, 0, 0, 0, 0, 0])
