"""VDI/DGQ 3441, straightness/squareness, ISO 230-6 and volumetric indices: hand values."""

import numpy as np
import pytest
from test_iso230_2 import cycle

from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import volumetric_error
from volcal.session.format import Measurement
from volcal.standards import vdi3441
from volcal.standards.iso230_6 import elv, evaluate_diagonal
from volcal.standards.straightness import squareness_from_lines, straightness
from volcal.standards.volumetric import elv_from_model, volumetric_indices


def test_vdi3441_hand_values():
    # U_j = |B_j| = [2, 2, 1, 1, 3]; sbar = [0.75, 0.75, 0.75, 1, 1.5]; Ps_j = 6 sbar
    # mean = [-1, 2, 4.5, 2.5, -2.5]; half = (U + Ps)/2 = [3.25, 3.25, 2.75, 3.5, 6]
    # P = max(mean + half) - min(mean - half) = 7.25 - (-8.5) = 15.75
    r = vdi3441.evaluate(*cycle())
    assert r.P == pytest.approx(15.75)
    assert r.Pa == pytest.approx(7.0)
    assert r.Ps == pytest.approx(9.0) and r.Ps_mean == pytest.approx(5.7)
    assert r.U == pytest.approx(3.0) and r.U_mean == pytest.approx(1.8)


def test_straightness_references_by_hand():
    s = [0, 100, 200, 300, 400]
    d = [0, 2, 1, 3, 0]
    ep = straightness(s, d, "end_point")
    assert ep.straightness_um == pytest.approx(3.0) and ep.slope_urad == pytest.approx(0.0)
    # LS: Sxy = 100, Sxx = 1e5 -> slope 1e-3 um/mm = 1 urad, intercept 1.0
    # residuals [-1, 0.9, -0.2, 1.7, -1.4] -> range 3.1
    ls = straightness(s, d)
    assert ls.slope_urad == pytest.approx(1.0)
    assert ls.intercept_um == pytest.approx(1.0)
    assert ls.straightness_um == pytest.approx(3.1)
    with pytest.raises(VolcalInputError, match="reference"):
        straightness(s, d, "minimum_zone_please")


def test_squareness_recovered_from_model():
    m = MachineErrors.zero("XYFZ", [[0, 800], [0, 600], [0, 500]])
    m.squareness = np.array([50.0, 0.0, 0.0])  # EC0Y = 50 urad
    x = np.linspace(0, 800, 9)
    y = np.linspace(0, 600, 7)
    ex = volumetric_error(m, np.c_[x, np.full_like(x, 300), np.zeros_like(x)])
    ey = volumetric_error(m, np.c_[np.full_like(y, 400), y, np.zeros_like(y)])
    # X line: deviation toward Y; Y line: deviation toward X
    assert squareness_from_lines(x, ex[:, 1], y, ey[:, 0]) == pytest.approx(50.0, abs=1e-6)


def test_volumetric_indices_by_hand():
    m = MachineErrors.zero("XYFZ", [[0, 800], [0, 600], [0, 500]])
    m.squareness = np.array([10.0, 20.0, 4.0])  # EC0Y, EB0Z, EA0Z [urad]
    # e_x = (-10 y + 20 z) 1e-3 um -> [-6, +10]; e_y = -4 z 1e-3 -> [-2, 0]; e_z = 0
    r = volumetric_indices(m, n=5)
    assert r.E_VX == pytest.approx(16.0)
    assert r.E_VY == pytest.approx(2.0)
    assert r.E_VZ == pytest.approx(0.0, abs=1e-12)
    assert r.E_VXYZ == pytest.approx(np.hypot(10.0, 2.0))
    np.testing.assert_allclose(r.worst_point_mm[1:], [0.0, 500.0])
    assert r.E_VXYZ_range == pytest.approx(np.hypot(16.0, 2.0))
    assert elv_from_model(m)["ELv"] == 0.0


def test_elv_rss():
    assert elv(3.0, 4.0, 12.0) == pytest.approx(13.0)


def _diag(dev, **cols):
    pos = np.linspace([0, 0, 0], [800, 600, 0], len(dev))
    return Measurement("d1", "diagonal", "retroreflector", pos, np.asarray(dev, float),
                       [0.8, 0.6, 0.0], columns=cols, meta={"diagonal": "pp", "plane": "xy"})


def test_iso230_6_single_run():
    r = evaluate_diagonal(_diag([0, 1, 4, 2, -1]))
    assert r.E_D == pytest.approx(5.0)
    assert r.max_abs_um == pytest.approx(4.0)
    assert r.length_mm == pytest.approx(1000.0)
    assert r.iso230_2 is None


def test_iso230_6_bidirectional_uses_iso230_2():
    t, run, d, dev = cycle()
    frac = t / 800.0
    pos = np.c_[800 * frac, 600 * frac, np.zeros_like(frac)]
    meas = Measurement("d2", "diagonal", "retroreflector", pos, dev, [0.8, 0.6, 0.0],
                       columns={"run": run, "direction": d}, meta={"diagonal": "pp"})
    r = evaluate_diagonal(meas)
    assert r.iso230_2 is not None
    # targets along the diagonal are 1.25 x the X targets; the figures are those by hand
    assert r.E_D == pytest.approx(9.0)
    assert r.iso230_2.R == pytest.approx(9.0)
    np.testing.assert_allclose(r.iso230_2.targets.target_mm, [0, 225, 525, 762.5, 1000])
