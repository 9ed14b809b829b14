"""HEIDENHAIN nonlinear axis error compensation: ``.COM`` value tables and the ``.CMA`` assignment.

A ``.COM`` table lists compensation points of one input axis (column ``AXISPOS``,
machine coordinates [mm]) and the compensation value of the compensated axis in a
column named after it [mm]; the ``.CMA`` table assigns the ``.COM`` tables to the
input axes (one column per axis, ``*`` in ``ACTIVE`` marks the active line). Tables
start with ``BEGIN <name> MM`` and end with ``[END]``. This is the AXISPOS format of
the TNC 640 / MANUALplus 620 generation: the ``BACKLASH`` column holds the additional
value for the negative direction of travel [mm] (reverse minus forward compensation;
0 without bidirectional data). The control interpolates linearly between points.

Tables are fixed-width: every value starts at the column where its header name starts
(HEIDENHAIN tables and pyLSV2's table reader take each field from the header's column).

The 256-entry limit with a datum and power-of-two spacing belongs to the older TNC
407/415/425 tables, which have no AXISPOS column; volcal does not write that format and
sets no default limit (``max_points`` on request).

References
----------
HEIDENHAIN MANUALplus 620 / TNC 640 Technical Manual, nonlinear axis error
compensation (*.COM/*.CMA, AXISPOS and BACKLASH columns). HEIDENHAIN TNC 407/415/425
Technical Manual (256-entry tables, for contrast).
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


_W = 14  # column width: every header name and its values start at a multiple of it


def _row(cells: list[str]) -> str:
    return "".join(c.ljust(_W) for c in cells[:-1]) + cells[-1]


def heidenhain_files(errors: MachineErrors, spacing: float, sign: str = "error",
                     max_points: int | None = None, reversal_um=None) -> dict[str, str]:
    """``X.COM``, ``Y.COM``, ``Z.COM`` (positioning errors) and ``VOLCAL.CMA``.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between compensation points [mm] (a multiple of 0.0001 mm).
    sign : str
        ``'error'`` or ``'correction'``.
    max_points : int, optional
        Entries allowed per ``.COM`` table (no limit by default).
    reversal_um : sequence of 3 callables, optional
        Per axis, ``f(positions [mm]) -> reverse minus forward error [um]``; written
        in the ``BACKLASH`` column (0 when absent), and the value column then holds the
        forward error (model - r/2; the model is the bidirectional mean).

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
        back = np.zeros_like(p)
        if reversal_um is not None and reversal_um[k] is not None:
            s = 1.0 if sign == "error" else -1.0
            back = s * np.asarray(reversal_um[k](p), dtype=float)
        back = np.round(back / RESOLUTION_UM) * RESOLUTION_UM
        vals = np.round((t.values - back / 2.0) / RESOLUTION_UM) * RESOLUTION_UM
        rows = [f"BEGIN {a}.COM MM", _row(["NR", "AXISPOS", a, "BACKLASH"])]
        rows += [_row([str(n), _f(pos, 4), _f(v / 1000.0, 4), _f(b / 1000.0, 4)])
                 for n, (pos, v, b) in enumerate(zip(p, vals, back, strict=True))]
        files[f"{a}.COM"] = "\n".join([*rows, "[END]"]) + "\n"
    cma = [f"BEGIN {CMA_FILE}", _row(["NR", "ACTIVE", "X", "Y", "Z"]),
           _row(["0", "*", "X.COM", "Y.COM", "Z.COM"]), "[END]"]
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
            arr = np.array([[float(r[1]), float(r[h.index(out_axis[0])])] for r in data])
        except (ValueError, IndexError):
            raise VolcalInputError("bad number in table", folder / com) from None
        out.append(AxisTable(AXES.index(col), AXES.index(out_axis[0]), arr[:, 0],
                             arr[:, 1] * 1000.0, sign, RESOLUTION_UM))
    return out
