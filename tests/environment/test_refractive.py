"""Refractive index of air against the NIST Engineering Metrology Toolbox check values.

Source: J. A. Stone and J. H. Zimmerman, "Index of Refraction of Air", NIST Engineering
Metrology Toolbox, https://emtoolbox.nist.gov/Wavelength/Documentation.asp, section VII
"Comparison of Ciddor and Modified Edlén Equations", table of test conditions and results
(CO2 450 umol/mol). Columns: temperature [degC], relative humidity [%], pressure [kPa],
vacuum wavelength [nm], n by Ciddor, n by the modified Edlén equation.
"""

import numpy as np
import pytest

from volcal.environment.refractive import (
    ciddor,
    edlen,
    refractive_index,
    saturation_vapor_pressure,
)
from volcal.errors import VolcalInputError

NIST_TABLE = [
    (20, 0, 101.325, 633, 1.000271800, 1.000271799),
    (20, 0, 60, 633, 1.000160924, 1.000160920),
    (20, 0, 120, 633, 1.000321916, 1.000321918),
    (50, 0, 100, 633, 1.000243285, 1.000243270),
    (5, 0, 100, 633, 1.000282756, 1.000282750),
    (-40, 0, 100, 633, 1.000337580, 1.000337471),
    (50, 100, 120, 633, 1.000287924, 1.000287864),
    (40, 75, 120, 633, 1.000299418, 1.000299406),
    (20, 100, 100, 633, 1.000267394, 1.000267394),
    (40, 100, 110, 1700, 1.000270247, 1.000270237),
    (20, 0, 101.325, 1700, 1.000268479, 1.000268483),
    (40, 100, 110, 300, 1.000289000, 1.000288922),
    (20, 0, 101.325, 300, 1.000286581, 1.000286579),
    (-40, 0, 120, 300, 1.000427233, 1.000427072),
]


@pytest.mark.parametrize("t, h, p_kpa, wl, n_ciddor, n_edlen", NIST_TABLE)
def test_nist_check_values(t, h, p_kpa, wl, n_ciddor, n_edlen):
    assert abs(ciddor(t, p_kpa * 1e3, h, wl, 450.0) - n_ciddor) < 2e-8
    assert abs(edlen(t, p_kpa * 1e3, h, wl, 450.0) - n_edlen) < 2e-8
    assert refractive_index(t, p_kpa * 1e3, h, wl, "edlen") == pytest.approx(
        edlen(t, p_kpa * 1e3, h, wl), abs=0)


def test_vectorised_over_readings():
    t = np.array([r[0] for r in NIST_TABLE], dtype=float)
    h = np.array([r[1] for r in NIST_TABLE], dtype=float)
    p = np.array([r[2] for r in NIST_TABLE]) * 1e3
    wl = np.array([r[3] for r in NIST_TABLE], dtype=float)
    np.testing.assert_allclose(ciddor(t, p, h, wl), [r[4] for r in NIST_TABLE], atol=2e-8)


def test_saturation_vapour_pressure_at_20c():
    # IAPWS: 2339.3 Pa at 20 degC (the value quoted by NIST's documentation)
    assert saturation_vapor_pressure(20.0) == pytest.approx(2339.3, abs=0.1)


def test_co2_raises_refractivity():
    # Ciddor: (n - 1) grows by 5.34e-7 relative per umol/mol of CO2 (plus molar mass)
    lo = ciddor(20, 101325, 0, 633, 300) - 1
    hi = ciddor(20, 101325, 0, 633, 600) - 1
    assert hi / lo - 1 == pytest.approx(300 * 5.34e-7, rel=0.05)


def test_out_of_range_is_user_error():
    with pytest.raises(VolcalInputError, match="pressure_pa"):
        ciddor(20, 101.325, 50, 633)  # kPa given where Pa is expected
    with pytest.raises(VolcalInputError, match="formula"):
        refractive_index(20, 101325, 50, 633, formula="owens")
