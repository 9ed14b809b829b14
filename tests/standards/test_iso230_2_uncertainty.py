"""Expanded uncertainty of the ISO 230-2 parameters, checked by hand.

Data: the hand-worked cycle of test_iso230_2 (s known exactly). With every instrument and
environment uncertainty zero, U reduces to the repeatability part, worked out here from
the definitions: u(xbar) = s / sqrt(n), u(s) = s / sqrt(2 (n - 1)) (GUM E.4.3), Welch-
Satterthwaite, k = t_95.45(nu). Then the systematic parts alone on noise-free data: the
scale terms enter E with the difference of lengths, never R or B; the expansion
coefficient's part scales with L and |t - 20|, the material temperature's with L and alpha.
"""

import math
import tomllib

import numpy as np
import pytest
from scipy import stats
from test_iso230_2 import MU_DN, MU_UP, S_DN, S_UP, TARGETS, cycle

from volcal.standards.iso230_2 import evaluate
from volcal.standards.iso230_2_uncertainty import evaluate_with_budget, iso230_2_uncertainty
from volcal.standards.positioning_data import PositioningData
from volcal.uncertainty.budget import TEMPLATE, BudgetWarning, parse_budget

P = math.erf(2 / math.sqrt(2))    # 95.45 %: k = 2 for infinite dof
N = 5


def k_t(nu):
    return stats.t.ppf((1 + P) / 2, nu)


def budget(**kw):
    """All u zero unless given as section__key=value."""
    doc = {"laser": {"u_wavelength_ppm": 0.0},
           "air": {"temperature_c": 20.0, "pressure_pa": 101325.0, "humidity_pct": 50.0,
                   "u_temperature_k": 0.0, "u_pressure_pa": 0.0, "u_humidity_pct": 0.0},
           "material": {"temperature_c": 20.0, "u_temperature_k": 0.0,
                        "expansion_ppm_per_k": 11.5, "u_expansion_ppm_per_k": 0.0},
           "setup": {"u_misalignment_urad": 0.0, "dead_path_mm": 0.0}}
    for key, v in kw.items():
        sec, k = key.split("__")
        doc[sec][k] = v
    return parse_budget(doc)


def test_zero_budget_reduces_to_repeatability():
    res = evaluate(*cycle())
    u = iso230_2_uncertainty(res, budget())
    U = {k: e.U for k, e in u.parameters.items()}
    # E = mu_up(420) - mu_dn(800) = 5 - (-4): u^2 = 0.5^2/5 + 2^2/5
    a, b = S_UP[2] ** 2 / N, S_DN[4] ** 2 / N
    nu = (a + b) ** 2 / ((a**2 + b**2) / (N - 1))
    assert U["E"] == pytest.approx(k_t(nu) * math.sqrt(a + b), rel=1e-6)
    # R_up = 4 s_up(610) = 6: u = 4 s / sqrt(2 (n - 1)), nu = 4
    assert U["R_up"] == pytest.approx(k_t(4) * 4 * 1.5 / math.sqrt(8), rel=1e-6)
    assert U["R_down"] == pytest.approx(k_t(4) * 4 * 2.0 / math.sqrt(8), rel=1e-6)
    # B = B_i(800) = 3: u^2 = (1 + 4) / 5
    a, b = 1.0 / N, 4.0 / N
    nu_b = (a + b) ** 2 / ((a**2 + b**2) / (N - 1))
    assert U["B"] == pytest.approx(k_t(nu_b) * 1.0, rel=1e-6)
    # R = 2 s_up + 2 s_dn + |B| at 800: u^2 = 4 u(s_up)^2 + 4 u(s_dn)^2 + u(B_i)^2
    terms = [4 * 1.0 / 8, 4 * 4.0 / 8, a, b]
    dofs = [4, 4, 4, 4]
    uc2 = sum(terms)
    nu_r = uc2**2 / sum(t**2 / d for t, d in zip(terms, dofs, strict=True))
    assert U["R"] == pytest.approx(k_t(nu_r) * math.sqrt(uc2), rel=1e-6)
    # B_mean: mean of the B_i, u^2 = sum(s_up^2 + s_dn^2) / n / m^2
    terms = list(S_UP**2 / N / 25) + list(S_DN**2 / N / 25)
    nu_bm = sum(terms) ** 2 / sum(t**2 / 4 for t in terms)
    assert U["B_mean"] == pytest.approx(k_t(nu_bm) * math.sqrt(sum(terms)), rel=1e-6)
    # per target: the mean bidirectional deviation, u^2 = (s_up^2 + s_dn^2) / n / 4
    for i, e in enumerate(u.targets):
        a, b = S_UP[i] ** 2 / N / 4, S_DN[i] ** 2 / N / 4
        nu = (a + b) ** 2 / ((a**2 + b**2) / 4)
        assert e.U == pytest.approx(k_t(nu) * math.sqrt(a + b), rel=1e-6)


