"""Generic pitch compensation CSV: ``axis,point,position_mm,error_um`` (or ``correction_um``).

The value column's name states the sign; positions are the controller grid [mm];
values are rounded to 0.001 um.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from volcal.compensate.tables import AxisTable, axis_grid, pitch_table
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

CSV_FILE = "pitch.csv"
RESOLUTION_UM = 0.001


def generic_files(errors: MachineErrors, spacing: float, sign: str,
                  max_points: int | None = None) -> dict[str, str]:
    """The pitch tables of X, Y, Z as one CSV file.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between points [mm].
    sign : str
        ``'error'`` or ``'correction'`` (names the value column).
    max_points : int, optional
        Limit of points per axis.

    Returns
    -------
    dict of str to str
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["axis", "point", "position_mm", f"{sign}_um"])
    for k in range(3):
        p = axis_grid(*errors.travel[k], spacing, max_points=max_points, what=AXES[k])
        t = pitch_table(errors, k, p, sign, RESOLUTION_UM)
        for n, (pos, v) in enumerate(zip(p, t.values, strict=True)):
            w.writerow([AXES[k], n, f"{pos:.6f}", f"{v:.3f}"])
    return {CSV_FILE: buf.getvalue()}


def read_generic(path: str | Path) -> list[AxisTable]:
    """Read a generic pitch CSV; the sign comes from the value column's name.

    Parameters
    ----------
    path : str or Path
        The CSV file written by :func:`generic_files` (header
        ``axis,point,position_mm,error_um`` or ``...,correction_um``).

    Returns
    -------
    list of AxisTable
        The pitch tables of X, Y and Z (positions [mm], values [um]).
    """
    path = Path(path)
    try:
        rows = list(csv.reader(io.StringIO(path.read_text(encoding="utf-8"))))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    if not rows or rows[0][:3] != ["axis", "point", "position_mm"] or len(rows[0]) != 4 \
            or rows[0][3] not in ("error_um", "correction_um"):
        raise VolcalInputError("expected the header axis,point,position_mm,error_um|correction_um",
                               path, 1)
    sign = rows[0][3].removesuffix("_um")
    per: dict[int, list[tuple[float, float]]] = {0: [], 1: [], 2: []}
    for i, r in enumerate(rows[1:], start=2):
        if len(r) != 4 or r[0] not in AXES:
            raise VolcalInputError("expected 4 fields with axis X, Y or Z", path, i)
        try:
            per[AXES.index(r[0])].append((float(r[2]), float(r[3])))
        except ValueError:
            raise VolcalInputError("not a number", path, i) from None
    return [AxisTable(k, k, np.array([a for a, _ in per[k]]), np.array([b for _, b in per[k]]),
                      sign, RESOLUTION_UM) for k in range(3)]
