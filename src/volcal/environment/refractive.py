"""Refractive index of air: the modified Edlén equation and the Ciddor equation.

Both follow the complete description published with the NIST Engineering Metrology
Toolbox [1]_, Appendix A, so that results can be checked against NIST's own calculator:

* saturation vapour pressure over water (IAPWS 1997) and over ice (IAPWS 1993), A-I;
* water vapour mole fraction with the enhancement factor of Giacomo, A-II;
* the Ciddor equation [2]_ with CO2 and humidity, A-III;
* the Edlén equation as updated by Birch and Downs [3]_ [4]_ with the water-vapour term
  modified by Stone and Zimmerman, A-IV.

References
----------
.. [1] J. A. Stone and J. H. Zimmerman, "Index of Refraction of Air", NIST Engineering
   Metrology Toolbox, https://emtoolbox.nist.gov/Wavelength/Documentation.asp
.. [2] P. E. Ciddor, "Refractive index of air: new equations for the visible and near
   infrared", Appl. Opt. 35, 1566-1573 (1996).
.. [3] K. P. Birch and M. J. Downs, "An updated Edlén equation for the refractive index
   of air", Metrologia 30, 155-162 (1993).
.. [4] K. P. Birch and M. J. Downs, "Correction to the updated Edlén equation for the
   refractive index of air", Metrologia 31, 315-316 (1994).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError

__all__ = [
    "FORMULAS",
    "HENE_VACUUM_WAVELENGTH_NM",
    "ciddor",
    "edlen",
    "refractive_index",
    "saturation_vapor_pressure",
    "water_vapor_pressure",
]

FORMULAS: tuple[str, ...] = ("edlen", "ciddor")

#: Vacuum wavelength of an iodine-stabilised-class HeNe laser [nm] (CIPM 2003 value
#: 632.99121 nm for the stabilised line; free-running lasers differ by < 2e-7 relative).
HENE_VACUUM_WAVELENGTH_NM = 632.9912


def saturation_vapor_pressure(t_c: ArrayLike) -> NDArray[np.float64]:
    """Saturation vapour pressure of water [Pa] (over water for t >= 0 C, over ice below).

    Parameters
    ----------
    t_c : array_like
        Air temperature [degC].

    Returns
    -------
    ndarray
        Saturation vapour pressure [Pa].

    Notes
    -----
    NIST EMToolbox Appendix A-I [1]_: IAPWS 1997 formulation over liquid water and the
    IAPWS 1993 sublimation-pressure formula over ice.
    """
    t = np.asarray(t_c, dtype=float)
    T = t + 273.15
    k1, k2, k3 = 1.16705214528e03, -7.24213167032e05, -1.70738469401e01
    k4, k5, k6 = 1.20208247025e04, -3.23255503223e06, 1.49151086135e01
    k7, k8, k9 = -4.82326573616e03, 4.05113405421e05, -2.38555575678e-01
    k10 = 6.50175348448e02
    om = T + k9 / (T - k10)
    a = om**2 + k1 * om + k2
    b = k3 * om**2 + k4 * om + k5
    c = k6 * om**2 + k7 * om + k8
    x = -b + np.sqrt(b**2 - 4 * a * c)
    p_water = 1e6 * (2 * c / x) ** 4
    theta = T / 273.16
    y = -13.928169 * (1 - theta**-1.5) + 34.7078238 * (1 - theta**-1.25)
    p_ice = 611.657 * np.exp(y)
    return np.where(t >= 0.0, p_water, p_ice)


def water_vapor_pressure(t_c: ArrayLike, humidity_pct: ArrayLike) -> NDArray[np.float64]:
    """Partial pressure of water vapour from relative humidity [Pa].

    Parameters
    ----------
    t_c : array_like
        Air temperature [degC].
    humidity_pct : array_like
        Relative humidity [%].

    Returns
    -------
    ndarray
        Partial pressure of water vapour, ``RH/100 * psv(t)`` [Pa] (NIST A-II).
    """
    return np.asarray(humidity_pct, dtype=float) / 100.0 * saturation_vapor_pressure(t_c)


def _check(t_c, p_pa, h_pct, wl_nm, co2_ppm) -> None:
    checks = [
        ("temperature_c", t_c, -40.0, 100.0),
        ("pressure_pa", p_pa, 10e3, 140e3),
        ("humidity_pct", h_pct, 0.0, 100.0),
        ("wavelength_nm", wl_nm, 300.0, 1700.0),
        ("co2_ppm", co2_ppm, 0.0, 2000.0),
    ]
    for name, v, lo, hi in checks:
        a = np.asarray(v, dtype=float)
        if not np.all(np.isfinite(a)):
            raise VolcalInputError(f"{name} must be a finite number", column=name)
        if np.any(a < lo) or np.any(a > hi):
            shown = f"{a.min():g}" if a.min() == a.max() else f"{a.min():g}..{a.max():g}"
            raise VolcalInputError(
                f"{name} = {shown} outside the range of validity "
                f"[{lo:g}, {hi:g}] of the refractive-index equations", column=name)


def ciddor(t_c: ArrayLike, p_pa: ArrayLike, humidity_pct: ArrayLike,
           wavelength_nm: ArrayLike = HENE_VACUUM_WAVELENGTH_NM,
           co2_ppm: ArrayLike = 450.0) -> NDArray[np.float64]:
    """Refractive index of moist air by the Ciddor (1996) equation.

    Parameters
    ----------
    t_c : array_like
        Air temperature [degC].
    p_pa : array_like
        Air pressure [Pa].
    humidity_pct : array_like
        Relative humidity [%].
    wavelength_nm : array_like
        Vacuum wavelength [nm], valid 300 nm to 1700 nm.
    co2_ppm : array_like
        CO2 mole fraction [umol/mol].

    Returns
    -------
    ndarray
        Phase refractive index n [-].

    Notes
    -----
    Ciddor [2]_ as written out in NIST EMToolbox Appendix A-III [1]_; the water vapour
    mole fraction uses the enhancement factor ``f = 1.00062 + 3.14e-8 p + 5.6e-7 t^2``.
    """
    _check(t_c, p_pa, humidity_pct, wavelength_nm, co2_ppm)
    t = np.asarray(t_c, dtype=float)
    p = np.asarray(p_pa, dtype=float)
    T = t + 273.15
    pv = water_vapor_pressure(t, humidity_pct)
    f = 1.00062 + 3.14e-8 * p + 5.60e-7 * t**2
    xv = f * pv / p
    s = 1.0 / (np.asarray(wavelength_nm, dtype=float) / 1000.0) ** 2
    w0, w1, w2, w3 = 295.235, 2.6422, -0.032380, 0.004028
    k0, k1, k2, k3 = 238.0185, 5792105.0, 57.362, 167917.0
    a0, a1, a2 = 1.58123e-6, -2.9331e-8, 1.1043e-10
    b0, b1 = 5.707e-6, -2.051e-8
    c0, c1 = 1.9898e-4, -2.376e-6
    d, e = 1.83e-11, -0.765e-8
    p_r1, t_r1, z_a = 101325.0, 288.15, 0.9995922115
    rho_vs, r_gas, m_v = 0.00985938, 8.314472, 0.018015
    x_co2 = np.asarray(co2_ppm, dtype=float)
    r_as = 1e-8 * (k1 / (k0 - s) + k3 / (k2 - s))
    r_vs = 1.022e-8 * (w0 + w1 * s + w2 * s**2 + w3 * s**3)
    m_a = 0.0289635 + 1.2011e-8 * (x_co2 - 400.0)
    r_axs = r_as * (1.0 + 5.34e-7 * (x_co2 - 450.0))
    z_m = (1.0 - (p / T) * (a0 + a1 * t + a2 * t**2 + (b0 + b1 * t) * xv
                            + (c0 + c1 * t) * xv**2)
           + (p / T) ** 2 * (d + e * xv**2))
    rho_axs = p_r1 * m_a / (z_a * r_gas * t_r1)
    rho_v = xv * p * m_v / (z_m * r_gas * T)
    rho_a = (1.0 - xv) * p * m_a / (z_m * r_gas * T)
    return 1.0 + (rho_a / rho_axs) * r_axs + (rho_v / rho_vs) * r_vs


def edlen(t_c: ArrayLike, p_pa: ArrayLike, humidity_pct: ArrayLike,
          wavelength_nm: ArrayLike = HENE_VACUUM_WAVELENGTH_NM,
          co2_ppm: ArrayLike = 450.0) -> NDArray[np.float64]:
    """Refractive index of moist air by the modified Edlén equation (Birch and Downs).

    Parameters
    ----------
    t_c : array_like
        Air temperature [degC].
    p_pa : array_like
        Air pressure [Pa].
    humidity_pct : array_like
        Relative humidity [%].
    wavelength_nm : array_like
        Vacuum wavelength [nm].
    co2_ppm : array_like
        CO2 mole fraction [umol/mol]. The Birch-Downs equation is written for 450 umol/mol
        (the NIST calculator has no CO2 input); other values scale the dry-air refractivity
        by ``1 + 5.34e-7 (x_CO2 - 450)``, the CO2 term of Ciddor's equation.

    Returns
    -------
    ndarray
        Phase refractive index n [-].

    Notes
    -----
    Birch and Downs [3]_ [4]_ with the water-vapour term of Stone and Zimmerman, NIST
    EMToolbox Appendix A-IV [1]_::

        (n_s - 1) 1e8 = 8342.54 + 2406147/(130 - S) + 15998/(38.9 - S),  S = 1/lambda^2
        n_tp - 1 = p (n_s - 1) X / 96095.43,
        X = (1 + 1e-8 (0.601 - 0.00972 t) p) / (1 + 0.003661 t)
        n = n_tp - 1e-10 (292.75 / T) (3.7345 - 0.0401 S) p_v
    """
    _check(t_c, p_pa, humidity_pct, wavelength_nm, co2_ppm)
    t = np.asarray(t_c, dtype=float)
    p = np.asarray(p_pa, dtype=float)
    T = t + 273.15
    pv = water_vapor_pressure(t, humidity_pct)
    s = 1.0 / (np.asarray(wavelength_nm, dtype=float) / 1000.0) ** 2
    ns_1 = 1e-8 * (8342.54 + 2406147.0 / (130.0 - s) + 15998.0 / (38.9 - s))
    ns_1 = ns_1 * (1.0 + 5.34e-7 * (np.asarray(co2_ppm, dtype=float) - 450.0))
    x = (1.0 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1.0 + 0.003661 * t)
    n_tp = 1.0 + p * ns_1 * x / 96095.43
    return n_tp - 1e-10 * (292.75 / T) * (3.7345 - 0.0401 * s) * pv


def refractive_index(t_c: ArrayLike, p_pa: ArrayLike, humidity_pct: ArrayLike,
                     wavelength_nm: ArrayLike = HENE_VACUUM_WAVELENGTH_NM,
                     formula: str = "ciddor", co2_ppm: ArrayLike = 450.0
                     ) -> NDArray[np.float64]:
    """Refractive index of air by the chosen equation.

    Parameters
    ----------
    t_c : array_like
        Air temperature [degC].
    p_pa : array_like
        Air pressure [Pa].
    humidity_pct : array_like
        Relative humidity [%].
    wavelength_nm : array_like
        Vacuum wavelength [nm].
    formula : str
        ``'ciddor'`` (default, recommended by NIST [1]_) or ``'edlen'``.
    co2_ppm : array_like
        CO2 mole fraction [umol/mol].

    Returns
    -------
    ndarray
        Refractive index n [-].
    """
    f = str(formula).lower().replace("é", "e")
    if f == "ciddor":
        return ciddor(t_c, p_pa, humidity_pct, wavelength_nm, co2_ppm)
    if f == "edlen":
        return edlen(t_c, p_pa, humidity_pct, wavelength_nm, co2_ppm)
    raise VolcalInputError(f"unknown formula {formula!r}: expected one of {', '.join(FORMULAS)}",
                           column="formula")

