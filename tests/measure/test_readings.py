"""Laser reading models: exact vs first order, Soons eq. (2) and (4), tool orientation."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import TRAVEL, machine, meas, only
from volcal.measure.readings import (
    SetupErrors,
    perpendicular_basis,
    reading_exact,
    reading_first_order,
    reading_jacobian,
)
from volcal.model.parameters import ParameterLayout
from volcal.plan.geometry import diagonal_test, step_diagonal_test


def _step(code="ppp", steps=6, order="xyz", target="flat_mirror", t=(0, 0, 0)):
    g = step_diagonal_test(code, TRAVEL, steps, order)
    return meas(g.positions, target, g.beam_direction, t)


def _equivalent_tilt(m, ms, setup: SetupErrors) -> np.ndarray:
    """First-order set-up tilt [urad] along perpendicular_basis(n) of an exact set-up.

    Beam aligned to the actual motion from the first to the farthest reading: the beam
    turns by delta = (e_far - e_0)_perp / |d|; beam tilt beta and mirror tilt mu turn the
    sensitive direction by beta x n and (flat mirror) mu x n.
    """
    from volcal.model.kinematics import first_order_pose

    n = ms.beam_direction
    q = ms.positions
    e, _ = first_order_pose(m, q, ms.tool_offset)
    far = int(np.argmax(np.linalg.norm(q - q[0], axis=1)))
    de = (e[far] - e[0]) * 1e-3  # mm
    delta = (de - (de @ n) * n) / np.linalg.norm(q[far] - q[0])
    tau = (delta if setup.align_beam else 0.0) + np.cross(setup.beam_tilt * 1e-6, n)
    if ms.target == "flat_mirror":
        tau = tau + np.cross(setup.mirror_tilt * 1e-6, n)
    return perpendicular_basis(n) @ tau * 1e6


@pytest.mark.parametrize("chain", ["FXYZ", "XYFZ", "YFXZ", "ZFYX"])
@pytest.mark.parametrize("target", ["flat_mirror", "retroreflector"])
@pytest.mark.parametrize("aligned", [False, True])
def test_readings_agree_to_second_order(chain, target, aligned, rng):
    """Halving every error (machine and set-up) quarters exact minus first order."""
    code = ["ppp", "npp", "pnp", "ppn"][hash(chain) % 4]
    ms = _step(code, 5, "yzx", target, rng.uniform(-150, 150, 3))
    big = machine(chain, seed=len(chain) + ord(chain[0]), scale=20.0)
    n = ms.beam_direction
    B = perpendicular_basis(n)
    setup = SetupErrors(mirror_tilt=400.0 * B[0] - 300.0 * B[1],
                        beam_tilt=(200.0 * B[1] if aligned else np.zeros(3)),
                        align_beam=aligned)
    diffs = []
    for f in (1.0, 0.5):
        m = big.scaled(f)
        s = SetupErrors(setup.mirror_tilt * f, setup.beam_tilt * f, aligned)
        tilt = _equivalent_tilt(m, ms, s)
        d = reading_exact(m, ms, s) - reading_first_order(m, ms, tilt)
        diffs.append(np.abs(d).max())
    assert diffs[0] > 1e-4
    assert diffs[0] / diffs[1] == pytest.approx(4.0, rel=0.05)


def _soons_eq1(m, q):
    """Soons eq. (1), chain FXYZ, written out [um] and [urad] (S_xy=EC0Y, S_xz=-EB0Z, S_yz=EA0Z)."""
    x, y, z = q.T
    f = {n: m.function(n, q[:, "XYZ".index(n[-1])]) for n in
         ("EXX", "EYX", "EZX", "EAX", "EBX", "ECX", "EXY", "EYY", "EZY", "EAY", "EBY", "ECY",
          "EXZ", "EYZ", "EZZ", "EAZ", "EBZ", "ECZ")}
    k = 1e-3  # urad * mm -> um
    s_xy, s_xz, s_yz = m.squareness[0], -m.squareness[1], m.squareness[2]
    e = np.c_[f["EXX"] + f["EXY"] + f["EXZ"] + k * (f["EBX"] + f["EBY"] - s_xz) * z
              - k * (f["ECX"] + s_xy) * y,
              f["EYX"] + f["EYY"] + f["EYZ"] - k * (f["EAX"] + f["EAY"] + s_yz) * z,
              f["EZX"] + f["EZY"] + f["EZZ"] + k * f["EAX"] * y]
    w = np.c_[f["EAX"] + f["EAY"] + f["EAZ"], f["EBX"] + f["EBY"] + f["EBZ"],
              f["ECX"] + f["ECY"] + f["ECZ"]]
    return e, w


@pytest.mark.parametrize("code", ["ppp", "npp", "pnp", "ppn"])
def test_soons_eq2_and_eq4(code):
    """Soons eq. (2) (retroreflector) and eq. (4) (mirror), written out from the paper.

    Mirror: dd13 = n . [e(p3) - e(p1) + (eps(p3) + e_m) x (p1 - p3)], with e_m the mirror
    misalignment relative to the machine axes. Our mirror is aligned to the beam at the
    first reading plus a residual tilt mu: e_m = mu - eps(p1).
    """
    m = machine("FXYZ", seed=11)
    g = step_diagonal_test(code, TRAVEL, 8, "xyz")
    n, q = g.beam_direction, g.positions
    e, w = _soons_eq1(m, q)
    mu = 25.0 * perpendicular_basis(n)[1]  # [urad]
    e_m = mu - w[0]
    p1_p3 = q[0] - q  # [mm]
    mirror = (e - e[0]) @ n + np.cross((w + e_m) * 1e-3, p1_p3) @ n
    retro = (e - e[0]) @ n  # eq. (2); eq. (4) with no return mirror
    tilt = perpendicular_basis(n) @ np.cross(mu * 1e-6, n) * 1e6
    ms = meas(q, "flat_mirror", n)
    np.testing.assert_allclose(reading_first_order(m, ms, tilt), mirror, atol=1e-9)
    ex = reading_exact(m, ms, SetupErrors(mu, np.zeros(3), align_beam=False))
    np.testing.assert_allclose(ex, mirror, atol=0.01)  # second-order remainder < 10 nm
    mr = meas(q, "retroreflector", n)
    np.testing.assert_allclose(reading_first_order(m, mr), retro, atol=1e-9)
    ex = reading_exact(m, mr, SetupErrors(np.zeros(3), np.zeros(3), align_beam=False))
    np.testing.assert_allclose(ex, retro, atol=0.01)
    # the mirror term is real: it changes the readings by micrometres here
    assert np.abs(mirror - retro).max() > 1.0


@pytest.mark.parametrize("name", ["EAZ", "EBZ", "ECZ", "ECY"])
def test_tool_orientation_changes_mirror_not_retroreflector(name):
    """Soons section 2: errors that only turn the tool (Z angles, Y yaw in FXYZ, no tool
    offset) change flat-mirror step-diagonal readings off the diagonal, never on it, and
    leave a retroreflector reading unchanged."""
    base = machine("FXYZ", seed=1).scaled(0.0)
    nodes = base.nodes["XYZ".index(name[-1])]
    prof = 30.0 * np.sin(np.pi * (nodes - nodes[0]) / np.ptp(nodes))  # [urad]
    m = only(base, {name: prof})
    g = step_diagonal_test("ppp", TRAVEL, 10, "xyz")
    setup = SetupErrors.none()
    retro = reading_exact(m, meas(g.positions, "retroreflector", g.beam_direction), setup)
    mirror = reading_exact(m, meas(g.positions, "flat_mirror", g.beam_direction), setup)
    np.testing.assert_allclose(retro, 0.0, atol=1e-9)
    on_diag = np.arange(0, g.positions.shape[0], 3)
    off_diag = np.setdiff1d(np.arange(g.positions.shape[0]), on_diag)
    np.testing.assert_allclose(mirror[on_diag], 0.0, atol=1e-9)
    assert np.abs(mirror[off_diag]).max() > 0.5  # um
    # first order: n . (d_omega x (q0 - q)), by hand at the first off-diagonal point
    n, q = g.beam_direction, g.positions
    w = np.zeros(3)
    w["ABC".index(name[1])] = m.function(name, q[1:2, "XYZ".index(name[-1])])[0] - \
        m.function(name, q[0:1, "XYZ".index(name[-1])])[0]
    hand = n @ np.cross(w * 1e-3, q[0] - q[1])
    assert mirror[1] == pytest.approx(hand, abs=1e-4)


@pytest.mark.parametrize("target", ["flat_mirror", "retroreflector"])
@pytest.mark.parametrize("chain", ["XYFZ", "FYZX"])
def test_reading_jacobian_is_finite_difference(target, chain, rng):
    m = machine(chain, seed=8, n_nodes=6)
    lay = ParameterLayout(tuple(m.nodes))
    ms = _step("pnp", 4, "zxy", target, rng.uniform(-80, 80, 3))
    A = reading_jacobian(m.chain_obj.order, m.nodes, ms).toarray()
    theta = lay.pack(m)
    r0 = reading_first_order(m, ms)
    np.testing.assert_allclose(A @ theta, r0, atol=1e-9)
    for j in range(lay.size):
        th = theta.copy()
        th[j] += 1.0
        r1 = reading_first_order(lay.unpack(th, chain), ms)
        np.testing.assert_allclose(r1 - r0, A[:, j], atol=1e-9)


def test_diagonal_retroreflector_first_reading_zero_and_length():
    """Deviation counted from the first row; a pure X scale error reads n_x^2-weighted."""
    g = diagonal_test("ppp", TRAVEL, 4)
    base = machine("FXYZ").scaled(0.0)
    nodes = base.nodes[0]
    m = only(base, {"EXX": 10.0 * (nodes - nodes[0]) / 800.0})  # 10 um over 800 mm
    ms = meas(g.positions, "retroreflector", g.beam_direction, kind="diagonal")
    r = reading_exact(m, ms, SetupErrors.none())
    assert r[0] == 0.0
    # n . e with e = (10 um * x/800, 0, 0), along the diagonal: n_x * 10 * s
    s = np.linspace(0, 1, 5)
    np.testing.assert_allclose(r, g.beam_direction[0] * 10.0 * s, atol=1e-4)
