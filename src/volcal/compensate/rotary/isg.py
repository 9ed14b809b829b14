"""ISG / Beckhoff TwinCAT CNC: the angular positioning error of a rotary axis (ISG CSV).

The volumetric compensation of the ISG kernel (Beckhoff TF5280) reads component errors of
every axis of the kinematic chain, rotary axes included, from parameter files; the ISG CSV
format (:mod:`volcal.compensate.volumetric`) has a header line naming the argument and the
errors, then one row per argument value. For a rotary axis C the argument is ``C``, "axis
value of the C axis, in degrees (e.g. [0°, 360°], for rotation axes)", and its angular
positioning error is the component error ``ECC`` (ISO 230-1 names, as for the linear axes'
``EXX``), in **rad** ("rad for angles"), the **error** (the ISG convention: the list
parameter ``negate`` (P-VOLC) inverts the values; volcal's notes say ``negate 0``).

Full circle: rows from 0 to 360 deg, the same value at both. The format has no direction:
the value is the mean of both approach directions (the reversal is not compensated here;
the ISG kernel's backlash compensation is an axis parameter, not part of this file).
Activation: list the file in the volumetric compensation's parameter list
(``file[j]``, ``file_format[j]`` = ISG CSV), the C axis as ``c`` (logical axis number) and
in ``Chain``; the whole volumetric compensation is then active for the chain.

References
----------
Beckhoff TF5280 / ISG kernel documentation: "ISG CSV format" (296429067), "Units of
measure" (296426379: parameter values in mm or rad, arguments A, B, C in degrees),
"Overview of compensation parameters" (563009163: a, b, c, Chain, negate, file[j],
file_format[j]).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.compensate.rotary.profile import RotaryProfile
from volcal.compensate.tables import sign_factor
from volcal.errors import VolcalInputError

__all__ = ["isg_rotary_files", "read_isg_rotary"]

DEFAULT_SIGN = "error"
RAD_PER_URAD = 1e-6


def isg_rotary_files(p: RotaryProfile, name: str, sign: str = DEFAULT_SIGN
                     ) -> tuple[dict[str, str], list[str]]:
    """``rotary_isg_<axis>.csv``: the ECC (EAA, EBB) of one rotary axis.

    Parameters
    ----------
    p : RotaryProfile
        The axis' error.
    name : str
        File name.
    sign : str
        ``'error'`` (the ISG convention, default) or ``'correction'``.

    Returns
    -------
    files : dict of str to str
    notes : list of str
    """
    s = sign_factor(sign)
    ax = p.axis.upper()
    col = f"E{ax}{ax}"
    t = np.asarray(p.targets_deg, dtype=float)
    if p.modulo:
        t = np.unique(np.r_[0.0, t, 360.0])
    v = s * p.error_urad(t) * RAD_PER_URAD
    rows = [f"// volcal: angular positioning error {col} of rotary axis {ax} (test {p.id})",
            f"// argument {ax} [deg]; {col} [rad], sign {sign}"
            + (" (the ISG convention; list parameter negate 0)" if sign == DEFAULT_SIGN
               else " (NOT the ISG convention: set negate 1 or the error doubles)"),
            "// the mean of both approach directions" if p.bidirectional else
            "// one approach direction measured",
            f"{ax:<12s}{col}"]
    rows += [f"{a:<12.6f}{x:.6e}" for a, x in zip(t, v, strict=True)]
    notes = ["", f"Rotary axis {ax} (test {p.id}): {name}, ISG CSV with {col} [rad] over {ax} "
             f"[deg] " + ("0..360 (same value at both)" if p.modulo else "(the targets)"),
             "The format has no direction: the mean of both approach directions."
             if p.bidirectional else "One approach direction measured.",
             "Activate: file[j] / file_format[j] of the volumetric compensation (TF5280), "
             f"the axis as '{ax.lower()}' and in Chain."]
    return {name: "\n".join(rows) + "\n"}, notes


def read_isg_rotary(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Argument [deg] and value [rad] of a rotary ISG CSV file (the documented syntax).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    argument, value : ndarray
    """
    from volcal.compensate.volumetric import parse_isg_csv

    path = Path(path)
    blocks = parse_isg_csv(path.read_text(encoding="utf-8"), path)
    for b in blocks:
        names = list(b)
        if len(names) == 2 and names[0] in "ABC" and names[1] == f"E{names[0]}{names[0]}":
            pos, val = b[names[0]], b[names[1]]
            if not np.all(np.diff(pos) > 0) or not np.all(np.isfinite(val)):
                raise VolcalInputError("argument not increasing or value not a number", path)
            return np.asarray(pos, dtype=np.float64), np.asarray(val, dtype=np.float64)
    raise VolcalInputError("no block '<axis> E<axis><axis>'", path)

