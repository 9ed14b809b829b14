"""Sensitivities of the air's refractive index from volcal's own equations.

The partial derivatives of n (Ciddor or modified Edlén, :mod:`volcal.environment.refractive`)
with respect to air temperature, pressure and relative humidity, by central differences.
Near 20 degC, 101.325 kPa, 50 %RH and 633 nm they are about -0.93 ppm/K, +2.7 ppm/kPa and
-0.0085 ppm/%RH (NIST Engineering Metrology Toolbox, Stone and Zimmerman [1]_, "Index of
Refraction of Air", table of sensitivities); the tests compare with those published
figures, not with volcal's code.

A compensated laser length is ``L = L_raw / n``, so an error ``dx`` of an air input makes
the relative length error ``-(dn/dx) dx / n``.

References
----------
.. [1] J. A. Stone and J. H. Zimmerman, "Index of Refraction of Air", NIST Engineering
   Metrology Toolbox, https://emtoolbox.nist.gov/Wavelength/Documentation.asp
"""

from __future__ import annotations

from dataclasses import dataclass

from volcal.environment.refractive import HENE_VACUUM_WAVELENGTH_NM, refractive_index

__all__ = ["AirSensitivity", "air_sensitivity"]


@dataclass(frozen=True)
class AirSensitivity:
    """Partial derivatives of the refractive index of air at an operating point.

    Attributes
    ----------
    n : float
        Refractive index at the operating point [-].
    dn_dt : float
        d n / d t [1/K].
    dn_dp : float
        d n / d p [1/Pa].
    dn_dh : float
        d n / d RH [1/%RH].
    """

    n: float
    dn_dt: float
    dn_dp: float
    dn_dh: float


def air_sensitivity(t_c: float, p_pa: float, humidity_pct: float,
                    wavelength_nm: float = HENE_VACUUM_WAVELENGTH_NM,
                    formula: str = "ciddor", co2_ppm: float = 450.0) -> AirSensitivity:
    """Sensitivities of n to the air temperature, pressure and humidity.

    Parameters
    ----------
    t_c : float
        Air temperature [degC].
    p_pa : float
        Air pressure [Pa].
    humidity_pct : float
        Relative humidity [%].
    wavelength_nm : float
        Vacuum wavelength [nm].
    formula : str
        ``'ciddor'`` or ``'edlen'``.
    co2_ppm : float
        CO2 mole fraction [umol/mol].

    Returns
    -------
    AirSensitivity
        Central differences with steps 0.01 K, 10 Pa, 0.1 %RH (the equations are smooth:
        the truncation error is below 1e-6 relative).
    """
    def n(t: float, p: float, h: float) -> float:
        return float(refractive_index(t, p, h, wavelength_nm, formula, co2_ppm))

    ht, hp, hh = 0.01, 10.0, 0.1
    h_lo, h_hi = max(humidity_pct - hh, 0.0), min(humidity_pct + hh, 100.0)
    return AirSensitivity(
        n=n(t_c, p_pa, humidity_pct),
        dn_dt=(n(t_c + ht, p_pa, humidity_pct) - n(t_c - ht, p_pa, humidity_pct)) / (2 * ht),
        dn_dp=(n(t_c, p_pa + hp, humidity_pct) - n(t_c, p_pa - hp, humidity_pct)) / (2 * hp),
        dn_dh=(n(t_c, p_pa, h_hi) - n(t_c, p_pa, h_lo)) / (h_hi - h_lo))
