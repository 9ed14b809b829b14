"""Generic pitch compensation CSV: ``axis,point,position_mm,error_um`` (or ``correction_um``).

The value column's name states the sign; positions are the controller grid [mm];
values are rounded to 0.001 um.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from volcal.compensate.reference import reference_line_notes
from volcal.compensate.tables import AxisTable, axis_grid, pitch_table
from volcal.errors import VolcalInputError
from volcal.io.table import Column, TableSpec, read_table
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

CSV_FILE = "pitch.csv"
NOTES_FILE = "pitch_notes.txt"
"""Notes beside ``pitch.csv``: the reference line of each table and its Abbe terms."""
RESOLUTION_UM = 0.001


def generic_files(errors: MachineErrors, spacing: float, sign: str,
                  max_points: int | None = None) -> dict[str, str]:
    """The pitch tables of X, Y, Z as one CSV file, with a notes file beside it.

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
        lo, hi = errors.travel[k]
        p = axis_grid(lo, hi, spacing, max_points=max_points, what=AXES[k])
        t = pitch_table(errors, k, p, sign, RESOLUTION_UM)
        for n, (pos, v) in enumerate(zip(p, t.values, strict=True)):
            w.writerow([AXES[k], n, f"{pos:.6f}", f"{v:.3f}"])
    notes = ["volcal: generic pitch tables (pitch.csv): axis, point, position [mm], "
             f"{sign} [um] (the column name states the sign).",
             "Not corrected: straightness, squareness and angular (Abbe) errors.",
             *reference_line_notes(errors)]
    return {CSV_FILE: buf.getvalue(), NOTES_FILE: "\n".join(notes) + "\n"}


def _axis(text: str) -> str:
    if text not in AXES:
        raise ValueError(f"unknown axis {text!r}: expected X, Y or Z")
    return text


GENERIC_TABLE = TableSpec(
    (Column("axis", kind="str", parse=_axis), Column("point", kind="int", min=0),
     Column("position_mm", abs_max=1e7), Column("error_um", required=False, abs_max=1e7),
     Column("correction_um", required=False, abs_max=1e7)),
    unknown="error", what="pitch table")
"""Columns of the generic pitch CSV: ``axis,point,position_mm`` and one value column."""


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

    Raises
    ------
    VolcalInputError
        Naming file, row and column (unknown axis, not a number, a missing column or
        both value columns).
    """
    t = read_table(path, GENERIC_TABLE)
    signs = [c for c in ("error_um", "correction_um") if t.has(c)]
    if len(signs) != 1:
        raise VolcalInputError("expected the header axis,point,position_mm,error_um|correction_um",
                               path, t.header_row)
    values = t[signs[0]]
    axes = np.asarray(t["axis"], dtype=str)
    return [AxisTable(k, k, t["position_mm"][axes == a], values[axes == a],
                      signs[0].removesuffix("_um"), RESOLUTION_UM) for k, a in enumerate(AXES)]
