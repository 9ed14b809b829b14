"""Ranges and unit hints of the environment quantities, shared by every reader.

One table for the uncertainty budget's operating point (``[air]``, ``[material]``,
``[laser]``; :mod:`volcal.uncertainty.budget`) and a session measurement's
``environment`` table and per-reading columns (:mod:`volcal.environment.apply`,
``docs/environment.md``): a value outside its range is refused with the same message
and unit hint wherever it is read (a pressure of ``1013.25`` names hPa, a temperature of
``293`` names kelvin).

The ranges are those of the refractive-index equations (Ciddor, Edlén: -40..100 degC,
10..140 kPa, 0..100 %RH, 300..1700 nm; :mod:`volcal.environment.refractive`) and of the
materials machine scales are made of (-5..50 ppm/K).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from volcal.errors import VolcalInputError

__all__ = ["ENVIRONMENT_LIMITS", "Limit", "check_environment_value", "range_message"]


@dataclass(frozen=True)
class Limit:
    """Allowed range of one quantity.

    Attributes
    ----------
    lo, hi : float
        Smallest and largest value accepted (inclusive), in ``unit``.
    unit : str
        Unit of the quantity (``'degC'``, ``'Pa'``...).
    hint : str
        What a value outside the range most likely is (``'percent: 50, not 0.5'``).
    """

    lo: float
    hi: float
    unit: str
    hint: str = ""


ENVIRONMENT_LIMITS: dict[str, Limit] = {
    "air_temperature_c": Limit(-40.0, 100.0, "degC", "degrees Celsius, not kelvin"),
    "air_pressure_pa": Limit(10e3, 140e3, "Pa", "pascal: 101325, not 1013.25 hPa or "
                             "101.3 kPa"),
    "humidity_pct": Limit(0.0, 100.0, "%", "percent: 50, not 0.5"),
    "wavelength_nm": Limit(300.0, 1700.0, "nm"),
    "co2_ppm": Limit(0.0, 2000.0, "umol/mol"),
    "material_temperature_c": Limit(-40.0, 100.0, "degC", "degrees Celsius, not kelvin"),
    "expansion_ppm_per_k": Limit(-5.0, 50.0, "ppm/K", "ppm/K: 11.5 for steel, not 1.15e-5"),
}
"""Range of every numeric key of a measurement's ``environment`` table (the budget's
``[air]``, ``[material]`` and ``[laser] wavelength_nm`` use the same entries)."""


def range_message(x: float, key: str, limit: Limit) -> str:
    """The message for a value outside its range, with the likely unit mistake.

    Parameters
    ----------
    x : float
        The value, in ``limit.unit``.
    key : str
        Its key (``air_pressure_pa``, ``air.pressure_pa``): the suffix chooses the hint.
    limit : Limit
        Its range.

    Returns
    -------
    str
        ``'500 Pa is outside [10000, 140000] Pa (hPa or kPa? give pascal: 101325)'``.
    """
    msg = f"{x:g} {limit.unit} is outside [{limit.lo:g}, {limit.hi:g}] {limit.unit}"
    if key.endswith("pressure_pa") and 10.0 <= x < 10e3:
        msg += " (hPa or kPa? give pascal: 101325)"
    elif key.endswith("temperature_c") and x > 200.0:
        msg += " (kelvin? give degrees Celsius: 20)"
    elif limit.hint:
        msg += f" ({limit.hint})"
    return msg


def check_environment_value(value: Any, key: str, file: Any = None,
                            where: str | None = None) -> float:
    """A finite number within the range of ``ENVIRONMENT_LIMITS[key]``.

    Parameters
    ----------
    value : object
        The value as read (TOML number).
    key : str
        Key of :data:`ENVIRONMENT_LIMITS`.
    file : str or Path, optional
        File named in the error.
    where : str, optional
        Key path named in the error (default ``environment.<key>``).

    Returns
    -------
    float

    Raises
    ------
    VolcalInputError
        Not a number (a boolean or text), not finite, or outside the range.
    """
    lim = ENVIRONMENT_LIMITS[key]
    where = where or f"environment.{key}"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise VolcalInputError(f"expected a number [{lim.unit}], got {value!r}", file, None,
                               where)
    x = float(value)
    if not math.isfinite(x):
        raise VolcalInputError(f"must be a finite number [{lim.unit}], got {value!r}", file,
                               None, where)
    if not lim.lo <= x <= lim.hi:
        raise VolcalInputError(range_message(x, key, lim), file, None, where)
    return x
