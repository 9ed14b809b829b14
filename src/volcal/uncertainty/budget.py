"""The uncertainty budget file (TOML): reader, validator and template.

Every ``u_*`` key is a *standard* uncertainty (one standard deviation), never a
half-width or an expanded uncertainty. Each may carry its degrees of freedom
(``<key>_dof``, default infinite) and the distribution it was evaluated from
(``<key>_distribution``: ``normal`` (default), ``rectangular``, ``triangular``,
``arcsine``); the distribution is recorded in the budget and used by Monte Carlo checks,
the propagation itself needs only the standard uncertainty.

=========================  ==========================================================
``[laser]``
u_wavelength_ppm           vacuum wavelength of the laser [ppm]
wavelength_nm              vacuum wavelength [nm] (default 632.9912, HeNe)
``[air]``
temperature_c              air temperature at the test [degC] (operating point)
pressure_pa                air pressure [Pa] (operating point)
humidity_pct               relative humidity [%] (operating point)
u_temperature_k            air temperature sensor [K]
u_pressure_pa              pressure sensor [Pa]
u_humidity_pct             humidity sensor [%RH]
change_temperature_k       standard uncertainty of the air's change during the test
change_pressure_pa         (dead-path error) [K], [Pa], [%RH]; when absent, the
change_humidity_pct        sensor's ``u`` (the change is not known better)
formula                    ``ciddor`` (default) or ``edlen``: sensitivities of n
co2_ppm                    CO2 mole fraction [umol/mol] (default 450)
``[material]``
temperature_c              temperature of the machine scale [degC]
u_temperature_k            material temperature sensor [K]
expansion_ppm_per_k        expansion coefficient of the scale [ppm/K]
u_expansion_ppm_per_k      its standard uncertainty [ppm/K]
referred_to_20c            retired (read, never applied): whether the readings are
                           referred to 20 degC is the measurement's ``referred_to_20c``
                           in ``session.toml``; a value here is cross-checked against
                           it with a warning (:func:`cross_check_referral`)
``[setup]``
u_misalignment_urad        beam misalignment angle [urad] (cosine error)
dead_path_mm               laser to the reflector's datum position [mm]
datum_mm                   target where the laser was zeroed [mm] (default: the
                           first, lowest, target)
``[optics]``               optional (direct optics; every key has a data-sheet default)
u_straightness_scale_pct   scale (calibration) error of the straightness optics [%]
u_angular_scale_pct        scale error of the angular optics [%]
u_level_scale_pct          scale error of the differential electronic level [%]
u_roll_scale_pct           scale error of a 6-DOF system's roll channel [%]
u_straightness_um          one straightness reading [um] (independent per reading)
u_angular_urad             one angular-optics reading [urad] (independent per reading)
u_level_urad               one level reading [urad] (independent per reading)
u_roll_urad                one roll-optics reading [urad] (independent per reading)
scale_correlation          ``instrument`` (default): one scale error per optic (target),
                           common to every line read with it; ``measurement``: one per
                           line (each line read with another optic of that kind)
``[angular]``              optional (rotary tests; every key has a data-sheet default)
u_calibrator_urad          rotary calibrator's accuracy [urad] (XR20: +-1 arcsec, rect.)
u_index_table_urad         precision index table [urad] (Keysight 5530 360-tooth table:
                           +-0.5 arcsec, rect.), for tests with target ``index_table``
u_eccentricity_urad_per_mm eccentric mounting, per mm of eccentricity [urad/mm] (XR20:
                           under +-0.5 arcsec for 1 mm, rect.)
=========================  ==========================================================

Every problem raises :class:`~volcal.errors.VolcalInputError` naming the file and the
key (``section.key``) and the valid choices; the reader writes nothing.

References
----------
.. [1] JCGM 100:2008 (GUM), 4.3 (type B evaluation), 6.3 (coverage factor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from volcal.environment.limits import ENVIRONMENT_LIMITS, Limit, range_message
from volcal.environment.refractive import FORMULAS, HENE_VACUUM_WAVELENGTH_NM
from volcal.errors import VolcalInputError
from volcal.io.tomlread import read_toml

__all__ = ["DISTRIBUTIONS", "OPERATING_KEYS", "OPTIC_KEYS", "Budget", "BudgetWarning", "Input",
           "cross_check_referral", "parse_budget", "read_budget", "template_text"]

DISTRIBUTIONS: tuple[str, ...] = ("normal", "rectangular", "triangular", "arcsine")

_REQUIRED = object()
_ARCSEC_URAD = math.pi / 648000.0 * 1e6
"""One arcsecond [urad]."""


@dataclass(frozen=True)
class _Key:
    kind: str          # 'value', 'u', 'bool', 'choice'
    default: Any       # _REQUIRED, None (optional) or a value
    unit: str
    lo: float = -math.inf
    hi: float = math.inf
    hint: str = ""
    choices: tuple[str, ...] = FORMULAS
    distribution: str = "normal"  # of a defaulted u (a data sheet's +-a: rectangular)


def _env(key: str, default: Any = _REQUIRED) -> _Key:
    """An operating-point key with the range and hint of ``ENVIRONMENT_LIMITS[key]``."""
    lim = ENVIRONMENT_LIMITS[key]
    return _Key("value", default, lim.unit, lim.lo, lim.hi, lim.hint)


#: Keys of every section: kind, default, unit, range of validity.
SCHEMA: dict[str, dict[str, _Key]] = {
    "laser": {
        "u_wavelength_ppm": _Key("u", _REQUIRED, "ppm", hi=100.0),
        "wavelength_nm": _env("wavelength_nm", HENE_VACUUM_WAVELENGTH_NM),
    },
    "air": {
        "temperature_c": _env("air_temperature_c"),
        "pressure_pa": _env("air_pressure_pa"),
        "humidity_pct": _env("humidity_pct"),
        "u_temperature_k": _Key("u", _REQUIRED, "K", hi=20.0),
        "u_pressure_pa": _Key("u", _REQUIRED, "Pa", hi=20e3),
        "u_humidity_pct": _Key("u", _REQUIRED, "%", hi=100.0),
        "change_temperature_k": _Key("u", None, "K", hi=20.0),
        "change_pressure_pa": _Key("u", None, "Pa", hi=20e3),
        "change_humidity_pct": _Key("u", None, "%", hi=100.0),
        "formula": _Key("choice", "ciddor", ""),
        "co2_ppm": _env("co2_ppm", 450.0),
    },
    "material": {
        "temperature_c": _env("material_temperature_c"),
        "u_temperature_k": _Key("u", _REQUIRED, "K", hi=20.0),
        "expansion_ppm_per_k": _env("expansion_ppm_per_k"),
        "u_expansion_ppm_per_k": _Key("u", _REQUIRED, "ppm/K", hi=50.0),
        "referred_to_20c": _Key("bool", None, ""),  # retired: cross-checked, never applied
    },
    "setup": {
        "u_misalignment_urad": _Key("u", _REQUIRED, "urad", hi=50e3),
        "dead_path_mm": _Key("value", _REQUIRED, "mm", 0.0, 100e3),
        "datum_mm": _Key("value", None, "mm", -1e6, 1e6),
    },
    "optics": {
        "u_straightness_scale_pct": _Key("u", 0.5 / math.sqrt(3), "%", hi=20.0,
                                         hint="percent: 0.29, not 0.0029",
                                         distribution="rectangular"),
        "u_angular_scale_pct": _Key("u", 0.2 / math.sqrt(3), "%", hi=20.0,
                                    hint="percent: 0.12, not 0.0012",
                                    distribution="rectangular"),
        "u_level_scale_pct": _Key("u", 1.0 / math.sqrt(3), "%", hi=20.0,
                                  hint="percent: 0.58, not 0.0058",
                                  distribution="rectangular"),
        "u_roll_scale_pct": _Key("u", 1.0 / math.sqrt(3), "%", hi=20.0,
                                 hint="percent: 0.58, not 0.0058",
                                 distribution="rectangular"),
        "u_straightness_um": _Key("u", 0.5 / math.sqrt(3), "um", hi=100.0,
                                  hint="micrometres: 0.29, not 0.00029 mm",
                                  distribution="rectangular"),
        "u_angular_urad": _Key("u", 0.5 / math.sqrt(3), "urad", hi=1000.0,
                               hint="microradians: 1 arcsec = 4.85 urad",
                               distribution="rectangular"),
        "u_level_urad": _Key("u", 1.0 / math.sqrt(3), "urad", hi=1000.0,
                             hint="microradians: 1 um/m = 1 urad",
                             distribution="rectangular"),
        "u_roll_urad": _Key("u", 1.0 / math.sqrt(3), "urad", hi=1000.0,
                            hint="microradians", distribution="rectangular"),
        "scale_correlation": _Key("choice", "instrument", "",
                                  choices=("instrument", "measurement")),
    },
    "angular": {  # rotary tests (volcal.standards.iso230_2_rotary); data-sheet defaults
        "u_calibrator_urad": _Key("u", 1.0 * _ARCSEC_URAD / math.sqrt(3), "urad", hi=1000.0,
                                  hint="microradians: 1 arcsec = 4.848 urad",
                                  distribution="rectangular"),
        "u_index_table_urad": _Key("u", 0.5 * _ARCSEC_URAD / math.sqrt(3), "urad",
                                   hi=1000.0, hint="microradians: 1 arcsec = 4.848 urad",
                                   distribution="rectangular"),
        "u_eccentricity_urad_per_mm": _Key("u", 0.5 * _ARCSEC_URAD / math.sqrt(3), "urad/mm",
                                           hi=1000.0, hint="microradians per mm",
                                           distribution="rectangular"),
    },
}

#: Sections whose every key has a default: the section may be absent from the file.
OPTIONAL_SECTIONS: tuple[str, ...] = ("optics", "angular")

#: ``[optics]`` keys of each direct-optics target: (scale [%], one reading [um or urad]).
OPTIC_KEYS: dict[str, tuple[str, str]] = {
    "straightness_optics": ("optics.u_straightness_scale_pct", "optics.u_straightness_um"),
    "angular_optics": ("optics.u_angular_scale_pct", "optics.u_angular_urad"),
    "level": ("optics.u_level_scale_pct", "optics.u_level_urad"),
    "roll_optics": ("optics.u_roll_scale_pct", "optics.u_roll_urad"),
}


@dataclass(frozen=True)
class Input:
    """A standard uncertainty with its degrees of freedom and distribution.

    Attributes
    ----------
    u : float
        Standard uncertainty, in the unit of its key.
    dof : float
        Degrees of freedom (``inf`` for a type B evaluation known exactly).
    distribution : str
        One of :data:`DISTRIBUTIONS`.
    """

    u: float
    dof: float = math.inf
    distribution: str = "normal"


@dataclass
class Budget:
    """A validated budget file.

    Attributes
    ----------
    values : dict of str to float, bool or str
        Operating point and settings, by ``section.key`` (e.g. ``'air.temperature_c'``).
    inputs : dict of str to Input
        Standard uncertainties by ``section.key`` (e.g. ``'air.u_temperature_k'``).
    file : str or None
        Source file, for messages.
    notes : list of str
        Defaults taken (keys absent from the file), for the output.
    defaulted : list of str
        ``[optics]`` keys absent from the file, taken from the data-sheet defaults (said
        by the outputs that use them, not in ``notes``: a laser-only evaluation does not
        use them).
    """

    values: dict[str, Any]
    inputs: dict[str, Input]
    file: str | None = None
    notes: list[str] = field(default_factory=list)
    defaulted: list[str] = field(default_factory=list)

    def __getitem__(self, key: str) -> Any:
        """``budget['air.temperature_c']`` (a value) or ``budget['air.u_temperature_k']``."""
        if key in self.inputs:
            return self.inputs[key]
        return self.values[key]

    def at(self, operating: dict[str, float] | None) -> Budget:
        """The budget at the operating point a session records (the sensitivities only).

        Parameters
        ----------
        operating : dict of str to float, optional
            Values recorded by the measurement, by environment key (``air_temperature_c``
            [degC], ``air_pressure_pa`` [Pa], ``humidity_pct`` [%], ``wavelength_nm``
            [nm], ``co2_ppm`` [umol/mol], ``material_temperature_c`` [degC],
            ``expansion_ppm_per_k`` [ppm/K]); keys absent keep the budget's value.

        Returns
        -------
        Budget
            A copy whose operating point is the recorded one where there is one (the
            standard uncertainties are the budget's), with a note naming what the
            session gave; ``self`` when nothing is recorded.
        """
        new = {OPERATING_KEYS[k]: float(v) for k, v in (operating or {}).items()
               if k in OPERATING_KEYS and v is not None}
        if not new:
            return self
        import dataclasses

        taken = ", ".join(f"{k} = {v:g}" for k, v in new.items())
        return dataclasses.replace(
            self, values={**self.values, **new},
            notes=[*self.notes, f"operating point from the session: {taken} (the budget's "
                   "serve only what the session does not record)"])


#: A measurement's environment key -> the budget's operating-point key it replaces.
OPERATING_KEYS: dict[str, str] = {
    "air_temperature_c": "air.temperature_c", "air_pressure_pa": "air.pressure_pa",
    "humidity_pct": "air.humidity_pct", "wavelength_nm": "laser.wavelength_nm",
    "co2_ppm": "air.co2_ppm", "material_temperature_c": "material.temperature_c",
    "expansion_ppm_per_k": "material.expansion_ppm_per_k",
}


class BudgetWarning(UserWarning):
    """A budget that disagrees with the session it is applied to (printed on stderr)."""


def cross_check_referral(budget: Budget, referred: bool | None, what: str) -> None:
    """Compare the budget's retired ``[material] referred_to_20c`` with the readings' record.

    Parameters
    ----------
    budget : Budget
        The budget (``values['material.referred_to_20c']`` present only when the file
        states it).
    referred : bool or None
        Whether the readings as given were referred to 20 degC by the laser software
        (False: volcal refers them from the session, or raw readings), None when nothing
        is recorded (a positioning CSV, a measurement without ``referred_to_20c``).
    what : str
        The readings (``"measurement 'lin-x'"``, a file name), for the message.

    Warns
    -----
    BudgetWarning
        The budget states the key and it disagrees with the record, or nothing is
        recorded: the budget's key is never applied.
    """
    stated = budget.values.get("material.referred_to_20c")
    if stated is None or stated == referred:
        return
    import warnings

    src = budget.file or "the budget"
    if referred is None:  # one line for every such test (the same text is shown once)
        rec = ("readings whose referral to 20 °C is not recorded (no referred_to_20c in "
               "session.toml, or a positioning file read alone) are taken as they are")
    else:
        rec = (f"the readings of {what} "
               + ("were referred to 20 °C by the laser software (taken as they are)"
                  if referred else "are referred to 20 °C by volcal from the session's "
                  "environment"))
    text = (f"{src}: [material] referred_to_20c = {str(stated).lower()} is retired and not "
            f"applied: {rec}; state referred_to_20c per measurement in session.toml "
            "(docs/uncertainty.md, migration)")
    if text not in _WARNED:  # once per process, wherever the budget is applied
        _WARNED.add(text)
        warnings.warn(text, BudgetWarning, stacklevel=3)


_WARNED: set[str] = set()


def _number(v: Any, where: str, file: str | None, k: _Key) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise VolcalInputError(f"expected a number [{k.unit}], got {v!r}", file, None, where)
    x = float(v)
    if not math.isfinite(x):
        raise VolcalInputError(f"must be a finite number [{k.unit}], got {v!r}", file, None,
                               where)
    return x


def _range_error(x: float, where: str, file: str | None, k: _Key) -> VolcalInputError:
    return VolcalInputError(range_message(x, where, Limit(k.lo, k.hi, k.unit, k.hint)), file,
                            None, where)


def parse_budget(doc: dict[str, Any], file: str | Path | None = None) -> Budget:
    """Validate a budget document (the parsed TOML).

    Parameters
    ----------
    doc : dict
        Sections ``laser``, ``air``, ``material``, ``setup`` and the optional ``optics``
        (see the module docstring).
    file : str or Path, optional
        Source file named in errors.

    Returns
    -------
    Budget

    Raises
    ------
    VolcalInputError
        Unknown section or key, missing required key (the operating point included), a
        negative or non-finite ``u``, a value outside its range (e.g. pressure in hPa),
        an unknown distribution or formula; naming the file and ``section.key``.
    """
    f = None if file is None else str(file)
    unknown = [s for s in doc if s not in SCHEMA]
    if unknown:
        raise VolcalInputError(f"unknown section [{unknown[0]}]: expected "
                               f"{', '.join(f'[{s}]' for s in SCHEMA)}", f, None, unknown[0])
    values: dict[str, Any] = {}
    inputs: dict[str, Input] = {}
    notes: list[str] = []
    defaulted: list[str] = []
    for sec, keys in SCHEMA.items():
        table = doc.get(sec, {})
        if not isinstance(table, dict):
            raise VolcalInputError("expected a table", f, None, sec)
        allowed = set(keys)
        allowed |= {f"{k}_{s}" for k, spec in keys.items() if spec.kind == "u"
                    for s in ("dof", "distribution")}
        for k in table:
            if k not in allowed:
                raise VolcalInputError(
                    f"unknown key (units?): [{sec}] takes {', '.join(keys)} (and "
                    "<u key>_dof, <u key>_distribution)", f, None, f"{sec}.{k}")
        for k, spec in keys.items():
            where = f"{sec}.{k}"
            if k not in table:
                if spec.default is _REQUIRED:
                    what = ("the operating point" if spec.kind == "value" else
                            "a standard uncertainty (0 if negligible)")
                    raise VolcalInputError(f"missing key: {what} [{spec.unit}] is required",
                                           f, None, where)
                if spec.default is not None and spec.kind == "u":
                    inputs[where] = Input(float(spec.default), math.inf, spec.distribution)
                elif spec.default is not None:
                    values[where] = spec.default
                if sec in OPTIONAL_SECTIONS:
                    defaulted.append(where)
                continue
            v = table[k]
            if spec.kind == "bool":
                if not isinstance(v, bool):
                    raise VolcalInputError(f"expected true or false, got {v!r}", f, None,
                                           where)
                values[where] = v
            elif spec.kind == "choice":
                if v not in spec.choices:
                    raise VolcalInputError(f"expected one of {', '.join(spec.choices)}, got "
                                           f"{v!r}", f, None, where)
                values[where] = v
            else:
                x = _number(v, where, f, spec)
                if spec.kind == "u" and x < 0:
                    raise VolcalInputError(f"a standard uncertainty cannot be negative: {x:g}",
                                           f, None, where)
                if not spec.lo <= x <= spec.hi:
                    raise _range_error(x, where, f, spec)
                if spec.kind == "u":
                    inputs[where] = Input(x, _dof(table, k, sec, f), _dist(table, k, sec, f))
                else:
                    values[where] = x
    if "material.referred_to_20c" in values:
        notes.append("[material] referred_to_20c is retired: whether readings are referred "
                     "to 20 °C is a key of each measurement (session.toml); the budget's is "
                     "only cross-checked against it and never changes a value")
    for k in ("temperature_k", "pressure_pa", "humidity_pct"):
        if f"air.change_{k}" not in inputs:
            inputs[f"air.change_{k}"] = inputs[f"air.u_{k}"]
            if values["setup.dead_path_mm"] > 0:
                notes.append(f"[air] change_{k} not given: the air's change during the test "
                             f"(dead path) taken as u_{k}")
    return Budget(values, inputs, f, notes, defaulted)


def _dof(table: dict[str, Any], k: str, sec: str, f: str | None) -> float:
    key = f"{k}_dof"
    if key not in table:
        return math.inf
    v = table[key]
    if v == "inf":
        return math.inf
    if isinstance(v, bool) or not isinstance(v, int | float) or not v >= 1:
        raise VolcalInputError(f"degrees of freedom must be a number >= 1 or \"inf\", got "
                               f"{v!r}", f, None, f"{sec}.{key}")
    return float(v)


def _dist(table: dict[str, Any], k: str, sec: str, f: str | None) -> str:
    key = f"{k}_distribution"
    v = table.get(key, "normal")
    if v not in DISTRIBUTIONS:
        raise VolcalInputError(f"expected one of {', '.join(DISTRIBUTIONS)}, got {v!r}", f,
                               None, f"{sec}.{key}")
    return str(v)


def read_budget(path: str | Path) -> Budget:
    """Read and validate a budget file.

    Parameters
    ----------
    path : str or Path
        TOML file (see :func:`template_text`).

    Returns
    -------
    Budget

    Raises
    ------
    VolcalInputError
        Missing or unreadable file, invalid TOML, or any problem of :func:`parse_budget`.
    """
    doc, _ = read_toml(path, "budget file")
    return parse_budget(doc, Path(path))


#: The template written by ``volcal budget --template``.
TEMPLATE = """\
# volcal uncertainty budget of a laser positioning measurement (docs/uncertainty.md).
#
# Every u_* is a STANDARD uncertainty (one standard deviation) in the unit of its key.
# A data-sheet accuracy "+-a" of a rectangular distribution is u = a / sqrt(3).
# Each u_* may carry <key>_dof = 10 (degrees of freedom, default "inf") and
# <key>_distribution = "normal" | "rectangular" | "triangular" | "arcsine".
#
# DEFAULTS BELOW ARE TYPICAL DATA-SHEET VALUES, NOT YOUR INSTRUMENT'S: replace them by
# the figures of your laser's and sensors' calibration certificates.

[laser]
# Typical data sheet: laser frequency (vacuum wavelength) accuracy +-0.05 ppm,
# rectangular -> u = 0.05 / sqrt(3).
u_wavelength_ppm = 0.029
u_wavelength_ppm_distribution = "rectangular"
wavelength_nm = 632.9912

[air]
# Operating point: the air during the test (sensitivities of the refractive index), used
# where the measurement's environment records no air.
temperature_c = 20.0
pressure_pa = 101325.0
humidity_pct = 50.0
# Typical environment unit data sheet: air temperature +-0.2 K, pressure +-100 Pa
# (1 hPa), humidity +-6 %RH, all rectangular.
u_temperature_k = 0.12
u_temperature_k_distribution = "rectangular"
u_pressure_pa = 58.0
u_pressure_pa_distribution = "rectangular"
u_humidity_pct = 3.5
u_humidity_pct_distribution = "rectangular"
# The air's change during the test acts on the dead path only. Without these keys it is
# taken as the sensors' u above. Standard uncertainties [K], [Pa], [%RH]:
# change_temperature_k = 0.3
# change_pressure_pa = 100.0
# change_humidity_pct = 3.0
formula = "ciddor"

[material]
# Temperature of the machine scale during the test and its expansion coefficient:
# the operating point of the material uncertainty's sensitivities, used only for a
# measurement whose session records none (its environment's material_temperature_c,
# material or expansion_ppm_per_k win). The budget never corrects a reading: whether the
# readings are referred to 20 degC is the measurement's referred_to_20c in session.toml.
# Migration: the key referred_to_20c of this section is retired; it is still read and
# compared with the session (a warning when they disagree), never applied. Remove it and
# state referred_to_20c per measurement instead (docs/uncertainty.md).
temperature_c = 20.0
# Typical material sensor data sheet: +-0.1 K, rectangular.
u_temperature_k = 0.06
u_temperature_k_distribution = "rectangular"
# Steel (typical handbook value, ISO/TR 16015); coefficient known to +-1 ppm/K.
expansion_ppm_per_k = 11.5
u_expansion_ppm_per_k = 0.58
u_expansion_ppm_per_k_distribution = "rectangular"

[setup]
# Beam misalignment to the axis (cosine error, a one-sided bias): typical of a beam
# aligned by eye on the target over 1 m, 0.1 mm -> 100 urad.
u_misalignment_urad = 100.0
# Distance from the laser to the reflector at the datum (where the reading was zeroed).
dead_path_mm = 0.0
# datum_mm = 0.0   # target where the laser was zeroed (default: the lowest target)

[optics]
# Direct optics (straightness, angular, level, roll); optional: without this section
# these data-sheet defaults are used, and the outputs that use them say so.
# Scale (calibration) error of each optic, a percentage of the reading, and the
# uncertainty of one reading (resolution, non-linearity, air: independent per reading).
# Renishaw XL-80 specification as commonly quoted (not checked against the data
# sheet here; docs/uncertainty.md), short-range straightness optics: +-0.5 % of the reading
# +-0.5 um (+-0.15 M^2 um, M the travel in metres), rectangular:
u_straightness_scale_pct = 0.29
u_straightness_scale_pct_distribution = "rectangular"
u_straightness_um = 0.29
u_straightness_um_distribution = "rectangular"
# Renishaw XL-80 specification as quoted, angular optics: +-0.2 % of the reading +-0.5 urad
# (+-0.1 M urad), rectangular:
u_angular_scale_pct = 0.12
u_angular_scale_pct_distribution = "rectangular"
u_angular_urad = 0.29
u_angular_urad_distribution = "rectangular"
# Differential electronic level and a 6-DOF roll channel: +-1 % of the reading
# +-1 urad, rectangular (an assumption: replace it by your level's certificate).
u_level_scale_pct = 0.58
u_level_scale_pct_distribution = "rectangular"
u_level_urad = 0.58
u_level_urad_distribution = "rectangular"
u_roll_scale_pct = 0.58
u_roll_scale_pct_distribution = "rectangular"
u_roll_urad = 0.58
u_roll_urad_distribution = "rectangular"
# "instrument": one scale error per optic, common to every line read with it (one kit
# in the case); "measurement": one per line (lines read with different optics).
scale_correlation = "instrument"
# The optical square's deviation from 90 degrees and its u are the session's
# [references.NAME] square_deviation_urad / u_square_urad (its certificate), not here.

[angular]
# Rotary tests (kind "rotary"); optional: without this section these data-sheet defaults
# are used and the outputs say so. 1 arcsec = 4.8481 urad.
# Renishaw XR20 rotary calibrator (data sheet; white paper TE327): within +-1 arcsec,
# rectangular -> u = 4.8481 / sqrt(3):
u_calibrator_urad = 2.80
u_calibrator_urad_distribution = "rectangular"
# Keysight 5530 precision index table (Measurements Reference Guide, ch. 4): 360 teeth,
# +-0.5 arcsec, rectangular (tests with target = "index_table"):
u_index_table_urad = 1.40
u_index_table_urad_distribution = "rectangular"
# Eccentric (off-axis) mounting, per mm of the test's eccentricity_mm (TE327: 1 mm adds
# under +-0.5 arcsec), rectangular:
u_eccentricity_urad_per_mm = 1.40
u_eccentricity_urad_per_mm_distribution = "rectangular"
"""


def template_text() -> str:
    """The documented budget template (``volcal budget --template``).

    Returns
    -------
    str
        TOML text with typical data-sheet defaults, stated as such.
    """
    return TEMPLATE
