import numpy as np
import pytest

from volcal.classic.abbe import abbe_design, abbe_lines, rotation_names
from volcal.measure.readings import reading_first_order
from volcal.measure.virtual import random_machine
from volcal.model.kinematics import first_order_pose
from volcal.plan.geometry import linear_test
from volcal.session.format import Measurement

from .conftest import TRAVEL


def _line(axis, at, tool_offset=(0.0, 0.0, 0.0), steps=10):
    g = linear_test(axis, TRAVEL, steps, at)
    return Measurement(f"l{axis}", "linear", "retroreflector", g.positions, None,
                       g.beam_direction, np.asarray(tool_offset, float))


def test_lever_rule_matches_the_kinematic_model():
    # d = E + [eps x dL]_k with dL along the other two axes, for every axis
    full = random_machine(TRAVEL, "XYFZ", 5)
    rng = np.random.default_rng(1)
    for k in range(3):
        m = full.copy()  # only axis k rotates: its effect alone
        for j in range(3):
            if j != k:
                m.values[j][:, 3:] = 0.0
        q = rng.uniform(0, 500, (7, 3))
        dl = rng.uniform(-300, 300, 3)
        dl[k] = 0.0
        e0, _ = first_order_pose(m, q, (0.0, 0.0, 0.0))
        e1, _ = first_order_pose(m, q, dl)
        a, b = [j for j in range(3) if j != k]
        A = abbe_design(np.tile(dl[[a, b]], (7, 1)), k)
        rot = m.component(k, q[:, k])[:, [3 + a, 3 + b]]
        np.testing.assert_allclose(e1[:, k] - e0[:, k], (A[:, 1:] * rot).sum(1), atol=1e-12)


def test_hand_example_x():
    # EXX = 2 um, EBX = 10 urad, ECX = -4 urad at one target
    # reference: 2; y + 600: 2 - (-4)*0.6 = 4.4; z + 500: 2 + 10*0.5 = 7
    pos, rot = abbe_lines([[2.0], [4.4], [7.0]], [[0, 0], [600, 0], [0, 500]], "X")
    np.testing.assert_allclose(pos, [2.0], atol=1e-12)
    np.testing.assert_allclose(rot, [[10.0, -4.0]], atol=1e-12)
    assert rotation_names("X") == ("EBX", "ECX")


def test_hand_example_y_and_z_signs():
    # Y: d = EYY - EAY*dz + ECY*dx ; EYY=1, EAY=2, ECY=3, lines dx=100 and dz=200
    pos, rot = abbe_lines([[1.0], [1.0 + 0.3], [1.0 - 0.4]], [[0, 0], [100, 0], [0, 200]], "Y")
    np.testing.assert_allclose(rot, [[2.0, 3.0]], atol=1e-12)
    # Z: d = EZZ + EAZ*dy - EBZ*dx ; EZZ=-1, EAZ=5, EBZ=-2
    pos, rot = abbe_lines([[-1.0], [-1.0 + 0.2 * 100 / 100 * 2], [-1.0 + 5 * 0.1]],
                          [[0, 0], [200, 0], [0, 100]], "Z")
    np.testing.assert_allclose(pos, [-1.0], atol=1e-12)
    np.testing.assert_allclose(rot, [[5.0, -2.0]], atol=1e-12)
    assert rotation_names("Y") == ("EAY", "ECY") and rotation_names("Z") == ("EAZ", "EBZ")


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ", "XFYZ", "YFXZ"])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_exact_recovery_from_first_order_lines(chain, axis):
    # lever arms varied through the tool offset: valid for every axis and chain
    m = random_machine(TRAVEL, chain, 11 + axis)
    a, b = [j for j in range(3) if j != axis]
    offsets = np.array([[0.0, 0.0], [250.0, 0.0], [0.0, 180.0]])
    devs = []
    for off in offsets:
        t = np.zeros(3)
        t[[a, b]] = off
        devs.append(reading_first_order(m, _line(axis, TRAVEL[:, 0], t)))
    pos, rot = abbe_lines(np.array(devs), offsets, axis)
    q = _line(axis, TRAVEL[:, 0]).positions[:, axis]
    truth = m.component(axis, q)
    # reference line: at the travel start with zero tool offset -> lever arm of the
    # downstream axes at their start; every chain starts at 0 here, so E is the reading
    ref = reading_first_order(m, _line(axis, TRAVEL[:, 0]))
    np.testing.assert_allclose(pos, ref, atol=1e-9)
    np.testing.assert_allclose(pos, truth[:, axis], atol=1e-9)
    np.testing.assert_allclose(rot, truth[:, [3 + a, 3 + b]], atol=1e-9)


def test_x_lines_at_machine_positions_xyfz():
    # the seed's set-up: X measured at the reference edge, at y = 600 and at z = 500
    m = random_machine(TRAVEL, "XYFZ", 3)
    lines = [(0, 0), (600, 0), (0, 500)]
    devs = [reading_first_order(m, _line(0, (0, y, z))) for y, z in lines]
    pos, rot = abbe_lines(np.array(devs), lines, "X")
    q = _line(0, (0, 0, 0)).positions[:, 0]
    np.testing.assert_allclose(pos, m.function("EXX", q), atol=1e-9)
    np.testing.assert_allclose(rot[:, 0], m.function("EBX", q), atol=1e-9)
    np.testing.assert_allclose(rot[:, 1], m.function("ECX", q), atol=1e-9)


