"""5-axis chains: codes, exact pose, hand-worked signs, Jacobian vs finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import machine
from volcal.errors import VolcalInputError
from volcal.model.chain import parse_machine_chain
from volcal.model.fiveaxis import (
    FiveAxisMachine,
    exact_pose5,
    location_parameter_names,
    pose_jacobian5,
)
from volcal.model.kinematics import exact_pose
from volcal.model.names import describe, info
from volcal.model.rotary import RotaryAxis

CHAINS = ("CAFXYZ", "BCFXYZ", "CFXYZB", "AFXYZ", "FXYZCA", "FXYZCB", "XCFYZ", "CXYFZA")


def random_rotary(code: str, rng, pivot_um=1000.0, tilt_urad=200.0, components=True,
                  linear=None) -> FiveAxisMachine:
    """A machine with random location errors (and component errors over 4 nodes)."""
    c = parse_machine_chain(code)
    rot = {}
    for r in c.rotary:
        names = RotaryAxis(r).location_names
        loc = {n: rng.normal(0, pivot_um if i < 2 else tilt_urad) for i, n in enumerate(names)}
        nodes = np.array([0.0, 90.0, 180.0, 270.0])
        vals = (rng.normal(0, 3, (4, 6)) * np.array([1, 1, 1, 10, 10, 10])
                if components else np.zeros((4, 6)))
        rot[r] = RotaryAxis(r, rng.normal(0, 100, 3), loc, nodes, vals)
    return FiveAxisMachine(code, rot, linear)


def test_chain_codes():
    c = parse_machine_chain("cafxyz")
    assert c.letters == ("C", "A", "X", "Y", "Z")
    assert c.rotary == ("C", "A") and c.linear.code == "FXYZ" and c.frame_index == 2
    assert c.kind == "table-table"
    assert parse_machine_chain("CFXYZB").kind == "table-head"
    assert parse_machine_chain("FXYZCA").kind == "head-head"
    assert parse_machine_chain("XYFZ").kind == "linear"
    assert parse_machine_chain("CXYFZ").linear.order == (0, 1, 2)
    for bad in ("CCFXYZ", "CAFXY", "DFXYZ", "CAXYZ", 5):
        with pytest.raises(VolcalInputError, match="chain code"):
            parse_machine_chain(bad)


def test_location_names_iso():
    assert location_parameter_names("CAFXYZ") == (
        "EX0C", "EY0C", "EA0C", "EB0C", "EC0C", "EY0A", "EZ0A", "EB0A", "EC0A", "EA0A")
    assert location_parameter_names("FXYZB") == ("EX0B", "EZ0B", "EA0B", "EC0B", "EB0B")
    assert info("EX0C").unit == "um" and info("EB0C").unit == "urad"
    assert info("EC0C").kind == "zero" and info("EA0C").kind == "orientation"
    assert info("EYC").kind == "radial" and info("EZC").kind == "axial"
    assert info("ECC").kind == "angular positioning" and info("EAC").kind == "tilt"
    assert describe("EY0A") == "EY0A (position of the A axis average line in Y)"


def test_linear_numbers_unchanged(rng):
    """Without rotary axes (or with them at zero, error free) the pose is the linear model's."""
    lin = machine("XYFZ", seed=3, scale=30.0)
    q = rng.uniform([0, 0, 0], [800, 600, 500], (20, 3))
    t = np.array([10.0, -20.0, 150.0])
    p_lin, R_lin = exact_pose(lin, q, t)
    for code in ("XYFZ", "CXYFZB"):
        m = FiveAxisMachine(code, linear=lin)
        p, R = exact_pose5(m, q, None, t)
        np.testing.assert_allclose(p, p_lin, atol=1e-12)
        np.testing.assert_allclose(R, R_lin, atol=1e-15)