def noise_free(slope_um_per_m=0.0):
    """Readings with s = 0: only the budget's systematic terms are uncertain."""
    t, r, d, _ = cycle()
    dev = slope_um_per_m * t / 1000 + np.where(d == "+", 0.5, -0.5)
    return evaluate(t, r, d, dev)


def test_scale_terms_enter_E_by_the_difference_of_lengths_not_R_or_B():
    res = evaluate(*cycle())
    quiet = iso230_2_uncertainty(res, budget())
    loud = iso230_2_uncertainty(res, budget(laser__u_wavelength_ppm=5.0,
                                            material__u_temperature_k=0.5,
                                            air__u_pressure_pa=200.0))
    for k in ("R", "R_up", "R_down", "B", "B_mean"):
        assert loud.parameters[k].U == pytest.approx(quiet.parameters[k].U, rel=1e-12), k
    assert loud.parameters["E"].U > quiet.parameters["E"].U
    # noise-free falling line: E between 0 mm (max) and 800 mm (min)
    t, r, d, _ = cycle()
    dev = -0.01 * t + np.where(d == "+", 0.5, -0.5)   # max at 0 mm, min at 800 mm
    res = evaluate(t, r, d, dev)
    u = iso230_2_uncertainty(res, budget(laser__u_wavelength_ppm=0.5))
    # U = 2 |L_a - L_b| u_rel: 800 mm x 0.5 ppm = 0.4 um, k = 2
    assert u.parameters["E"].k == 2.0
    assert u.parameters["E"].U == pytest.approx(2 * 800 * 0.5e-3, rel=1e-9)
    assert u.parameters["R"].U < 1e-12 and u.parameters["B"].U < 1e-12


def test_material_parts_scale_with_length_temperature_and_alpha():
    res = noise_free()

    def U_targets(**kw):
        return np.array([e.U for e in iso230_2_uncertainty(res, budget(**kw)).targets])

    L = TARGETS - TARGETS[0]
    # expansion coefficient: U = 2 L |t - 20| u(alpha) (k = 2, infinite dof)
    for tm in (21.0, 23.0, 17.0):
        got = U_targets(material__temperature_c=tm, material__u_expansion_ppm_per_k=1.0)
        assert got == pytest.approx(2 * L * 1e3 * abs(tm - 20) * 1e-6, rel=1e-9)
    # material temperature: U = 2 L alpha u(t)
    for alpha in (11.5, 23.0):
        got = U_targets(material__expansion_ppm_per_k=alpha, material__u_temperature_k=0.1)
        assert got == pytest.approx(2 * L * 1e3 * alpha * 1e-6 * 0.1, rel=1e-9)


def test_steel_two_kelvin_above_20_the_coefficient_dominates():
    """Issue figure: 1 m of steel 2 K above 20 C, alpha uncertain by 1 ppm/K: ~90 % of U."""
    doc = tomllib.loads(TEMPLATE)
    doc["material"].update(temperature_c=22.0, u_expansion_ppm_per_k=1.0)
    doc["material"].pop("u_expansion_ppm_per_k_distribution")
    t = np.repeat([0.0, 250.0, 500.0, 750.0, 1000.0], 10)
    run = np.tile(np.repeat([1, 2, 3, 4, 5], 2), 5)
    d = np.tile(["+", "-"], 25)
    data = PositioningData(t, run, d, np.zeros(t.size), np.arange(t.size) + 2, "x.csv")
    res, u, corr = evaluate_with_budget(data, parse_budget(doc))
    share = {c.label: c.share for c in u.reading.components}
    assert 0.85 < share["expansion coefficient"] < 0.92
    # the budget corrects no value (issue 25): the readings' parameters as without it
    assert not corr["material_applied"] and corr["largest_correction_um"] == 0.0
    assert "no correction by the budget" in corr["text"]
    assert res.targets.mean == pytest.approx(np.zeros(5), abs=0.0)
    plain = evaluate(data.targets_mm, data.run, data.direction, data.deviation_um,
                     **data.evaluate_kwargs())
    assert all(getattr(res, k) == getattr(plain, k) for k in ("A", "E", "M", "R", "B"))
    # the retired [material] referred_to_20c: a warning, never a change of value or U
    doc["material"]["referred_to_20c"] = True
    with pytest.warns(BudgetWarning, match="referred_to_20c = true is retired"):
        res2, u2, corr2 = evaluate_with_budget(data, parse_budget(doc))
    assert not corr2["material_applied"] and res2.E == 0.0
    assert u2.reading.U == u.reading.U


def test_mu_values_follow_the_data():
    # sanity: the uncertain expressions carry the same values as the evaluation
    res = evaluate(*cycle())
    u = iso230_2_uncertainty(res, budget())
    assert [e.value for e in u.targets] == pytest.approx((MU_UP + MU_DN) / 2)
    for k in ("E", "E_up", "E_down", "M", "R", "R_up", "R_down", "B", "B_mean", "A"):
        assert u.parameters[k].value == pytest.approx(getattr(res, k), abs=1e-12), k