def test_least_squares_with_four_lines():
    m = random_machine(TRAVEL, "FXYZ", 8)
    lines = np.array([(0, 0), (600, 0), (0, 500), (600, 500)], float)
    clean = np.array([reading_first_order(m, _line(0, (0, y, z))) for y, z in lines])
    q = _line(0, (0, 0, 0)).positions[:, 0]
    pos, rot = abbe_lines(clean, lines, "X")
    np.testing.assert_allclose(pos, m.function("EXX", q), atol=1e-9)
    np.testing.assert_allclose(rot, np.column_stack([m.function("EBX", q),
                                                     m.function("ECX", q)]), atol=1e-9)
    # a disturbance orthogonal to the design leaves the LS solution unchanged, and the
    # solution equals the normal equations' one for an arbitrary disturbance
    A = abbe_design(lines, "X")
    u, s, vt = np.linalg.svd(A)
    null = u[:, 3]
    p2, r2 = abbe_lines(clean + 3.0 * null[:, None], lines, "X")
    np.testing.assert_allclose(p2, pos, atol=1e-9)
    np.testing.assert_allclose(r2, rot, atol=1e-9)
    noise = np.random.default_rng(0).normal(0, 0.5, clean.shape)
    p3, r3 = abbe_lines(clean + noise, lines, "X")
    ne = np.linalg.solve(A.T @ A, A.T @ (clean + noise))
    np.testing.assert_allclose(p3, ne[0], atol=1e-9)
    np.testing.assert_allclose(r3, ne[1:].T, atol=1e-9)


@pytest.mark.parametrize("offsets, word", [
    ([[0, 0], [0, 0], [0, 0]], "same Abbe offset"),
    ([[0, 0], [100, 100], [300, 300]], "collinear"),
    ([[0, 0], [100, 0], [250, 0]], "collinear"),
    ([[0, 0], [0, 100], [0, 250], [0, 400]], "collinear"),
])
def test_degenerate_offsets_raise(offsets, word):
    d = np.zeros((len(offsets), 4))
    with pytest.raises(ValueError, match=word):
        abbe_lines(d, offsets, "Y")


def test_bad_shapes_raise():
    with pytest.raises(ValueError, match="at least 3"):
        abbe_lines(np.zeros((2, 3)), [[0, 0], [1, 0]], "X")
    with pytest.raises(ValueError, match="offsets"):
        abbe_lines(np.zeros((3, 3)), [[0, 0], [1, 0]], "X")
    with pytest.raises(ValueError, match="axis"):
        abbe_lines(np.zeros((3, 3)), [[0, 0], [1, 0], [0, 1]], "W")
    with pytest.raises(ValueError, match="finite"):
        abbe_lines(np.full((3, 2), np.nan), [[0, 0], [1, 0], [0, 1]], "X")


def _printed_closed_form(dx, m, p):
    """Seed 000 section 6 / seed 001 as printed (with the numerator's parentheses restored)."""
    (m1, m2, m3), (p1, p2, p3) = m, p
    den = (m3 - m1) * (p2 - p1) - (m2 - m1) * (p3 - p1)
    ay = ((m3 - m1) * (dx[1] - dx[0]) - (m2 - m1) * (dx[2] - dx[0])) / den
    az = ((p3 - p1) * (dx[1] - dx[0]) - (p2 - p1) * (dx[2] - dx[0])) / den
    d = (dx[0] * (m2 * p3 - m3 * p2) + dx[1] * (m3 * p1 - m1 * p3)
         + dx[2] * (m1 * p2 - m2 * p1)) / den
    return d, ay, az


def test_seed_closed_forms_are_wrong_even_for_their_own_model():
    # Wang eq. 23 model, taken literally: DX = Dx + m*Ay + p*Az (m, p in the angle's units)
    dxx, ay, az = 1.0, 2.0, 3.0
    m = (10.0, 40.0, 15.0)
    p = (5.0, 8.0, 30.0)
    dx = [dxx + mi * ay + pi * az for mi, pi in zip(m, p, strict=True)]
    d, ay_p, az_p = _printed_closed_form(dx, m, p)
    # the printed "Ay" is the true Az, the printed "Az" is minus the true Ay, and the
    # positioning has the denominator's sign flipped
    assert ay_p == pytest.approx(az)
    assert az_p == pytest.approx(-ay)
    assert d == pytest.approx(-dxx)
    # the linear-system solution of the same model is right (Cramer == solve)
    A = np.column_stack([np.ones(3), m, p])
    np.testing.assert_allclose(np.linalg.solve(A, dx), [dxx, ay, az])


def test_seed_eq23_pairing_contradicts_the_model():
    # eq. 23 pairs the y offset m with pitch Ay(x) = EBX; the model pairs it with -ECX.
    m_ = random_machine(TRAVEL, "XYFZ", 4)
    q = _line(0, (0, 0, 0)).positions[:, 0]
    d_y = reading_first_order(m_, _line(0, (0, 600, 0))) - reading_first_order(
        m_, _line(0, (0, 0, 0)))
    np.testing.assert_allclose(d_y, -m_.function("ECX", q) * 0.6, atol=1e-9)
    assert np.abs(d_y - m_.function("EBX", q) * 0.6).max() > 1.0
