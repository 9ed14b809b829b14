"""Air sensitivities against published values, not against volcal's own code.

Source: J. A. Stone and J. H. Zimmerman, "Index of Refraction of Air", NIST Engineering
Metrology Toolbox (emtoolbox.nist.gov), the commonly quoted sensitivities near 20 degC,
101.325 kPa, 50 %RH, 633 nm: -0.93 ppm/K (at a fixed water-vapour pressure: the density
of the air), +2.7 ppm/kPa, -0.0085 ppm/%RH; and its Appendix B shop-floor formula
n = 1 + 7.86e-4 p / (273 + t) - 1.5e-11 RH (t^2 + 160) (p in kPa), whose derivative at a
fixed relative humidity is evaluated by hand below.
"""

import pytest

from volcal.environment.refractive import refractive_index, saturation_vapor_pressure
from volcal.uncertainty.sensitivity import air_sensitivity

T, P, H = 20.0, 101325.0, 50.0


@pytest.mark.parametrize("formula", ["ciddor", "edlen"])
def test_pressure_and_humidity(formula):
    s = air_sensitivity(T, P, H, formula=formula)
    assert s.dn_dp * 1e3 * 1e6 == pytest.approx(2.7, rel=0.01)        # ppm/kPa
    assert s.dn_dh * 1e6 == pytest.approx(-0.0085, rel=0.02)          # ppm/%RH


@pytest.mark.parametrize("formula", ["ciddor", "edlen"])
def test_temperature_at_fixed_vapour_pressure(formula):
    # the published -0.93 ppm/K holds the water-vapour pressure fixed
    pv = H / 100 * float(saturation_vapor_pressure(T))
    h = 0.01

    def n(t):
        rh = 100 * pv / float(saturation_vapor_pressure(t))
        return float(refractive_index(t, P, rh, formula=formula))

    assert (n(T + h) - n(T - h)) / (2 * h) * 1e6 == pytest.approx(-0.93, rel=0.01)


def test_temperature_at_fixed_relative_humidity_vs_nist_shop_floor_formula():
    # d/dt of 7.86e-4 p/(273+t) - 1.5e-11 RH (t^2+160), p = 101.325 kPa, by hand:
    shop = -7.86e-4 * 101.325 / 293.0**2 - 1.5e-11 * H * 2 * T        # = -0.958 ppm/K
    s = air_sensitivity(T, P, H)
    assert shop * 1e6 == pytest.approx(-0.958, abs=0.001)
    assert s.dn_dt == pytest.approx(shop, rel=0.01)
