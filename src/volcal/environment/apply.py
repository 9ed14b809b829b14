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
from collections.abc import Sequence
from typing import Any

import numpy as np

from volcal.environment.compensation import compensate_readings
from volcal.environment.materials import expansion_coefficient, to_20c
from volcal.environment.refractive import (
    FORMULAS,
    HENE_VACUUM_WAVELENGTH_NM,
    refractive_index,
)
from volcal.errors import VolcalInputError

__all__ = ["ENVIRONMENT_KEYS", "READINGS", "check_environment",
           "compensate_measurement", "prepare_readings", "refer_measurement",
           "thermal_record"]

READINGS: tuple[str, ...] = ("deviation", "compensated", "raw")
"""Values of a measurement's ``readings`` key: ``deviation`` (default: as the laser software
compensated them), ``compensated`` (written by volcal after compensating raw readings) and
``raw`` (vacuum wavelength, no material correction: compensated by volcal on reading)."""

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
    t_m = vals["material_temperature_c"]
    out.meta["referred_to_20c"] = True
    out.meta["referral"] = {
        "by": "volcal",
        "material_temperature_c": float(np.mean(t_m)),
        "expansion_ppm_per_k": float(np.mean(vals["expansion_ppm_per_k"])),
        "recorded": bool("material_temperature_c" in meas.columns
                         or "material_temperature_c" in env),
    }
    return out


def check_environment(env: Any, file: Any, where: str) -> dict[str, Any]:
    """Validate a measurement's ``environment`` table where it is read.

    Parameters
    ----------
    env : object
        The table as parsed from ``session.toml``.
    file : str or Path
        ``session.toml``, named in errors.
    where : str
        Key of the measurement (``measurements[2]``); errors name
        ``measurements[2].environment.<key>``.

    Returns
    -------
    dict
        ``env`` (numbers as float).

    Raises
    ------
    VolcalInputError
        Not a table, an unknown key, a value that is not a finite number within the range
        of :data:`volcal.environment.limits.ENVIRONMENT_LIMITS` (with the unit hint), an
        unknown ``material`` (the valid ones listed) or ``formula``.
    """
    from volcal.environment.limits import ENVIRONMENT_LIMITS, check_environment_value
    from volcal.environment.materials import EXPANSION_PPM_PER_K

    key = f"{where}.environment"
    if not isinstance(env, dict):
        raise VolcalInputError("environment must be a table", file, None, key)
    valid = [*ENVIRONMENT_KEYS, "material", "formula"]
    out: dict[str, Any] = {}
    for k, v in env.items():
        if k in ENVIRONMENT_LIMITS:
            out[k] = check_environment_value(v, k, file, f"{key}.{k}")
        elif k == "material":
            try:
                if not isinstance(v, str):
                    raise VolcalInputError("")
                expansion_coefficient(v)
            except VolcalInputError:
                raise VolcalInputError(f"unknown material {v!r}: expected one of "
                                       f"{', '.join(sorted(EXPANSION_PPM_PER_K))} (or give "
                                       "expansion_ppm_per_k [ppm/K])", file, None,
                                       f"{key}.material") from None
            out[k] = v
        elif k == "formula":
            if v not in FORMULAS:
                raise VolcalInputError(f"unknown formula {v!r}: expected one of "
                                       f"{', '.join(FORMULAS)}", file, None, f"{key}.formula")
            out[k] = v
        else:
            raise VolcalInputError(f"unknown key (units?): expected one of {', '.join(valid)}",
                                   file, None, f"{key}.{k}")
    return out


