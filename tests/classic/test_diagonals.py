import numpy as np
import pytest

from volcal.classic.diagonals import (
    body_diagonal_code,
    diagonal_check,
    soons_combinations,
    soons_from_measurements,
)
from volcal.errors import VolcalInputError
from volcal.measure.readings import reading_first_order
from volcal.measure.virtual import random_machine
from volcal.model.errorfunctions import MachineErrors
from volcal.plan.planner import plan_session

from .conftest import TRAVEL, no_angles


def _diagonals(machine, chain="XYFZ", tool_offset=(0.0, 0.0, 0.0)):
    s = plan_session(TRAVEL, chain, 10, tests=("diagonal",), tool_offset=tool_offset)
    for m in s.measurements:
        m.deviation = reading_first_order(machine, m)
    return s


def test_quick_check_numbers():
    truth = random_machine(TRAVEL, "XYFZ", 2)
    s = _diagonals(truth)
    checks = diagonal_check(s.measurements)
    assert [c.id for c in checks] == ["diag-ppp", "diag-npp", "diag-pnp", "diag-ppn"]
    for c, m in zip(checks, s.measurements, strict=True):
        assert c.max_abs_um == pytest.approx(np.abs(m.deviation).max())
        assert c.range_um == pytest.approx(m.deviation.max() - m.deviation.min())
        assert c.length_mm == pytest.approx(np.sqrt(800**2 + 600**2 + 500**2))


def test_pure_squareness_hand_value():
    # only EC0Y = 100 urad: e_x = -EC0Y*y*1e-3; ppp end: n_x * (-0.1 um/mm * 600 mm)
    m = MachineErrors.zero("XYFZ", TRAVEL)
    m.squareness[:] = [100.0, 0.0, 0.0]
    s = _diagonals(m)
    D = np.sqrt(800**2 + 600**2 + 500**2)
    assert s.measurements[0].deviation[-1] == pytest.approx(800 / D * (-60.0))
    r = soons_from_measurements(s.measurements)
    np.testing.assert_allclose(r.squareness_urad, [100.0, 0.0, 0.0], atol=1e-9)
    assert r.positioning_um == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("chain, seed", [("XYFZ", 1), ("FXYZ", 2), ("XFYZ", 3)])
def test_combinations_exact_without_angular_errors(chain, seed):
    truth = no_angles(random_machine(TRAVEL, chain, seed))
    r = soons_from_measurements(_diagonals(truth, chain).measurements)
    np.testing.assert_allclose(r.squareness_urad, truth.squareness, atol=1e-9)
    n = (TRAVEL[:, 1] - TRAVEL[:, 0]) / np.linalg.norm(TRAVEL[:, 1] - TRAVEL[:, 0])
    ends = [truth.function(f"E{a}{a}", [TRAVEL[k, 1]])[0] for k, a in enumerate("XYZ")]
    assert r.positioning_um == pytest.approx(float(n @ ends), abs=1e-9)


def test_angular_terms_follow_the_lever_rule_for_chain_xyz():
    # For the order X, Y, Z with zero tool offset the Abbe term of diagonal s is
    # n . [eps_X(x) x (0, y, z) + eps_Y(y) x (0, 0, z)] between the end corners.
    # Only X's yaw/pitch and Y's pitch contribute; check one rotation at a time:
    # ECX = c at x1 (0 at x0), others zero -> e_x = -c*y*1e-3 where x = x1.
    m = MachineErrors.zero("XYFZ", TRAVEL)
    m.values[0][1, 5] = 50.0  # ECX(x1) = 50 urad
    r = soons_from_measurements(_diagonals(m).measurements)
    # ppp: start (0,0,0)->(800,600,500): dD = n_x*(-50*600e-3)
    # npp: (800,0,0)->(0,600,500): e(start) = -50*0 ; e(end) at x0: 0 -> dD = 0
    # pnp: (0,600,0)->(800,0,500): e(end) = -50*0 = 0 -> dD = 0
    # ppn: (0,0,500)->(800,600,0): dD = n_x*(-50*600e-3)
    D = np.sqrt(800**2 + 600**2 + 500**2)
    nx, ny = 800 / D, 600 / D
    dppp = nx * (-30.0)
    # EC0Y estimate: -(ppp - 0 - 0 + ppn)/(4 D nx ny)*1e3 = 50/2 = 25 urad bias
    assert r.squareness_urad[0] == pytest.approx(-(2 * dppp) / (4 * D * nx * ny) * 1e3)
    assert r.squareness_urad[0] == pytest.approx(25.0)
    assert r.positioning_um == pytest.approx(dppp / 2)


def test_reversed_diagonal_and_missing_one():
    truth = no_angles(random_machine(TRAVEL, "XYFZ", 7))
    s = _diagonals(truth)
    ref = soons_from_measurements(s.measurements)
    m = s.measurements[1]
    m.positions = m.positions[::-1].copy()
    m.deviation = (m.deviation[::-1] - m.deviation[-1]).copy()
    assert body_diagonal_code(m) == ("npp", -1.0)
    again = soons_from_measurements(s.measurements)
    np.testing.assert_allclose(again.squareness_urad, ref.squareness_urad, atol=1e-9)
    with pytest.raises(VolcalInputError, match="missing body diagonal"):
        soons_from_measurements(s.measurements[:3])
    with pytest.raises(ValueError, match="missing"):
        soons_combinations({"ppp": 1.0}, [1, 1, 1])
