"""HEIDENHAIN nonlinear axis error compensation: ``.COM`` value tables and the ``.CMA`` assignment.

Format of the current controls (TNC 640, TNC 620, MANUALplus 620, CNC PILOT 640): a
``.COM`` table lists compensation points of one input axis (column ``AXISPOS``,
positions with respect to the machine datum [mm]), the compensation value of the
compensated axis in a column named after it [mm] and, "if required", the values measured
in the negative direction of traverse in the column ``BACKLASH`` [mm] (written only with
measured reversal; the manual does not say whether an empty or zero ``BACKLASH`` means
"same as the axis column" or "zero", so volcal leaves the column out then); the ``.CMA``
table assigns the ``.COM`` tables to the input axes (one column per axis, ``*`` in
``ACTIVE`` marks the active line). Tables start with ``BEGIN <name> MM`` and end with
``[END]``. They are fixed-width: every value starts at the column of its header name
(HEIDENHAIN tables are read column by column from the header positions, as pyLSV2's
table reader does). The control interpolates linearly between points.

Sign: the table holds the **error** measured at each point (default ``sign='error'``:
the TNC 407/415/425 technical manual's example plots "Error in Z [mm]" as the table
content; the MANUALplus 620 technical manual speaks of "compensation values measured").

Not this format: the TNC 407/415/425 (and TNC 360) tables, which have no ``AXISPOS``
column but a datum and a power-of-two spacing, and at most 256 entries per table
(module 9095). The iTNC 530 variant could not be sourced and is not written.

References
----------
HEIDENHAIN MANUALplus 620 Technical Manual (01/2012), 6.10.3 "Nonlinear axis error
compensation", pp. 713-716 (AXISPOS, BACKLASH, entering compensation values).
HEIDENHAIN TNC 407/415/425 Technical Manual, nonlinear axis error compensation (.CMA/.COM,
module 9095: 256 entries; datum and power-of-two spacing).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from volcal.compensate.reference import reference_line_notes
from volcal.compensate.tables import (
    AxisTable,
    axis_grid,
    pitch_table,
    require_finite,
    sign_factor,
)
from volcal.errors import ParameterError, VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

CMA_FILE = "VOLCAL.CMA"
NOTES_FILE = "HEIDENHAIN_NOTES.TXT"
"""Notes beside the tables (the ``.COM`` tables have no comment lines)."""
RESOLUTION_UM = 0.1  # 4 decimals in mm
DEFAULT_SIGN = "error"
SIGN_SOURCE = ("HEIDENHAIN TNC 407/415/425 technical manual, nonlinear axis error "
               "compensation example (table = error in mm); MANUALplus 620 technical "
               "manual 6.10.3 p. 716 (compensation values measured)")
WIDTHS = {"NR": 6, "AXISPOS": 14, "VALUE": 14, "BACKLASH": 14}
"""Column widths [characters]: each value starts where its header name starts."""


def _f(v: float, d: int) -> str:
    return f"{v:+.{d}f}"


def _row(cells: list[str], widths: list[int]) -> str:
    out = ""
    for c, w in zip(cells, widths, strict=True):
        if len(c) >= w:
            raise ValueError(f"value {c!r} wider than its column ({w})")
        out += c.ljust(w)
    return out.rstrip()


def heidenhain_files(errors: MachineErrors, spacing: float, sign: str = DEFAULT_SIGN,
                     max_points: int | None = None, directional=None) -> dict[str, str]:
    """``X.COM``, ``Y.COM``, ``Z.COM`` (positioning errors), ``VOLCAL.CMA`` and notes.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between compensation points [mm] (a multiple of 0.0001 mm).
    sign : str
        ``'error'`` (default, the HEIDENHAIN convention) or ``'correction'``.
    max_points : int, optional
        Entries allowed per ``.COM`` table (no limit by default: see your control's
        technical manual).
    directional : DirectionalErrors, optional
        Measured reversal: a ``BACKLASH`` column with the values of the negative
        direction is written for the axes that have it (otherwise no such column: the
        axis values apply in both directions).

    Returns
    -------
    dict of str to str
    """
    if abs(spacing * 1e4 - round(spacing * 1e4)) > 1e-6:
        raise ParameterError(f"{{spacing=}}{spacing:g}: Heidenhain positions have 4 decimals")
    s = sign_factor(sign)
    files = {}
    widths = [WIDTHS["NR"], WIDTHS["AXISPOS"], WIDTHS["VALUE"], WIDTHS["BACKLASH"]]
    for k in range(3):
        a = AXES[k]
        lo, hi = errors.travel[k]
        p = axis_grid(lo, hi, spacing, max_points=max_points, what=f"Heidenhain {a}")
        t = pitch_table(errors, k, p, sign, RESOLUTION_UM)
        half = directional.half_reversal(k, p) if directional is not None else 0.0 * p
        fwd = t.values + np.round(s * half / RESOLUTION_UM) * RESOLUTION_UM
        rev = t.values - np.round(s * half / RESOLUTION_UM) * RESOLUTION_UM
        require_finite(np.column_stack([fwd, rev]), p, f"Heidenhain {a}.COM")
        if directional is None or not directional.has(k):
            # "if required" (MANUALplus 620 p. 716): without measured reversal the column is
            # left out, so the axis values apply in both directions
            rows = [f"BEGIN {a}.COM MM", _row(["NR", "AXISPOS", a], widths[:3])]
            rows += [_row([str(n), _f(pos, 4), _f(vf / 1000.0, 4)], widths[:3])
                     for n, (pos, vf) in enumerate(zip(p, t.values, strict=True))]
        else:
            rows = [f"BEGIN {a}.COM MM", _row(["NR", "AXISPOS", a, "BACKLASH"], widths)]
            rows += [_row([str(n), _f(pos, 4), _f(vf / 1000.0, 4), _f(vr / 1000.0, 4)], widths)
                     for n, (pos, vf, vr) in enumerate(zip(p, fwd, rev, strict=True))]
        files[f"{a}.COM"] = "\n".join([*rows, "[END]"]) + "\n"
    cw = [6, 8, 10, 10, 10]
    cma = [f"BEGIN {CMA_FILE}", _row(["NR", "ACTIVE", "X", "Y", "Z"], cw),
           _row(["0", "*", "X.COM", "Y.COM", "Z.COM"], cw), "[END]"]
    files[CMA_FILE] = "\n".join(cma) + "\n"
    files[NOTES_FILE] = "\n".join([
        "volcal: HEIDENHAIN nonlinear axis error compensation (.COM tables, VOLCAL.CMA)",
        f"sign: {sign} (HEIDENHAIN convention: {DEFAULT_SIGN}; source: {SIGN_SOURCE})",
        "Not corrected: straightness, squareness and angular (Abbe) errors.",
        *([f"BACKLASH (negative direction) from the reversal measured in the session's "
           f"ISO 230-2 tests ({directional.source or 'none'}); an axis without it has no "
           "BACKLASH column (its values apply in both directions).", *directional.notes()]
          if directional is not None else []),
        *reference_line_notes(errors)]) + "\n"
    return files


def _columns(header: str) -> list[tuple[str, int, int]]:
    """(name, start, end) of each header name; the last column runs to the line end."""
    import re

    ms = list(re.finditer(r"\S+", header))
    return [(m.group(), m.start(), ms[i + 1].start() if i + 1 < len(ms) else 10**6)
            for i, m in enumerate(ms)]


def _table(path: Path) -> tuple[list[str], list[list[str]]]:
    """Read a fixed-width table: each value taken from its header name's columns."""
    try:
        lines = [ln.rstrip("\n") for ln in path.read_text(encoding="ascii").splitlines()
                 if ln.strip()]
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    if len(lines) < 3 or not lines[0].startswith("BEGIN") or lines[-1].strip() != "[END]":
        raise VolcalInputError("expected BEGIN ... [END]", path)
    cols = _columns(lines[1])
    rows = [[ln[a:b].strip() for _, a, b in cols] for ln in lines[2:-1]]
    return [c[0] for c in cols], rows


