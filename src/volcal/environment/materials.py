"""Linear thermal expansion of machine and workpiece materials; normalisation to 20 degC.

ISO 1 fixes the reference temperature of geometrical product specification at 20 degC:
a length measured at another temperature is reported as the length it would have at
20 degC. For a machine axis whose scale (lead screw, glass scale) has the expansion
coefficient ``alpha`` and temperature ``t_m``, ISO 230-2 (annex A) calls
the correction the *nominal differential expansion* (NDE) correction.

The coefficients below are typical handbook values at room temperature [ppm/K]; use
the value of the actual material (scale data sheet) whenever it is known.

References
----------
.. [1] ISO 1:2016, Geometrical product specifications (GPS) - Standard reference
   temperature for the specification of geometrical and dimensional properties.
.. [2] ISO 230-2:2014, Test code for machine tools - Part 2: Determination of accuracy and
   repeatability of positioning of numerically controlled axes, annex A.
.. [3] ISO/TR 16015:2003, Systematic errors and contributions to measurement uncertainty of
   length measurement due to thermal influences (typical coefficients, table 1).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError

__all__ = ["EXPANSION_PPM_PER_K", "REFERENCE_TEMPERATURE_C", "expansion_coefficient",
           "to_20c"]

REFERENCE_TEMPERATURE_C = 20.0

#: Typical linear expansion coefficients near 20 degC [ppm/K] (ISO/TR 16015, handbooks).
EXPANSION_PPM_PER_K: dict[str, float] = {
    "steel": 11.5,
    "cast_iron": 10.5,
    "stainless_steel": 16.0,
    "aluminium": 23.0,
    "brass": 18.5,
    "granite": 7.0,
    "invar": 1.2,
    "glass_scale": 8.5,
    "glass_ceramic": 0.0,
    "zerodur": 0.05,
    "carbon_fibre": 0.5,
}

_ALIASES = {"aluminum": "aluminium", "iron": "cast_iron", "glass": "glass_scale",
            "cfrp": "carbon_fibre", "carbon_fiber": "carbon_fibre"}


def expansion_coefficient(material: str) -> float:
    """Expansion coefficient of a named material [ppm/K].

    Parameters
    ----------
    material : str
        A key of :data:`EXPANSION_PPM_PER_K` (case-insensitive; spaces and hyphens are
        read as underscores; ``aluminum``, ``iron``, ``glass`` and ``cfrp`` are accepted).

    Returns
    -------
    float
        Linear expansion coefficient [ppm/K].

    Raises
    ------
    VolcalInputError
        Unknown material.
    """
    key = str(material).strip().lower().replace(" ", "_").replace("-", "_")
    key = _ALIASES.get(key, key)
    if key not in EXPANSION_PPM_PER_K:
        raise VolcalInputError(f"unknown material {material!r}: expected one of "
                               f"{', '.join(sorted(EXPANSION_PPM_PER_K))} or give "
                               "expansion_ppm_per_k", column="material")
    return EXPANSION_PPM_PER_K[key]


def to_20c(length_mm: ArrayLike, temperature_c: ArrayLike,
           expansion_ppm_per_k: ArrayLike) -> NDArray[np.float64]:
    """Length normalised to 20 degC from a length measured at another temperature.

    Parameters
    ----------
    length_mm : array_like
        Length (or displacement) measured at ``temperature_c`` [mm].
    temperature_c : array_like
        Material temperature [degC].
    expansion_ppm_per_k : array_like
        Linear expansion coefficient [ppm/K].

    Returns
    -------
    ndarray
        ``L / (1 + alpha (t - 20))`` [mm], the length the part would have at 20 degC.
    """
    alpha = np.asarray(expansion_ppm_per_k, dtype=float) * 1e-6
    dt = np.asarray(temperature_c, dtype=float) - REFERENCE_TEMPERATURE_C
    return np.asarray(length_mm, dtype=float) / (1.0 + alpha * dt)
