"""Units and sign of direct-optics exports (straightness and angle readings).

Straightness exports carry lengths (um, mm, nm: :mod:`volcal.importer.units`); angle
exports carry urad, arcsec, mm/m (= mrad), um/m (= urad), mrad or degrees, named in the
header (``'Angle (arcsec)'``) or given with ``--deviation-units``. Instruments that report
the workpiece side relative to the tool side are read with ``--sign -`` (volcal's
readings are the tool side relative to the workpiece side, ``docs/formats.md``).
"""

from __future__ import annotations

import math
import re

from volcal.errors import VolcalInputError

__all__ = ["ANGLE_TO_URAD", "angle_unit", "parse_sign"]

ANGLE_TO_URAD: dict[str, float] = {
    "urad": 1.0, "mrad": 1000.0, "arcsec": math.pi / 180.0 / 3600.0 * 1e6,
    "mm/m": 1000.0, "um/m": 1.0, "deg": math.pi / 180.0 * 1e6,
}
"""Angle unit -> urad (1 arcsec = pi / 648000 rad = 4.848 urad)."""

_ALIASES = {"urad": "urad", "µrad": "urad", "μrad": "urad", "microrad": "urad",
            "mrad": "mrad", "arcsec": "arcsec", "arc sec": "arcsec", "sec": "arcsec", '"': "arcsec",
            "mm/m": "mm/m", "um/m": "um/m", "µm/m": "um/m", "μm/m": "um/m",
            "deg": "deg", "degree": "deg", "degrees": "deg", "°": "deg"}
_BRACKET = re.compile(r"[\(\[]\s*([^\)\]]+?)\s*[\)\]]\s*$")


def angle_unit(option: str, header: str) -> str:
    """The angle unit of a reading column: the option, else the header's.

    Parameters
    ----------
    option : str
        ``--deviation-units`` (``'auto'``: from the header).
    header : str
        The column's header as written.

    Returns
    -------
    str
        A key of :data:`ANGLE_TO_URAD`.

    Raises
    ------
    VolcalInputError
        An unknown unit, or none in the header with ``auto``.
    """
    if option not in (None, "auto"):
        u = _ALIASES.get(option.strip().lower())
        if u is None:
            raise VolcalInputError(f"--deviation-units {option!r}: not an angle unit; expected "
                                   f"one of {', '.join(ANGLE_TO_URAD)}")
        return u
    m = _BRACKET.search(header)
    if m and m.group(1).strip().lower() in _ALIASES:
        return _ALIASES[m.group(1).strip().lower()]
    raise VolcalInputError(f"no angle unit in the header {header!r}: give --deviation-units "
                           f"(one of {', '.join(ANGLE_TO_URAD)})", column=header)


def parse_sign(text: str) -> float:
    """``+``/``+1``/``1`` -> 1.0, ``-``/``-1`` -> -1.0.

    Parameters
    ----------
    text : str
        The ``--sign`` option.

    Returns
    -------
    float

    Raises
    ------
    VolcalInputError
        Anything else.
    """
    t = str(text).strip()
    if t in ("+", "+1", "1"):
        return 1.0
    if t in ("-", "-1"):
        return -1.0
    from volcal.errors import ParameterError

    raise ParameterError(f"{{sign=}}{text!r}: expected + (the tool side relative to the "
                         "workpiece side, volcal's sign) or - (the workpiece side relative "
                         "to the tool side)")
