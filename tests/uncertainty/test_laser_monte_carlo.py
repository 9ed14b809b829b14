"""GUM Supplement 1 check of the laser budget: Monte Carlo of the exact model against the
linear propagation of :class:`volcal.uncertainty.laser.LaserModel`, cosine error and the
second-order material term included.

Exact model of one reading at L from the datum: the machine moves X; the laser counts the
optical path X cos(theta) in the true air with the true wavelength; volcal divides by n of
the *measured* air; the material is at its nominal 20 degC (nothing to refer, the scale's
temperature and alpha uncertain). The cosine error is not corrected (the budget never
changes a value): it is an uncorrected one-sided bias, and the linear u is its root mean
square about zero. The error of the reading against X referred to 20 degC with the true
alpha and temperature is sampled.
"""

import numpy as np
import pytest

from volcal.environment.refractive import refractive_index
from volcal.uncertainty.budget import parse_budget
from volcal.uncertainty.laser import COSINE_RMS_FACTOR, LaserModel
from volcal.uncertainty.propagation import Propagator

DOC = {
    "laser": {"u_wavelength_ppm": 0.05},
    "air": {"temperature_c": 20.0, "pressure_pa": 101325.0, "humidity_pct": 50.0,
            "u_temperature_k": 0.2, "u_pressure_pa": 50.0,
            "u_pressure_pa_distribution": "rectangular", "u_humidity_pct": 5.0},
    "material": {"temperature_c": 20.0, "u_temperature_k": 0.5, "expansion_ppm_per_k": 1.0,
                 "u_expansion_ppm_per_k": 1.0},
    # 1 mrad: a deliberately poor alignment, so that the one-sided term matters
    "setup": {"u_misalignment_urad": 1000.0, "dead_path_mm": 0.0},
}


def draw(rng, inp, n):
    if inp.distribution == "rectangular":
        return rng.uniform(-np.sqrt(3) * inp.u, np.sqrt(3) * inp.u, n)
    return rng.normal(0.0, inp.u, n)


def monte_carlo(budget, length_mm, n=200_000, seed=1):
    rng = np.random.default_rng(seed)
    v, i = budget.values, budget.inputs
    t, p, h = v["air.temperature_c"], v["air.pressure_pa"], v["air.humidity_pct"]
    n_meas = float(refractive_index(t, p, h))
    n_true = refractive_index(t + draw(rng, i["air.u_temperature_k"], n),
                              p + draw(rng, i["air.u_pressure_pa"], n),
                              h + draw(rng, i["air.u_humidity_pct"], n))
    dlam = draw(rng, i["laser.u_wavelength_ppm"], n) * 1e-6
    a_nom = v["material.expansion_ppm_per_k"] * 1e-6
    a_true = a_nom + draw(rng, i["material.u_expansion_ppm_per_k"], n) * 1e-6
    tm = v["material.temperature_c"]
    tm_true = tm + draw(rng, i["material.u_temperature_k"], n)
    theta = rng.normal(0.0, i["setup.u_misalignment_urad"].u * 1e-6, n)
    x20 = length_mm                                 # the measurand, referred to 20 degC
    x = x20 * (1 + a_true * (tm_true - 20))         # the actual travel at tm_true
    reading = x * np.cos(theta) * n_true / n_meas / (1 + dlam)
    # no correction by the budget: the reading's deviation as it is
    corrected = (reading - x20) * 1e3
    return x20 * 1e3 - (x20 * 1e3 + corrected)      # correction still needed [um]


def test_linear_propagation_matches_monte_carlo():
    b = parse_budget(DOC)
    L = 1000.0
    prop = Propagator()
    e = prop.estimate(LaserModel(b, prop).length_term(L))
    mc = monte_carlo(b, L)
    # value: 0 (nothing corrected); the MC keeps the cosine bias, its mean is the
    # correction still needed, L u^2 / 2 = 0.5 um (the reading is short by L theta^2 / 2)
    assert e.value == 0.0
    assert np.mean(mc) == pytest.approx(0.5, abs=0.01)
    # the linear u is the root mean square of the error about zero (bias and spread)
    assert np.sqrt(np.mean(mc**2)) == pytest.approx(e.u, rel=0.02)
    # GUM S1 7.9: the probability of the MC errors inside +-U (one-sided cosine term: the
    # probability, not the end points)
    inside = np.mean(np.abs(mc) <= e.U)
    assert 0.93 <= inside <= 0.98
    # the second-order material term and the cosine term are both needed: without them
    # the linear u is 20 % short of the Monte Carlo spread
    comp = {c.label: c.u for c in e.components}
    assert comp["misalignment (cosine error)"] == pytest.approx(1e6 * 1e-6 * COSINE_RMS_FACTOR)
    assert COSINE_RMS_FACTOR == pytest.approx(np.sqrt(0.25 + 0.5))  # sqrt(b^2 + u_b^2)
    assert comp["expansion coefficient × material temperature (2nd order)"] == \
        pytest.approx(1e6 * 1e-6 * 0.5)
    first = np.sqrt(e.u**2 - comp["misalignment (cosine error)"]**2
                    - comp["expansion coefficient × material temperature (2nd order)"]**2)
    assert first < 0.8 * np.sqrt(np.mean(mc**2))