def _readings_keys(meas: Any, file: Any, where: str, kinds: Sequence[Any]
                   ) -> tuple[str, bool | None]:
    """The measurement's ``readings`` and ``referred_to_20c``, checked against its kind."""
    raw_kinds = [k.name for k in kinds if k.raw_readings]
    referable = [k.name for k in kinds if k.referable]
    readings = meas.meta.get("readings", "deviation")
    if not isinstance(readings, str) or readings not in READINGS:
        raise VolcalInputError(f"unknown readings {readings!r}: expected one of "
                               f"{', '.join(READINGS)}", file, None, f"{where}.readings")
    if readings == "raw" and meas.kind not in raw_kinds:
        raise VolcalInputError(f"raw readings are laser lengths ({', '.join(raw_kinds)}); "
                               f"kind {meas.kind!r} has none: remove readings = \"raw\"",
                               file, None, f"{where}.readings")
    referred = meas.meta.get("referred_to_20c")
    if referred is not None and not isinstance(referred, bool):
        raise VolcalInputError(f"expected true or false, got {referred!r}", file, None,
                               f"{where}.referred_to_20c")
    if readings == "raw" and referred:
        raise VolcalInputError("raw readings are not referred to 20 °C (volcal refers them "
                               "from the environment): remove referred_to_20c or set it "
                               "false", file, None, f"{where}.referred_to_20c")
    if referred is False and meas.kind not in referable and readings != "raw":
        raise VolcalInputError(f"volcal refers to 20 °C the readings of "
                               f"{', '.join(referable)} tests, not of a {meas.kind} "
                               "measurement: refer them before the import (or remove the key)",
                               file, None, f"{where}.referred_to_20c")
    ref = meas.meta.get("referral")
    if ref is not None and not isinstance(ref, dict):
        raise VolcalInputError("referral must be a table (written by volcal)", file, None,
                               f"{where}.referral")
    return readings, referred


def prepare_readings(meas: Any, file: Any, where: str, kinds: Sequence[Any]) -> Any:
    """Validate a measurement's thermal record and compensate/refer its readings once.

    The one place where a session's readings are referred to 20 degC (called by
    :func:`volcal.session.format.read_session`): raw readings are compensated from the
    environment (:func:`compensate_measurement`); compensated readings with
    ``referred_to_20c = false`` are referred (:func:`refer_measurement`); others are
    taken as they are. Every command then sees the same values, with or without a budget.

    Parameters
    ----------
    meas : Measurement
        As read.
    file : str or Path
        ``session.toml`` (``'<path>/session.toml [<id>]'`` in the reader), for errors.
    where : str
        The measurement's key (``measurements[2]``), for errors.
    kinds : sequence of Kind
        The registered measurement kinds (:func:`volcal.session.kinds.kinds`): their
        ``raw_readings`` and ``referable`` say which kinds take raw readings and which
        volcal refers to 20 degC (the environment sits below the registry).

    Returns
    -------
    Measurement
        ``meas`` or a compensated/referred copy.

    Raises
    ------
    VolcalInputError
        An unknown ``readings`` value (the valid ones listed), ``referred_to_20c`` not a
        boolean or contradicting raw readings, an invalid ``environment`` table,
        ``referred_to_20c = false`` without a material temperature or expansion.
    """
    readings, referred = _readings_keys(meas, file, where, kinds)
    if "environment" in meas.meta:
        check_environment(meas.meta["environment"], file, where)
    if meas.deviation is None:
        return meas
    if readings == "raw":
        return compensate_measurement(meas, file)
    if referred is False:
        return refer_measurement(meas, file, where)
    return meas


def refer_measurement(meas: Any, file: Any = None, where: str | None = None) -> Any:
    """Refer compensated readings to 20 degC (ISO 1) from the measurement's environment.

    The readings are laser deviations compensated for the air but not for the material
    (``referred_to_20c = false``): the measured displacement ``L = C + d`` from the first
    row (``C`` commanded along the beam [mm], ``d`` the deviation) becomes
    ``L_20 = L / (1 + alpha (t_m - 20))`` and the deviation ``L_20 - C``.

    Parameters
    ----------
    meas : Measurement
        With deviations [um] and an ``environment`` giving ``material_temperature_c``
        [degC] (or the CSV column of that name, row by row) and ``material`` or
        ``expansion_ppm_per_k`` [ppm/K].
    file : str or Path, optional
        ``session.toml``, for errors.
    where : str, optional
        The measurement's key (``measurements[2]``), for errors.

    Returns
    -------
    Measurement
        A copy with referred deviations [um], ``meta['referred_to_20c'] = True`` and
        ``meta['referral']`` recording the temperature and coefficient applied (so that a
        session written back is not referred twice).

    Raises
    ------
    VolcalInputError
        No material temperature, or no expansion coefficient, naming the key.
    """
    where = where or f"measurement {meas.id!r}"
    env = meas.meta.get("environment") or {}
    if "material_temperature_c" in meas.columns:
        t_m: Any = np.asarray(meas.columns["material_temperature_c"], dtype=float)
    elif "material_temperature_c" in env:
        t_m = float(env["material_temperature_c"])
    else:
        raise VolcalInputError("referred_to_20c = false: volcal refers the readings to 20 °C "
                               "from the material temperature, and none is recorded (give "
                               f"{where}.environment.material_temperature_c [degC] or a "
                               "material_temperature_c column)", file, None,
                               f"{where}.environment.material_temperature_c")
    if "expansion_ppm_per_k" in env:
        alpha = float(env["expansion_ppm_per_k"])
    elif "material" in env:
        alpha = expansion_coefficient(env["material"])
    else:
        raise VolcalInputError("referred_to_20c = false: volcal refers the readings to 20 °C "
                               "and needs the expansion coefficient (give "
                               f"{where}.environment.material = \"steel\" or "
                               "expansion_ppm_per_k [ppm/K])", file, None,
                               f"{where}.environment.expansion_ppm_per_k")
    commanded = (meas.positions - meas.positions[0]) @ meas.beam_direction
    measured = commanded + np.asarray(meas.deviation, dtype=float) * 1e-3
    out = copy.copy(meas)
    out.deviation = (to_20c(measured, t_m, alpha) - commanded) * 1e3
    out.meta = dict(meas.meta)
    out.meta["referred_to_20c"] = True
    out.meta["referral"] = {"by": "volcal", "material_temperature_c": float(np.mean(t_m)),
                            "expansion_ppm_per_k": alpha, "recorded": True}
    return out


