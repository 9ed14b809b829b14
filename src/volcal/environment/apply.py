"""Compensate a session measurement whose readings are raw (``readings = "raw"``).

The environment comes from the measurement's ``environment`` table in ``session.toml``
(keys below) and, row by row, from the optional CSV columns ``air_temperature_c``,
``air_pressure_pa``, ``humidity_pct`` and ``material_temperature_c``, which take
precedence over the table. Keys of the ``environment`` table:

=========================  =========================================  ==============
key                        meaning                                    default
=========================  =========================================  ==============
air_temperature_c          air temperature [degC]                     required
air_pressure_pa            air pressure [Pa]                          required
humidity_pct               relative humidity [%]                      required
wavelength_nm              laser vacuum wavelength [nm]               632.9912
co2_ppm                    CO2 mole fraction [umol/mol]               450
material_temperature_c     machine scale temperature [degC]           20 (no NDE)
expansion_ppm_per_k        scale expansion coefficient [ppm/K]        from material
material                   name in ``EXPANSION_PPM_PER_K``            (none: 0 ppm/K)
formula                    ``ciddor`` or ``edlen``                    ciddor
=========================  =========================================  ==============
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from volcal.environment.compensation import compensate_readings
from volcal.environment.materials import expansion_coefficient
from volcal.environment.refractive import (
    FORMULAS,
    HENE_VACUUM_WAVELENGTH_NM,
    refractive_index,
)
from volcal.errors import VolcalInputError

__all__ = ["ENVIRONMENT_KEYS", "compensate_measurement"]

ENVIRONMENT_KEYS: dict[str, float | None] = {
    "air_temperature_c": None,
    "air_pressure_pa": None,
    "humidity_pct": None,
    "wavelength_nm": HENE_VACUUM_WAVELENGTH_NM,
    "co2_ppm": 450.0,
    "material_temperature_c": 20.0,
    "expansion_ppm_per_k": None,
}
_ROW_COLUMNS = ("air_temperature_c", "air_pressure_pa", "humidity_pct",
                "material_temperature_c")


def _number(env: dict[str, Any], key: str, file: str) -> float:
    v = env[key]
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise VolcalInputError(f"expected a finite number, got {v!r}", file, None,
                               f"environment.{key}")
    return float(v)


def compensate_measurement(meas: Any, file: str | None = None) -> Any:
    """Return a copy of a raw measurement with compensated deviations.

    Parameters
    ----------
    meas : Measurement
        A measurement with ``meta['readings'] == 'raw'``: its deviations are raw laser
        deviations (vacuum wavelength, no material correction) [um].
    file : str, optional
        Name used in error messages (default: the measurement's ``session.toml`` entry).

    Returns
    -------
    Measurement
        A copy whose ``deviation`` is compensated [um], ``meta['readings']`` is
        ``'compensated'`` and ``meta['compensation']`` records the mean refractive index
        and expansion coefficient applied.

    Raises
    ------
    VolcalInputError
        Missing or invalid environment data, naming the key.
    """
    where = file or f"session.toml [measurement {meas.id}]"
    if meas.deviation is None:
        raise VolcalInputError("raw readings need the deviation_um column", meas.file, None,
                               "deviation_um")
    env = meas.meta.get("environment") or {}
    if not isinstance(env, dict):
        raise VolcalInputError("environment must be a table", where, None, "environment")
    unknown = [k for k in env if k not in ENVIRONMENT_KEYS and k not in ("material", "formula")]
    if unknown:
        raise VolcalInputError(f"unknown key (units?): expected one of "
                               f"{', '.join([*ENVIRONMENT_KEYS, 'material', 'formula'])}",
                               where, None, f"environment.{unknown[0]}")
    vals: dict[str, Any] = {}
    for key, default in ENVIRONMENT_KEYS.items():
        if key in meas.columns:
            vals[key] = np.asarray(meas.columns[key], dtype=float)
        elif key in env:
            vals[key] = _number(env, key, where)
        elif default is not None:
            vals[key] = default
        elif key == "expansion_ppm_per_k":
            vals[key] = (expansion_coefficient(env["material"]) if "material" in env else 0.0)
        else:
            raise VolcalInputError(
                f"raw readings need '{key}' in the environment table or as a CSV column",
                where, None, f"environment.{key}")
    formula = env.get("formula", "ciddor")
    if formula not in FORMULAS:
        raise VolcalInputError(f"unknown formula {formula!r}: expected one of "
                               f"{', '.join(FORMULAS)}", where, None, "environment.formula")
    commanded = (meas.positions - meas.positions[0]) @ meas.beam_direction
    try:
        dev = compensate_readings(commanded, meas.deviation, vals["air_temperature_c"],
                                  vals["air_pressure_pa"], vals["humidity_pct"],
                                  vals["wavelength_nm"], vals["material_temperature_c"],
                                  vals["expansion_ppm_per_k"], vals["co2_ppm"], formula)
    except VolcalInputError as exc:
        col = exc.column or ""
        key = {"temperature_c": "air_temperature_c", "pressure_pa": "air_pressure_pa"}.get(
            col, col)
        src = meas.file if key in meas.columns else where
        raise VolcalInputError(exc.message, src, None,
                               key if key in meas.columns else f"environment.{key}") from None
    n = refractive_index(vals["air_temperature_c"], vals["air_pressure_pa"],
                         vals["humidity_pct"], vals["wavelength_nm"], formula, vals["co2_ppm"])
    out = copy.copy(meas)
    out.deviation = dev
    out.meta = dict(meas.meta)
    out.meta["readings"] = "compensated"
    out.meta["compensation"] = {
        "formula": formula,
        "mean_refractive_index": float(np.mean(n)),
        "expansion_ppm_per_k": float(np.mean(vals["expansion_ppm_per_k"])),
    }
    return out
