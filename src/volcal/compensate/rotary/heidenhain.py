"""HEIDENHAIN nonlinear axis error compensation of a rotary axis (``.COM`` of its own axis).

The same tables as for linear axes (:mod:`volcal.compensate.heidenhain`): a ``.COM`` table
lists the compensation points of the input axis in ``AXISPOS`` and the values of the
compensated axis in the column named after it, "if required" the values measured in the
negative direction of traverse in ``BACKLASH`` (MANUALplus 620 Technical Manual, 6.10.3,
p. 716); the ``.CMA`` table assigns it to the input axis. For a rotary axis the input and
compensated axis are the rotary axis itself (the positioning error EAA/EBB/ECC, in the
iTNC 530 technical manual's recommended scheme "Positioning error EAA" in the rotary axis'
own column), positions and values in **degrees**, the control's unit of rotary axes. The
table holds the **error** (HEIDENHAIN's convention, as for linear axes), and the control
interpolates linearly between points.

Full circle: the points run from 0 to 360 deg with the same value at 0 and 360 (one
position); the values between are the target means interpolated periodically. Limited
axis: the targets. Positions have 4 decimals, values 6 decimals (0.0036 arcsec): the
rotary values need more than the 4 decimals of a linear table in mm (0.0001 deg = 0.36
arcsec); check the number of decimals your control accepts (the technical manual of the
control, "nonlinear axis error compensation").

The assignment is written as ``VOLCAL_ROTARY.CMA`` (columns ``NR ACTIVE <axis>``): enter
its ``.COM`` in the active line of the machine's ``.CMA`` (beside the linear axes' tables
of ``VOLCAL.CMA``).

References
----------
HEIDENHAIN MANUALplus 620 Technical Manual (01/2012), 6.10.3 "Nonlinear axis error
compensation", pp. 713-716. HEIDENHAIN iTNC 530 HSCI Technical Manual, KinematicsComp:
"Rotary axes (e.g. A axis) - Recommendation for COM file" (positioning error EAA), p. 680.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.compensate.heidenhain import _row, _table
from volcal.compensate.rotary.profile import DEG_PER_URAD, RotaryProfile
from volcal.compensate.tables import sign_factor
from volcal.errors import VolcalInputError

__all__ = ["ROTARY_CMA_FILE", "heidenhain_rotary_files", "read_heidenhain_rotary"]

ROTARY_CMA_FILE = "VOLCAL_ROTARY.CMA"
DEFAULT_SIGN = "error"
WIDTHS = [6, 14, 16, 16]


def heidenhain_nodes(p: RotaryProfile) -> NDArray[np.float64]:
    """Points of the table [deg]: the targets, and 360 deg on a full-circle axis.

    Parameters
    ----------
    p : RotaryProfile
        The axis' error.

    Returns
    -------
    ndarray
    """
    t = np.asarray(p.targets_deg, dtype=float)
    if p.modulo:
        t = np.unique(np.r_[0.0, t, 360.0])
    return t


def heidenhain_rotary_files(p: RotaryProfile, name: str, sign: str = DEFAULT_SIGN
                            ) -> tuple[dict[str, str], list[str]]:
    """``<axis>.COM`` of one rotary axis and the notes lines for it.

    Parameters
    ----------
    p : RotaryProfile
        The axis' error.
    name : str
        Table file name (``C.COM``).
    sign : str
        ``'error'`` (HEIDENHAIN's convention, default) or ``'correction'``.

    Returns
    -------
    files : dict of str to str
    notes : list of str
    """
    s = sign_factor(sign)
    ax = p.axis.upper()
    pos = heidenhain_nodes(p)
    fwd = s * p.error_urad(pos, "+") * DEG_PER_URAD
    rev = s * p.error_urad(pos, "-") * DEG_PER_URAD
    head = ["NR", "AXISPOS", ax] + (["BACKLASH"] if p.bidirectional else [])
    w = WIDTHS[:len(head)]
    rows = [f"BEGIN {name} MM", _row(head, w)]
    for n, (a, f, r) in enumerate(zip(pos, fwd, rev, strict=True)):
        cells = [str(n), f"{a:+.4f}", f"{f:+.6f}"] + ([f"{r:+.6f}"] if p.bidirectional else [])
        rows.append(_row(cells, w))
    files = {name: "\n".join([*rows, "[END]"]) + "\n"}
    notes = [
        "", f"Rotary axis {ax} (test {p.id}): {name}, positions and values in degrees, sign "
        f"{sign}" + ("" if sign == DEFAULT_SIGN else " (NOT the HEIDENHAIN convention: "
                     "loading it doubles the error)"),
        ("Full circle: points 0 to 360 deg, the same value at 0 and 360 (one position)."
         if p.modulo else "Limited axis: points at the test's targets."),
        ("BACKLASH: the values measured approaching in the negative direction."
         if p.bidirectional else "One approach direction measured: no BACKLASH column."),
        f"Assign {name} to axis {ax} in the active line of your .CMA ({ROTARY_CMA_FILE} "
        "shows the entry); values have 6 decimals: check what your control accepts.",
    ]
    return files, notes


def heidenhain_rotary_cma(assign: dict[str, str]) -> str:
    """``VOLCAL_ROTARY.CMA``: one active line assigning each rotary axis its table.

    Parameters
    ----------
    assign : dict of str to str
        Axis name -> ``.COM`` file.

    Returns
    -------
    str
    """
    axes = sorted(assign)
    w = [6, 8] + [12] * len(axes)
    rows = [f"BEGIN {ROTARY_CMA_FILE}", _row(["NR", "ACTIVE", *axes], w),
            _row(["0", "*", *(assign[a] for a in axes)], w), "[END]"]
    return "\n".join(rows) + "\n"


def read_heidenhain_rotary(path: str | Path, column: str | None = None
                           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions [deg] and values [deg] of a rotary ``.COM``.

    Parameters
    ----------
    path : str or Path
        The ``.COM`` table.
    column : str, optional
        ``'BACKLASH'`` for the negative direction (the axis column when there is none);
        default the axis column.

    Returns
    -------
    positions, values : ndarray
    """
    path = Path(path)
    head, rows = _table(path)
    if head[:2] != ["NR", "AXISPOS"] or len(head) < 3:
        raise VolcalInputError("expected columns NR AXISPOS <axis>", path, 2)
    j = head.index(column) if column is not None and column in head else 2
    try:
        arr = np.array([[float(r[1]), float(r[j])] for r in rows])
    except (ValueError, IndexError):
        raise VolcalInputError("bad number in table", path) from None
    return arr[:, 0], arr[:, 1]
