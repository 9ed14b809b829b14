"""The header block of a laser export: date, operator, air and material temperatures.

Vendor exports put a few lines above the table (``Date: 20.11.2026``, ``Operator: A.
Technician``, ``Air temperature: 20,4 °C``, ``Air pressure: 1013,2 hPa``, ``Humidity:
45 %``, ``Material temperature: 20,8 °C``). :func:`read_header` finds these fields by
their label (the defaults of :data:`LABELS`, or the label a ``--map`` key names) and
converts them into the session's keys: ``[calibration] date`` and ``operator``
(:mod:`volcal.session.identity`) and the measurement's ``environment`` table
(``air_temperature_c`` [degC], ``air_pressure_pa`` [Pa], ``humidity_pct`` [%],
``material_temperature_c`` [degC], ``expansion_ppm_per_k`` [ppm/K];
``docs/environment.md``). ``Material compensation: On`` / ``Off`` (Renishaw's and
Keysight's exports state whether the software applied the material correction) becomes
the measurement's ``referred_to_20c`` (``docs/formats.md``): with ``Off`` and a material
temperature, volcal refers the readings to 20 degC when the session is read. A field
named by ``--map`` must be found and must read; a field found by a default label that
does not read (a ``Date`` of ``n/a``) is reported and left out.
"""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass
from pathlib import Path

from volcal.errors import VolcalInputError

__all__ = ["CALIBRATION_FIELDS", "ENVIRONMENT_FIELDS", "HEADER_KEYS", "LABELS",
           "MEASUREMENT_FIELDS", "HeaderField", "read_header", "split_field"]

CALIBRATION_FIELDS: tuple[str, ...] = ("date", "operator")
"""Header fields that go to ``[calibration]``."""
ENVIRONMENT_FIELDS: tuple[str, ...] = ("air_temperature_c", "air_pressure_pa", "humidity_pct",
                                       "material_temperature_c")
"""Header fields that go to the measurement's ``environment`` table (also CSV columns)."""
MEASUREMENT_FIELDS: tuple[str, ...] = ("referred_to_20c", "expansion_ppm_per_k")
"""Header fields read by their default labels only (never a column): whether the laser
software applied the material correction (the measurement's ``referred_to_20c``) and the
expansion coefficient it used (``environment.expansion_ppm_per_k`` [ppm/K])."""
HEADER_KEYS: tuple[str, ...] = (*CALIBRATION_FIELDS, *ENVIRONMENT_FIELDS, *MEASUREMENT_FIELDS)

LABELS: dict[str, tuple[str, ...]] = {
    "date": ("date", "test date", "date of test", "measurement date", "date of measurement",
             "start date", "datum"),
    "operator": ("operator", "tested by", "measured by", "technician", "engineer", "user",
                 "bediener", "prüfer"),
    "air_temperature_c": ("air temperature", "air temp", "air temp.", "temperature air",
                          "lufttemperatur"),
    "air_pressure_pa": ("air pressure", "pressure", "barometric pressure", "baro pressure",
                        "luftdruck"),
    "humidity_pct": ("humidity", "relative humidity", "rel. humidity", "air humidity", "rh",
                     "luftfeuchte", "luftfeuchtigkeit"),
    "material_temperature_c": ("material temperature", "material temp", "material temp.",
                               "mat. temp", "mat temp", "machine temperature",
                               "workpiece temperature", "materialtemperatur"),
    "referred_to_20c": ("material compensation", "material comp", "material comp.",
                        "material temperature compensation", "material temp compensation",
                        "material expansion compensation", "expansion compensation",
                        "material normalization", "material normalisation",
                        "materialkompensation", "werkstoffkompensation"),
    "expansion_ppm_per_k": ("expansion coefficient", "material expansion coefficient",
                            "expansion coeff", "expansion coeff.", "exp. coeff", "exp. coeff.",
                            "coefficient of expansion", "thermal expansion coefficient",
                            "material expansion", "ausdehnungskoeffizient"),
}
"""Labels recognised without ``--map`` (compared without case, unit and ``:``)."""

RANGES: dict[str, tuple[float, float]] = {
    "air_temperature_c": (-40.0, 100.0),
    "material_temperature_c": (-40.0, 100.0),
    "air_pressure_pa": (10e3, 140e3),
    "humidity_pct": (0.0, 100.0),
    "expansion_ppm_per_k": (-5.0, 50.0),
}
"""Physically possible values (the validity of the refractive-index equations,
``volcal.environment.refractive``): outside, the field is refused."""

