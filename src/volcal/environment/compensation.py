"""Compensation of raw laser readings for the air refractive index and material temperature.

Convention (documented in ``docs/environment.md``): a *raw* laser reading is the optical
path change counted in vacuum wavelengths, ``L_raw = N lambda_vac / 2`` (the instrument's
displacement with ``n = 1`` and no material correction), counted from the first reading.
The displacement in air is ``L_air = L_raw / n``; normalised to 20 degC for a machine scale
at ``t_m`` with coefficient ``alpha`` it is ``L_20 = L_air / (1 + alpha (t_m - 20))``
(ISO 230-2:2014, annex A: nominal differential expansion). A raw *deviation* is
``L_raw - C`` with ``C`` the commanded displacement along the beam; the compensated
deviation is ``L_20 - C``.

References
----------
.. [1] ISO 230-2:2014, annex A (measurement uncertainty; environmental compensation).
.. [2] J. A. Stone and J. H. Zimmerman, "Index of Refraction of Air", NIST EMToolbox.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.environment.materials import to_20c
from volcal.environment.refractive import HENE_VACUUM_WAVELENGTH_NM, refractive_index

__all__ = ["compensate_readings"]


def compensate_readings(commanded_mm: ArrayLike, raw_deviation_um: ArrayLike,
                        air_temperature_c: ArrayLike, air_pressure_pa: ArrayLike,
                        humidity_pct: ArrayLike,
                        wavelength_nm: ArrayLike = HENE_VACUUM_WAVELENGTH_NM,
                        material_temperature_c: ArrayLike = 20.0,
                        expansion_ppm_per_k: ArrayLike = 0.0, co2_ppm: ArrayLike = 450.0,
                        formula: str = "ciddor") -> NDArray[np.float64]:
    """Compensated deviations from raw (vacuum-wavelength) laser deviations.

    Parameters
    ----------
    commanded_mm : array_like, shape (n,)
        Commanded displacement along the beam from the first reading [mm].
    raw_deviation_um : array_like, shape (n,)
        Raw laser displacement minus the commanded displacement [um].
    air_temperature_c, air_pressure_pa, humidity_pct : array_like
        Air temperature [degC], pressure [Pa] and relative humidity [%] (scalars or one
        value per reading).
    wavelength_nm : array_like
        Vacuum wavelength of the laser [nm].
    material_temperature_c : array_like
        Temperature of the machine scale [degC].
    expansion_ppm_per_k : array_like
        Expansion coefficient of the machine scale [ppm/K]; 0 disables the correction.
    co2_ppm : array_like
        CO2 mole fraction [umol/mol].
    formula : str
        ``'ciddor'`` or ``'edlen'``.

    Returns
    -------
    ndarray, shape (n,)
        Compensated deviation ``L_20 - C`` [um].
    """
    c_mm = np.asarray(commanded_mm, dtype=float)
    raw_mm = c_mm + np.asarray(raw_deviation_um, dtype=float) * 1e-3
    n = refractive_index(air_temperature_c, air_pressure_pa, humidity_pct, wavelength_nm,
                         formula, co2_ppm)
    l20 = to_20c(raw_mm / n, material_temperature_c, expansion_ppm_per_k)
    return (l20 - c_mm) * 1e3
