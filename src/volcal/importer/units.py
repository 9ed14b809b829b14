"""Length units of laser exports: names, conversion to mm, detection from column headers."""

from __future__ import annotations

import re

from volcal.errors import VolcalInputError

TO_MM: dict[str, float] = {"mm": 1.0, "um": 1e-3, "nm": 1e-6, "in": 25.4, "uin": 25.4e-6}
"""Unit name -> length in mm (1 in = 25.4 mm exactly, ISO 31/NIST SP 811)."""

_ALIASES: dict[str, str] = {
    "mm": "mm", "millimeter": "mm", "millimetre": "mm", "millimeters": "mm", "millimetres": "mm",
    "um": "um", "µm": "um", "μm": "um", "micron": "um", "microns": "um", "micrometer": "um",
    "micrometre": "um", "micrometers": "um", "micrometres": "um",
    "nm": "nm", "nanometer": "nm", "nanometre": "nm",
    "in": "in", "inch": "in", "inches": "in", '"': "in",
    "uin": "uin", "µin": "uin", "μin": "uin", "microinch": "uin", "microinches": "uin",
}

_UNSUPPORTED = frozenset({"m", "cm", "dm", "km", "ft", "foot", "feet", "yd", "mil", "mils",
                          "thou", "pm"})
"""Length units a header may name that volcal does not convert (they must not pass as mm)."""

_BRACKET = re.compile(r"[\(\[]\s*([^\)\]]+?)\s*[\)\]]\s*$")
_SUFFIX = re.compile(r"[_\s]([A-Za-zµμ\"]+)\s*$")


def unsupported_unit(header: str) -> str | None:
    """A length unit named in ``header`` that volcal does not read (``'Target (ft)'`` -> ft).

    Parameters
    ----------
    header : str
        Column header.

    Returns
    -------
    str or None
        The unit as written, or None.
    """
    for pat in (_BRACKET, _SUFFIX):
        m = pat.search(header)
        if m and m.group(1).strip().lower() in _UNSUPPORTED:
            return m.group(1).strip()
    return None


def unit_name(text: str, option: str = "--units") -> str:
    """Canonical unit name of ``text`` (``'µm'`` -> ``'um'``); raise if unknown.

    Parameters
    ----------
    text : str
        A unit as the user or the file writes it (``'mm'``, ``'µm'``, ``'micron'``,
        ``'inch'``...), case-insensitive.
    option : str
        Name of the option or column the unit came from, used in the error message.

    Returns
    -------
    str
        One of the keys of :data:`TO_MM` (``'mm'``, ``'um'``, ``'nm'``, ``'in'``, ``'uin'``).
    """
    u = _ALIASES.get(text.strip().lower().replace("micro-", "micro"))
    if u is None:
        raise VolcalInputError(f"{option} {text!r}: unknown unit; expected one of "
                               f"{', '.join(TO_MM)}")
    return u


def unit_from_header(header: str) -> str | None:
    """Unit written in a column header, e.g. ``'Position (mm)'``, ``'Error [µm]'``, ``'dev_um'``.

    Parameters
    ----------
    header : str
        Column header.

    Returns
    -------
    str or None
        Canonical unit, or None if the header names none.
    """
    for pat in (_BRACKET, _SUFFIX):
        m = pat.search(header)
        if m:
            u = _ALIASES.get(m.group(1).strip().lower())
            if u is not None:
                return u
    return None