_PRESSURE_PA = {"pa": 1.0, "hpa": 100.0, "mbar": 100.0, "kpa": 1000.0, "bar": 1e5,
                "mmhg": 133.322387415, "torr": 133.322368421, "inhg": 3386.389}
_NUMBER = re.compile(r"[-+\u2212]?\d+(?:[.,]\d+)?(?:[eE][-+]?\d+)?")
_MONTHS = {m: i + 1 for i, m in enumerate(("jan", "feb", "mar", "apr", "may", "jun", "jul",
                                            "aug", "sep", "oct", "nov", "dec"))}


@dataclass(frozen=True)
class HeaderField:
    """One field read from the header block.

    Attributes
    ----------
    key : str
        One of :data:`HEADER_KEYS`.
    value : str or float
        ``date``: ISO 8601 date (``YYYY-MM-DD``); ``operator``: text; the others a
        number in the key's unit ([degC], [Pa], [%]).
    line : int
        Line of the file (1-based).
    label : str
        The label as written.
    text : str
        The value as written.
    how : str
        How it was read (``'hPa -> Pa'``, ``'day.month.year'``), for the report line.
    """

    key: str
    value: str | float | bool
    line: int
    label: str
    text: str
    how: str = ""

    @property
    def target(self) -> str:
        """Where it goes: ``calibration.date``, ``environment.air_temperature_c``...

        The material compensation goes to the measurement's ``referred_to_20c``.
        """
        if self.key == "referred_to_20c":
            return self.key
        return (f"calibration.{self.key}" if self.key in CALIBRATION_FIELDS
                else f"environment.{self.key}")

    def describe(self) -> str:
        """One line for the user: ``line 3 'Air temperature: 20,4 °C' -> ...``."""
        v = (str(self.value).lower() if isinstance(self.value, bool) else self.value
             if isinstance(self.value, str) else f"{self.value:.6g}")
        how = f" ({self.how})" if self.how else ""
        return f"line {self.line} '{self.label}: {self.text}' -> {self.target} = {v}{how}"


def _loose(label: str) -> str:
    """A label without case, a trailing ``:``/``=`` and a unit in brackets."""
    t = label.strip().strip('"').strip().rstrip(":=").strip()
    t = re.sub(r"\s*[\(\[][^\)\]]*[\)\]]\s*$", "", t)
    return " ".join(t.casefold().split())


def _bracket_unit(label: str) -> str:
    m = re.search(r"[\(\[]([^\)\]]*)[\)\]]\s*:?\s*$", label.strip())
    return m.group(1).strip() if m else ""


def split_field(fields: list[str]) -> tuple[str, str] | None:
    """Label and value text of a header record (``Date: x``, ``Date;x``, ``Date = x``).

    Parameters
    ----------
    fields : list of str
        The record, split at the table's delimiter.

    Returns
    -------
    (label, value) or None
        None when the record holds no value.
    """
    cells = [c.strip() for c in fields if c.strip()]
    if not cells:
        return None
    first = cells[0]
    m = re.match(r"^([^:=]+?)\s*[:=]\s*(.*)$", first)
    if m and not re.match(r"^\d", first):
        label, rest = m.group(1), m.group(2)
        value = " ".join(v for v in [rest, *cells[1:]] if v)
    elif len(cells) >= 2:
        label, value = first, " ".join(cells[1:])
    else:
        return None
    return (label, value) if value else None


def _number(text: str) -> tuple[float, str]:
    """First number of ``text`` (decimal point or comma) and the text after it."""
    m = _NUMBER.search(text)
    if m is None:
        raise ValueError(f"no number in {text!r}")
    return float(m.group(0).replace("\u2212", "-").replace(",", ".")), text[m.end():].strip()


def _temperature(text: str, unit: str) -> tuple[float, str]:
    v, after = _number(text)
    u = (unit or after).replace("°", "").replace("deg", "").strip().casefold()
    if u in ("", "c", "celsius", "degc"):
        return v, "" if u else "no unit: degC assumed"
    if u in ("f", "fahrenheit"):
        return (v - 32.0) * 5.0 / 9.0, "degF -> degC"
    if u in ("k", "kelvin"):
        return v - 273.15, "K -> degC"
    raise ValueError(f"unknown temperature unit {u!r}: expected °C, °F or K")


