"""U of the ISO 230-6 diagonal displacement error E_D, by hand."""

import numpy as np
import pytest
from test_iso230_2_uncertainty import budget

from volcal.environment.apply import refer_measurement
from volcal.session.format import Measurement
from volcal.standards.iso230_6_uncertainty import evaluate_diagonal_with_budget

N = np.array([1.0, 1.0, 1.0]) / np.sqrt(3)


def diagonal(dev, run=None, direction=None, s=None):
    s = np.linspace(0.0, 900.0, len(dev)) if s is None else s
    cols = {} if run is None else {"run": np.asarray(run), "direction": np.asarray(direction)}
    return Measurement("d1", "diagonal", "retroreflector", s[:, None] * N[None, :],
                       np.asarray(dev, dtype=float), N, columns=cols,
                       meta={"diagonal": "ppp"})


def test_single_run_systematic_terms_by_the_difference_of_lengths():
    # readings rise to 600 mm then fall: max at 600 mm, min at 0 mm
    s = np.array([0.0, 150.0, 300.0, 450.0, 600.0, 750.0, 900.0])
    dev = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 3.5, 3.0])
    res, u = evaluate_diagonal_with_budget(diagonal(dev, s=s), budget(
        laser__u_wavelength_ppm=0.5))
    assert res.E_D == pytest.approx(4.0)
    assert u.E_D.U == pytest.approx(2 * 600 * 0.5e-3, rel=1e-9)       # k = 2
    assert any("no repeatability" in n for n in u.notes)
    # a budget with the material at 22 C corrects nothing (issue 25): E_D as without it
    res2, _ = evaluate_diagonal_with_budget(diagonal(dev, s=s), budget(
        material__temperature_c=22.0))
    assert res2.E_D == 4.0
    # the session refers it: compensated readings, referred_to_20c = false, steel at 22 C
    m = diagonal(dev, s=s)
    m.meta.update(referred_to_20c=False,
                  environment={"material_temperature_c": 22.0, "material": "steel"})
    res3, _ = evaluate_diagonal_with_budget(refer_measurement(m), budget())
    meas = s + dev * 1e-3                # the measured length [mm], L / (1 + alpha dt)
    assert res3.E_D == pytest.approx(np.ptp(dev - meas * 23e-3 / (1 + 23e-6)), abs=1e-9)


def test_bidirectional_diagonal_U_is_that_of_E():
    s1 = np.array([0.0, 210.0, 430.0, 640.0, 900.0])
    s, run, d, dev = [], [], [], []
    rng = np.random.default_rng(3)
    for j in range(1, 6):
        for sign, order in (("+", s1), ("-", s1[::-1])):
            for x in order:
                s.append(x)
                run.append(j)
                d.append(sign)
                dev.append(0.004 * x + (0.5 if sign == "+" else -0.5) + rng.normal(0, 0.3))
    res, u = evaluate_diagonal_with_budget(diagonal(dev, run, d, np.array(s)),
                                           budget(laser__u_wavelength_ppm=0.5))
    assert res.iso230_2 is not None and u.iso230_2 is not None
    assert u.E_D.U == u.iso230_2.parameters["E"].U > 2 * 900 * 0.5e-3 * 0.99