def _mean_recorded(meas: Any, key: str) -> float | None:
    """Mean of a quantity the measurement records (CSV column first, else its table)."""
    if key in meas.columns:
        v = np.asarray(meas.columns[key], dtype=float)
        v = v[np.isfinite(v)]
        if v.size:
            return float(v.mean())
    env = meas.meta.get("environment") or {}
    x = env.get(key)
    if isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x):
        return float(x)
    return None


def thermal_record(meas: Any) -> dict[str, Any]:
    """How a measurement's readings were compensated and referred to 20 degC.

    Parameters
    ----------
    meas : Measurement
        As returned by the session reader (after :func:`prepare_readings`).

    Returns
    -------
    dict
        ``compensated_by``: ``'laser software'`` or ``'volcal (raw readings)'``;
        ``referred_by``: ``'laser software'``, ``'volcal'``, ``'not stated'`` or
        ``'not referred'`` (``referred_to_20c = false`` on a measurement that was not read
        from a session file: :func:`prepare_readings` refers it);
        ``referred_to_20c``: True, False (not referred) or None (not stated);
        ``material_temperature_c`` [degC] and ``expansion_ppm_per_k`` [ppm/K] applied by
        volcal (None otherwise); ``operating_point``: the environment the session records
        (means, by environment key), which serves a budget's sensitivities;
        ``text``: one sentence.
    """
    meta = meas.meta
    comp = "volcal (raw readings)" if "compensation" in meta else "laser software"
    ref = meta.get("referral") if isinstance(meta.get("referral"), dict) else None
    referred = meta.get("referred_to_20c")
    by = "volcal" if ref is not None else ("laser software" if referred is True else
                                           "not referred" if referred is False else
                                           "not stated")
    rec: dict[str, Any] = {"compensated_by": comp, "referred_by": by,
                           "referred_to_20c": {"not stated": None,
                                               "not referred": False}.get(by, True),
                           "material_temperature_c": None, "expansion_ppm_per_k": None}
    text = ("compensated by volcal from raw readings" if comp != "laser software"
            else "compensated by the laser software")
    if ref is not None:
        t, a = ref.get("material_temperature_c"), ref.get("expansion_ppm_per_k")
        rec["material_temperature_c"], rec["expansion_ppm_per_k"] = t, a
        note = "" if ref.get("recorded", True) else ", no material temperature recorded"
        text += (f"; referred to 20 °C by volcal at t = {float(t):g} °C "
                 f"(alpha = {float(a):g} ppm/K{note})")
    elif by == "laser software":
        text += "; referred to 20 °C by the laser software"
    elif by == "not referred":  # a Measurement built in Python, not read from a session
        text += ("; not referred to 20 °C (referred_to_20c = false: volcal refers readings "
                 "where a session is read)")
    else:
        text += "; referral to 20 °C not stated (readings taken as they are)"
    rec["text"] = text
    op = {k: _mean_recorded(meas, k) for k in ENVIRONMENT_KEYS}
    env = meta.get("environment") or {}
    if op.get("expansion_ppm_per_k") is None and isinstance(env.get("material"), str):
        op["expansion_ppm_per_k"] = expansion_coefficient(env["material"])
    rec["operating_point"] = {k: v for k, v in op.items() if v is not None}
    return rec