def _pressure(text: str, unit: str) -> tuple[float, str]:
    v, after = _number(text)
    u = (unit or after).strip().casefold().replace(" ", "")
    if u in _PRESSURE_PA:
        return v * _PRESSURE_PA[u], ("" if u == "pa" else f"{unit or after.strip()} -> Pa")
    if u:
        raise ValueError(f"unknown pressure unit {u!r}: expected Pa, hPa, mbar, kPa, mmHg "
                         "or inHg")
    if 500.0 <= v <= 1200.0:
        return v * 100.0, "no unit: hPa by its magnitude -> Pa"
    if 50e3 <= v <= 120e3:
        return v, "no unit: Pa by its magnitude"
    raise ValueError("no unit, and the magnitude names none: write hPa or Pa")


def _humidity(text: str, unit: str) -> tuple[float, str]:
    v, after = _number(text)
    u = (unit or after).strip().casefold().replace(" ", "")
    if u not in ("", "%", "%rh", "pct", "percent", "rh"):
        raise ValueError(f"unknown humidity unit {u!r}: expected %")
    return v, ""


def parse_header_date(text: str) -> tuple[str, str]:
    """A date as vendors write it -> ISO 8601 ``YYYY-MM-DD``.

    Parameters
    ----------
    text : str
        ``2026-11-20``, ``2026-11-20T14:32``, ``20.11.2026``, ``2026/11/20``,
        ``20/11/2026``, ``11/20/2026``, ``20 Nov 2026``, ``Nov 20, 2026``, ``20-Nov-2026``;
        a time after the date is ignored.

    Returns
    -------
    date : str
        ``YYYY-MM-DD``.
    how : str
        The order read, when not ISO (``'day.month.year'``).

    Raises
    ------
    ValueError
        Not a date, or ambiguous (``05/11/2026``: day/month or month/day).
    """
    t = text.strip()
    m = re.match(r"^(\d{4})[-/.](\d{1,2})[-/.](\d{1,2})(?!\d)", t)
    if m:
        return _iso(int(m.group(1)), int(m.group(2)), int(m.group(3))), ""
    m = re.match(r"^(\d{1,2})\.(\d{1,2})\.(\d{4})(?!\d)", t)
    if m:
        return _iso(int(m.group(3)), int(m.group(2)), int(m.group(1))), "day.month.year"
    m = re.match(r"^(\d{1,2})[/-](\d{1,2})[/-](\d{4})(?!\d)", t)
    if m:
        a, b, y = int(m.group(1)), int(m.group(2)), int(m.group(3))
        if a > 12 >= b:
            return _iso(y, b, a), "day/month/year"
        if b > 12 >= a:
            return _iso(y, a, b), "month/day/year"
        if a == b:
            return _iso(y, a, b), ""
        raise ValueError(f"{t!r} is ambiguous (day/month or month/day): write it as "
                         "YYYY-MM-DD")
    m = re.match(r"^(\d{1,2})[\s.-]*([A-Za-z]{3})[A-Za-z]*\.?[\s.-]*(\d{4})\b", t)
    if m and m.group(2).casefold() in _MONTHS:
        return _iso(int(m.group(3)), _MONTHS[m.group(2).casefold()], int(m.group(1))), ""
    m = re.match(r"^([A-Za-z]{3})[A-Za-z]*\.?\s+(\d{1,2}),?\s+(\d{4})\b", t)
    if m and m.group(1).casefold() in _MONTHS:
        return _iso(int(m.group(3)), _MONTHS[m.group(1).casefold()], int(m.group(2))), ""
    raise ValueError(f"not a date: {t!r}")


def _iso(y: int, mo: int, d: int) -> str:
    return _dt.date(y, mo, d).isoformat()  # ValueError for 31.02.2026


def _switch(text: str) -> tuple[bool, str]:
    """A vendor's on/off word: whether the material compensation was applied."""
    t = text.strip().strip('"').strip().casefold().rstrip(".")
    word = t.split()[0] if t.split() else ""
    if word in _ON:
        return True, f"{word}: the laser software referred the readings to 20 °C"
    if word in _OFF:
        return False, f"{word}: not referred to 20 °C by the laser software"
    raise ValueError(f"expected on or off (yes/no, enabled/disabled), got {text.strip()!r}")


def _expansion(text: str, unit: str) -> tuple[float, str]:
    v, after = _number(text)
    u = (unit or after).replace("µ", "u").replace("°", "").replace(" ", "").casefold()
    if u in ("ppm/k", "ppm/c", "ppm", "um/m/k", "um/m/c", "um/(m.k)", "um/(mk)", "10^-6/k",
             "e-6/k", "x10^-6/k"):
        return v, ""
    if u in ("1/k", "/k", "1/c", "/c", "k^-1", "k-1"):
        return v * 1e6, "1/K -> ppm/K"
    if u:
        raise ValueError(f"unknown expansion unit {u!r}: expected ppm/K, um/m/K or 1/K")
    if abs(v) < 1e-3:
        return v * 1e6, "no unit: 1/K by its magnitude -> ppm/K"
    return v, "no unit: ppm/K assumed"


