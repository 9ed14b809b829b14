"""HEIDENHAIN nonlinear axis error compensation: ``.COM`` value tables and the ``.CMA`` assignment.

A ``.COM`` table lists compensation points of one input axis (column ``AXISPOS``,
machine coordinates [mm]) and the compensation value of the compensated axis in a
column named after it [mm]; the ``.CMA`` table assigns the ``.COM`` tables to the
input axes (one column per axis, ``*`` in ``ACTIVE`` marks the active line). Tables
start with ``BEGIN <name> MM`` and end with ``[END]``. The control interpolates linearly
between points; older controls (TNC 407/415/425) accept at most 256 entries per
``.COM`` table, which is volcal's default limit (``max_points``).

References
----------
HEIDENHAIN TNC 407/415/425 Technical Manual, 1 Machine axes, nonlinear axis error
compensation (.CMA/.COM, module 9095: "more than 256 entries"). HEIDENHAIN MANUALplus
620 Technical Manual, entering compensation values (AXISPOS column, *.COM/*.CMA).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from volcal.compensate.tables import AxisTable, axis_grid, pitch_table
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

CMA_FILE = "VOLCAL.CMA"
RESOLUTION_UM = 0.1  # 4 decimals in mm


def _f(v: float, d: int) -> str:
    return f"{v:+.{d}f}"


def heidenhain_files(errors: MachineErrors, spacing: float, sign: str, max_points: int = 256
                     ) -> dict[str, str]:
    """``X.COM``, ``Y.COM``, ``Z.COM`` (positioning errors) and ``VOLCAL.CMA``.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between compensation points [mm] (a multiple of 0.0001 mm).
    sign : str
        ``'error'`` or ``'correction'``.
    max_points : int
        Entries allowed per ``.COM`` table.

    Returns
    -------
    dict of str to str
    """
    if abs(spacing * 1e4 - round(spacing * 1e4)) > 1e-6:
        raise VolcalInputError(f"--spacing {spacing:g}: Heidenhain positions have 4 decimals")
    files = {}
    for k in range(3):
        a = AXES[k]
        p = axis_grid(*errors.travel[k], spacing, max_points=max_points, what=f"Heidenhain {a}")
        t = pitch_table(errors, k, p, sign, RESOLUTION_UM)
        rows = [f"BEGIN {a}.COM MM", f"{'NR':<6}{'AXISPOS':>14}{a:>14}"]
        rows += [f"{n:<6}{_f(pos, 4):>14}{_f(v / 1000.0, 4):>14}"
                 for n, (pos, v) in enumerate(zip(p, t.values, strict=True))]
        files[f"{a}.COM"] = "\n".join([*rows, "[END]"]) + "\n"
    cma = [f"BEGIN {CMA_FILE}", f"{'NR':<6}{'ACTIVE':<8}{'X':<10}{'Y':<10}{'Z':<10}",
           f"{0:<6}{'*':<8}{'X.COM':<10}{'Y.COM':<10}{'Z.COM':<10}", "[END]"]
    files[CMA_FILE] = "\n".join(cma) + "\n"
    return files


def _table(path: Path) -> tuple[list[str], list[list[str]]]:
    try:
        lines = [ln.split() for ln in path.read_text(encoding="ascii").splitlines() if ln.strip()]
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    if len(lines) < 3 or lines[0][0] != "BEGIN" or lines[-1] != ["[END]"]:
        raise VolcalInputError("expected BEGIN ... [END]", path)
    return lines[1], lines[2:-1]


def read_heidenhain(folder: str | Path, sign: str) -> list[AxisTable]:
    """Read the active ``.COM`` tables named in ``VOLCAL.CMA``.

    Parameters
    ----------
    folder : str or Path
        Folder holding ``VOLCAL.CMA`` and the ``.COM`` files it names.
    sign : str
        ``'error'`` or ``'correction'``: the convention the tables were written in (the
        files do not record it); stored on the returned tables.

    Returns
    -------
    list of AxisTable
        One per assigned table (input axis = ``.CMA`` column, output = value column).
    """
    folder = Path(folder)
    head, rows = _table(folder / CMA_FILE)
    active = [r for r in rows if len(r) == len(head) and r[head.index("ACTIVE")] == "*"]
    if len(active) != 1:
        raise VolcalInputError("exactly one active line expected", folder / CMA_FILE)
    out = []
    for col, com in zip(head, active[0], strict=True):
        if col not in AXES:
            continue
        h, data = _table(folder / com)
        out_axis = [c for c in h if c in AXES]
        if h[:2] != ["NR", "AXISPOS"] or len(out_axis) != 1:
            raise VolcalInputError("expected columns NR AXISPOS <axis>", folder / com, 2)
        try:
            arr = np.array([[float(r[1]), float(r[2])] for r in data])
        except (ValueError, IndexError):
            raise VolcalInputError("bad number in table", folder / com) from None
        out.append(AxisTable(AXES.index(col), AXES.index(out_axis[0]), arr[:, 0],
                             arr[:, 1] * 1000.0, sign, RESOLUTION_UM))
    return out
