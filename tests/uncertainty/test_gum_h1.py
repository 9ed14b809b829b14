"""The GUM's worked example H.1 (end-gauge calibration) through volcal's propagation code.

JCGM 100:2008, H.1: l = l_s + d - l_s (delta_alpha theta + alpha_s delta_theta).
Published: l = 50.000 838 mm, u_c = 32 nm (first order), 34 nm with the second-order
terms (H.1.7), nu_eff = 16 (H.1.6), U_99 = t_99(16) u_c = 2.92 x 32 nm = 93 nm.
The product terms go through :meth:`Propagator.product`, the same code that carries the
material term (alpha x (t - 20)) of the laser budget.
"""

import math

import pytest
from GTC import reporting

from volcal.uncertainty.propagation import Propagator


def end_gauge(second_order):
    p = Propagator(second_order=second_order)
    ls = p.input("l_s", 50_000_623.6, 25.0, 18)                   # [nm]
    d = (p.input("d, repeated observations", 215.0, 5.8, 24)
         + p.input("d, comparator random", 0.0, 3.9, 5)
         + p.input("d, comparator systematic", 0.0, 6.7, 8))      # u(d) = 9.7 nm, nu 25.6
    alpha_s = p.input("alpha_s", 11.5e-6, 1.2e-6)                 # [1/K]
    theta = p.input("theta", -0.1, 0.41)                          # [K]
    dalpha = p.input("delta_alpha", 0.0, 0.58e-6, 50)
    dtheta = p.input("delta_theta", 0.0, 0.029, 2)
    l_ = ls + d - (p.product("delta_alpha theta", ls.x, dalpha, theta)
                   + p.product("alpha_s delta_theta", ls.x, alpha_s, dtheta))
    return p, l_


def test_first_order_32_nm_and_16_dof():
    p, l_ = end_gauge(False)
    e = p.estimate(l_)
    assert e.value * 1e-6 == pytest.approx(50.000838, abs=1e-6)
    assert e.u == pytest.approx(31.7, abs=0.1)          # "32 nm"
    assert round(e.u) == 32
    assert 16 <= e.dof < 17.5                           # GUM: nu_eff = 16 (truncated)
    assert reporting.k_factor(16, 99) * round(e.u) == pytest.approx(93, abs=0.5)
    # the budget: l_s 25 nm, delta_theta 16.6 nm (GUM table H.2: 16), d 9.7, delta_alpha 2.9
    comp = {c.label: c.u for c in e.components}
    assert comp["l_s"] == pytest.approx(25.0)
    assert comp["delta_theta"] == pytest.approx(50e6 * 11.5e-6 * 0.029, rel=1e-3)
    assert comp["delta_alpha"] == pytest.approx(2.9, abs=0.01)
    assert math.hypot(comp["d, repeated observations"], comp["d, comparator random"],
                      comp["d, comparator systematic"]) == pytest.approx(9.7, abs=0.05)


def test_second_order_34_nm():
    p, l_ = end_gauge(True)
    e = p.estimate(l_)
    assert e.u == pytest.approx(33.9, abs=0.1)          # "34 nm"
    assert round(e.u) == 34
    comp = {c.label: c.u for c in e.components}
    # GUM H.1.7: l_s u(delta_alpha) u(theta) = 11.9 nm, l_s u(alpha_s) u(delta_theta) = 1.7 nm
    assert comp["delta_alpha theta (2nd order)"] == pytest.approx(11.9, abs=0.1)
    assert comp["alpha_s delta_theta (2nd order)"] == pytest.approx(1.74, abs=0.01)