_ON = ("on", "yes", "true", "enabled", "active", "applied", "auto", "automatic", "manual",
       "ein", "an", "ja", "1")
_OFF = ("off", "no", "false", "disabled", "inactive", "none", "not", "aus", "nein", "0")


def _convert(key: str, text: str, unit: str) -> tuple[str | float | bool, str]:
    if key == "date":
        return parse_header_date(text)
    if key == "referred_to_20c":
        return _switch(text)
    if key == "operator":
        name = text.strip().strip('"').strip()
        if not name:
            raise ValueError("empty")
        return name, ""
    v: float
    if key == "air_pressure_pa":
        v, how = _pressure(text, unit)
    elif key == "expansion_ppm_per_k":
        v, how = _expansion(text, unit)
    elif key == "humidity_pct":
        v, how = _humidity(text, unit)
    else:
        v, how = _temperature(text, unit)
    lo, hi = RANGES[key]
    if not lo <= v <= hi:
        raise ValueError(f"{v:.6g} is outside the possible range {lo:g}..{hi:g}")
    return round(v, 6), how


def read_header(records: list[tuple[int, list[str]]], mapped: dict[str, str],
                path: str | Path | None = None, skip: tuple[str, ...] = (),
                columns: tuple[str, ...] = (), header_row: int | None = None
                ) -> tuple[list[HeaderField], list[str]]:
    """Read the date, operator and environment from the lines above the table.

    Parameters
    ----------
    records : list of (line, fields)
        The records before the table's header line.
    mapped : dict of str to str
        Header keys (:data:`HEADER_KEYS`) named by ``--map`` -> their label; these must
        be found and must read.
    path : str or Path, optional
        The export, for messages.
    skip : tuple of str
        Keys not to look for by default label (read from table columns instead).
    columns : tuple of str
        The table's header names (candidates of the closest name of a mapped label
        found nowhere).
    header_row : int, optional
        Line of the table's header (where the error of a label found nowhere points).

    Returns
    -------
    fields : list of HeaderField
        What was read, in file order.
    notes : list of str
        Default-label fields that did not read (left out).

    Raises
    ------
    VolcalInputError
        A mapped label not found (naming the closest label of the header block), or a
        mapped field that does not read; naming the file, line and label.
    """
    import difflib

    entries = []
    for line, rec in records:
        sf = split_field(rec)
        if sf is not None:
            entries.append((line, sf[0], sf[1]))
    out: dict[str, HeaderField] = {}
    notes: list[str] = []
    for key, label in mapped.items():
        hits = [e for e in entries if _loose(e[1]) == _loose(label)]
        if not hits:
            names = [e[1].strip() for e in entries] + [c for c in columns if c.strip()]
            close = difflib.get_close_matches(_loose(label), [_loose(x) for x in names], n=1,
                                              cutoff=0.6)
            hint = ""
            if close:
                hint = f" (closest: {names[[_loose(x) for x in names].index(close[0])]!r})"
            where = (f"lines {records[0][0]}-{records[-1][0]}" if records else "none")
            raise VolcalInputError(f"--map {key}={label}: no column {label!r} in the table's "
                                   f"header line and no such field in the header lines above "
                                   f"it{hint}; header lines: {where}", path,
                                   header_row if header_row is not None else
                                   (records[0][0] if records else None), label)
        line, lab, text = hits[0]
        try:
            value, how = _convert(key, text, _bracket_unit(lab))
        except ValueError as exc:
            raise VolcalInputError(f"--map {key}={label}: cannot read {text!r}: {exc}", path,
                                   line, lab) from None
        out[key] = HeaderField(key, value, line, lab.strip(), text, how)
    for key, labels in LABELS.items():
        if key in out or key in mapped or key in skip:
            continue
        hit = next((e for e in entries if _loose(e[1]) in labels), None)
        if hit is None:
            continue
        line, lab, text = hit
        try:
            value, how = _convert(key, text, _bracket_unit(lab))
        except ValueError as exc:
            notes.append(f"line {line} '{lab.strip()}: {text}' not read as "
                         f"{key} ({exc}); map it with --map {key}=<label> or leave it")
            continue
        out[key] = HeaderField(key, value, line, lab.strip(), text, how)
    return sorted(out.values(), key=lambda f: f.line), notes