def read_heidenhain(folder: str | Path, sign: str = DEFAULT_SIGN, column: str | None = None
                    ) -> list[AxisTable]:
    """Read the active ``.COM`` tables named in ``VOLCAL.CMA``.

    Parameters
    ----------
    folder : str or Path
        Folder holding ``VOLCAL.CMA`` and the ``.COM`` files it names.
    sign : str
        ``'error'`` or ``'correction'``: the convention the tables were written in (the
        files do not record it); stored on the returned tables.
    column : str, optional
        ``'BACKLASH'`` to read the negative-direction values; default the axis column.

    Returns
    -------
    list of AxisTable
        One per assigned table (input axis = ``.CMA`` column, output = value column).
    """
    folder = Path(folder)
    head, rows = _table(folder / CMA_FILE)
    active = [r for r in rows if r[head.index("ACTIVE")] == "*"]
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
        j = h.index(column or out_axis[0])
        try:
            arr = np.array([[float(r[1]), float(r[j])] for r in data])
        except (ValueError, IndexError):
            raise VolcalInputError("bad number in table", folder / com) from None
        out.append(AxisTable(AXES.index(col), AXES.index(out_axis[0]), arr[:, 0],
                             arr[:, 1] * 1000.0, sign, RESOLUTION_UM))
    return out