def test_nominal_table_rotation_hand_value():
    """A table C at +90 deg turns the tool relative to the workpiece by +90 deg about its pivot."""
    p = np.array([100.0, 50.0, 0.0])
    m = FiveAxisMachine("CFXYZ", {"C": RotaryAxis("C", p)})
    pos, R = exact_pose5(m, p + [10.0, 0, 0], {"C": 90.0})
    np.testing.assert_allclose(pos[0], p + [0.0, 10.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(R[0], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)


_S2 = np.sin(2e-4) * 1e5  # 100 mm [um] turned by 2 x 100 urad
_C2 = 2e5 * np.sin(1e-4) ** 2  # its second-order drop along the line [um]


@pytest.mark.parametrize(("name", "value", "angle", "point", "expected_um"), [
    # the tool on the nominal pivot at 180 deg: twice the position error
    ("EX0C", 5.0, 180.0, [0, 0, 0], [10.0, 0, 0]),
    ("EY0C", 5.0, 180.0, [0, 0, 0], [0, 10.0, 0]),
    # a point 100 mm up the nominal line, the line leaning towards +X by EB0C = 100 urad:
    # turned by 180 deg about the leaning line it lands 2 x 100 urad x 100 mm = 20 um on +X
    ("EB0C", 100.0, 180.0, [0, 0, 100], [_S2, 0, -_C2]),
    # leaning towards -Y by EA0C = 100 urad
    ("EA0C", 100.0, 180.0, [0, 0, 100], [0, -_S2, -_C2]),
    # zero error: a point 100 mm out on X turns by EC0C = 100 urad: 10 um towards +Y
    ("EC0C", 100.0, 0.0, [100, 0, 0], [-1e5 * (1 - np.cos(1e-4)), 1e5 * np.sin(1e-4), 0]),
])
def test_location_error_signs_hand_values(name, value, angle, point, expected_um):
    ok = FiveAxisMachine("CFXYZ", {"C": RotaryAxis("C")})
    bad = FiveAxisMachine("CFXYZ", {"C": RotaryAxis("C", location={name: value})})
    p0, _ = exact_pose5(ok, np.array(point, float), {"C": angle})
    p1, _ = exact_pose5(bad, np.array(point, float), {"C": angle})
    np.testing.assert_allclose((p1 - p0)[0] * 1e3, expected_um, atol=1e-5)


def test_periodic_component_interpolation():
    ax = RotaryAxis("C", nodes_deg=[0.0, 90.0, 180.0, 270.0],
                    values=np.arange(24.0).reshape(4, 6))
    v = ax.component([315.0, 360.0, -45.0, 45.0])
    np.testing.assert_allclose(v[0], 0.5 * (np.arange(18, 24) + np.arange(0, 6)))
    np.testing.assert_allclose(v[1], np.arange(6.0))
    np.testing.assert_allclose(v[2], v[0])
    np.testing.assert_allclose(v[3], 0.5 * (np.arange(6) + np.arange(6, 12)))
    lim = RotaryAxis("A", nodes_deg=[-90.0, 90.0], values=np.arange(12.0).reshape(2, 6),
                     full_circle=False)
    np.testing.assert_allclose(lim.component([-120.0, 0.0, 120.0]),
                               [np.arange(6), np.arange(3, 9), np.arange(6, 12)])


def _rotvec_of(dR, R0):
    W = np.einsum("mij,mkj->mik", dR, R0)
    return np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], 1)


@pytest.mark.parametrize("code", CHAINS)
def test_jacobian_matches_finite_differences(code):
    """Location and component Jacobian at a machine with large errors (pivot ~1 mm)."""
    rng = np.random.default_rng(sum(map(ord, code)))
    m = random_rotary(code, rng, linear=machine(parse_machine_chain(code).linear.code,
                                                 seed=1, scale=10.0))
    q = rng.uniform([0, 0, 0], [800, 600, 500], (6, 3))
    ang = {r: rng.uniform(-150, 150, 6) for r in m.chain_obj.rotary}
    t = np.array([5.0, -3.0, 120.0])
    J = pose_jacobian5(m, q, ang, t, components=True)
    _, R0 = exact_pose5(m, q, ang, t)
    x0 = m.location_vector()
    h = 1e-2
    for j in range(x0.size):
        xp, xm = x0.copy(), x0.copy()
        xp[j] += h
        xm[j] -= h
        pp, Rp = exact_pose5(m.with_location(xp), q, ang, t)
        pm, Rm = exact_pose5(m.with_location(xm), q, ang, t)
        np.testing.assert_allclose((pp - pm) / (2 * h) * 1e3, J.position[:, :, j], atol=2e-7,
                                   err_msg=J.names[j])
        np.testing.assert_allclose(_rotvec_of((Rp - Rm) / (2 * h), R0) * 1e6,
                                   J.orientation[:, :, j], atol=2e-7, err_msg=J.names[j])
    # component nodes: perturb the table value
    for j, name in enumerate(J.names[x0.size:], start=x0.size):
        letter = name[2]
        comp, node = name.split("@")
        ax = m.rotary[letter]
        col = ax.component_names.index(comp)
        row = list(ax.nodes_deg).index(float(node))
        out = []
        for s in (1, -1):
            vals = ax.values.copy()
            vals[row, col] += s * h
            rot = dict(m.rotary)
            rot[letter] = RotaryAxis(letter, ax.pivot_mm, ax.location, ax.nodes_deg, vals)
            out.append(exact_pose5(FiveAxisMachine(m.chain, rot, m.linear), q, ang, t))
        np.testing.assert_allclose((out[0][0] - out[1][0]) / (2 * h) * 1e3, J.position[:, :, j],
                                   atol=2e-7, err_msg=name)
        np.testing.assert_allclose(_rotvec_of((out[0][1] - out[1][1]) / (2 * h), R0) * 1e6,
                                   J.orientation[:, :, j], atol=2e-7, err_msg=name)


@pytest.mark.parametrize("code", ("CAFXYZ", "CFXYZB", "FXYZCA"))
def test_first_order_model_is_second_order_accurate(code):
    """Exact minus nominal equals J x to second order: halving the errors quarters the gap."""
    rng = np.random.default_rng(7)
    m = random_rotary(code, rng, components=False)
    nominal = FiveAxisMachine(code, {r: RotaryAxis(r, m.rotary[r].pivot_mm)
                                     for r in m.chain_obj.rotary})
    q = rng.uniform(-300, 300, (10, 3))
    ang = {r: rng.uniform(-180, 180, 10) for r in m.chain_obj.rotary}
    t = np.array([0.0, 0.0, 100.0])
    J = pose_jacobian5(nominal, q, ang, t)
    p0, _ = exact_pose5(nominal, q, ang, t)
    gaps = []
    for s in (1.0, 0.5):
        x = m.location_vector() * s
        p, _ = exact_pose5(nominal.with_location(x), q, ang, t)
        gaps.append(np.abs((p - p0) * 1e3 - J.position @ x).max())
    assert gaps[0] > 1e-4
    assert gaps[0] / gaps[1] == pytest.approx(4.0, rel=0.05)
