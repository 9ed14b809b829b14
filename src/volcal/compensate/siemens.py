"""SINUMERIK 840D: leadscrew/encoder error compensation (LEC) and sag/cross compensation (CEC).

LEC (function manual K3, "Interpolatory compensation"): one table per machine axis and
measuring system, written as a part program ``%_N_AX_EEC_INI`` that sets

* ``$AA_ENC_COMP[e,N,AXi]`` compensation value of point N [mm],
* ``$AA_ENC_COMP_STEP[e,AXi]`` distance between points [mm],
* ``$AA_ENC_COMP_MIN[e,AXi]`` / ``_MAX`` first and last point [mm],
* ``$AA_ENC_COMP_IS_MODULO[e,AXi]`` = 0.

The control interpolates linearly between points and keeps the first and last value
outside the table; the number of points must not exceed MD38000
``$MA_MM_ENC_COMP_MAX_POINTS``. "A positive compensation value causes the machine axis
to move in the negative direction": the LEC table wants the **error** (sign='error').

CEC (``%_N_NC_CEC_INI``): tables ``$AN_CEC[t,N]`` add a value to an output axis as a
function of an input axis (``$AN_CEC_INPUT_AXIS``, ``$AN_CEC_OUTPUT_AXIS``,
``$AN_CEC_STEP``, ``$AN_CEC_MIN``, ``$AN_CEC_MAX``, ``$AN_CEC_DIRECTION``,
``$AN_CEC_MULT_BY_TABLE``, ``$AN_CEC_IS_MODULO``): volcal writes the six straightness
functions (with the squareness term whose lever is the input axis) as tables 0..5. The
axes are assigned as in the manual's example, ``$AN_CEC_INPUT_AXIS[t]=(AX1)``. A table
is evaluated only when MD32710 ``$MA_CEC_ENABLE[AXi]`` = 1 for the output axis and SD41300
``$SN_CEC_TABLE_ENABLE[t]`` = 1; MD18342 ``$MN_MM_CEC_MAX_POINTS[t]`` must hold the number
of points (K3 03/2013 pp. 245, 248, 264). CEC values enter the same total compensation
value of the axis as the LEC values ("the total compensation value is derived from the sum
of the individual compensation values", K3 p. 245), so they take the LEC sign: **error**.

Values are written in mm with 6 decimals (resolution 0.001 um). The machine axes are
named ``AX1``, ``AX2``, ``AX3`` (X, Y, Z); rename them if your machine differs.

References
----------
SINUMERIK 840D sl Function Manual Extended Functions (6FC5397-1BP40-3BA1, 03/2013), K3:
Compensation, 4.4 Interpolatory compensation (LEC and CEC system variables, the example
``%_N_AX_EEC_INI``; CEC activation p. 245, table parameters p. 248, MD18342 p. 264,
``$AN_CEC_INPUT_AXIS[0] = (XX)`` p. 268). SINUMERIK 808D Function Manual (sign of the LEC
value).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from volcal.compensate.reference import reference_line_notes
from volcal.compensate.tables import AxisTable, axis_grid, cross_table, pitch_table
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

LEC_FILE = "SIEMENS_LEC_AX_EEC_INI.SPF"
CEC_FILE = "SIEMENS_CEC_NC_CEC_INI.SPF"
RESOLUTION_UM = 0.001
DEFAULT_SIGN = "error"
SIGN_SOURCE = ("SINUMERIK K3 (6FC5397-1BP40-3BA1): 'a positive compensation value causes "
               "the machine axis to move in the negative direction'; CEC values add to the "
               "same total compensation value (p. 245)")
CEC_PAIRS: tuple[tuple[int, int], ...] = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
"""(input axis, output axis) of CEC tables 0..5: EYX, EZX, EXY, EZY, EXZ, EYZ."""


def _mm(v_um: float) -> str:
    return f"{v_um / 1000.0:.6f}"


def siemens_files(errors: MachineErrors, spacing: float, sign: str = DEFAULT_SIGN,
                  max_points: int = 5000, include_squareness: bool = True
                  ) -> dict[str, str]:
    """LEC and CEC initialisation programs of the model.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between interpolation points [mm].
    sign : str
        ``'error'`` (what the LEC expects) or ``'correction'``.
    max_points : int
        MD38000 ``MM_ENC_COMP_MAX_POINTS`` (and the CEC equivalent MD18342).
    include_squareness : bool
        Add the squareness terms to the CEC tables.

    Returns
    -------
    dict of str to str
        File name -> content.
    """
    warn = ("" if sign == DEFAULT_SIGN else
            " (NOT the Siemens convention: loading this doubles the error)")
    lec = ["%_N_AX_EEC_INI", "CHANDATA(1)",
           f"; volcal: positioning errors EXX, EYY, EZZ, sign = {sign}{warn}, values in mm",
           f"; sign source: {SIGN_SOURCE}",
           "; activate: MD32700 $MA_ENC_COMP_ENABLE[0,AXi]=1 after running this program, "
           "MD38000 $MA_MM_ENC_COMP_MAX_POINTS >= points, NCK reset",
           "; AX1..AX3 = X, Y, Z: rename to your machine axes; tables are zero at the start "
           "of travel", *("; " + n for n in reference_line_notes(errors))]
    cec = ["%_N_NC_CEC_INI", "CHANDATA(1)",
           f"; volcal: straightness (and squareness) tables, sign = {sign}{warn}, values in mm",
           f"; sign source: {SIGN_SOURCE}",
           "; activate: MD18342 $MN_MM_CEC_MAX_POINTS[t] >= points of table t, "
           "MD32710 $MA_CEC_ENABLE[AXi]=1 for each output axis, SD41300 "
           "$SN_CEC_TABLE_ENABLE[t]=1 (set below), NCK reset"]
    for k in range(3):
        lo, hi = errors.travel[k]
        p = axis_grid(lo, hi, spacing, max_points=max_points,
                      what=f"Siemens LEC {AXES[k]}")
        t = pitch_table(errors, k, p, sign, RESOLUTION_UM)
        ax = f"AX{k + 1}"
        lec += [f"$AA_ENC_COMP[0,{n},{ax}]={_mm(v)}" for n, v in enumerate(t.values)]
        lec += [f"$AA_ENC_COMP_STEP[0,{ax}]={spacing:.6f}",
                f"$AA_ENC_COMP_MIN[0,{ax}]={p[0]:.6f}", f"$AA_ENC_COMP_MAX[0,{ax}]={p[-1]:.6f}",
                f"$AA_ENC_COMP_IS_MODULO[0,{ax}]=0"]
    for ti, (a_in, a_out) in enumerate(CEC_PAIRS):
        lo, hi = errors.travel[a_in]
        p = axis_grid(lo, hi, spacing, max_points=max_points,
                      what=f"Siemens CEC {AXES[a_in]}")
        t = cross_table(errors, a_in, a_out, p, sign, RESOLUTION_UM, include_squareness)
        cec.append(f"; table {ti}: {t.name}")
        cec += [f"$AN_CEC[{ti},{n}]={_mm(v)}" for n, v in enumerate(t.values)]
        cec += [f"$AN_CEC_INPUT_AXIS[{ti}]=(AX{a_in + 1})",
                f"$AN_CEC_OUTPUT_AXIS[{ti}]=(AX{a_out + 1})",
                f"$AN_CEC_STEP[{ti}]={spacing:.6f}", f"$AN_CEC_MIN[{ti}]={p[0]:.6f}",
                f"$AN_CEC_MAX[{ti}]={p[-1]:.6f}", f"$AN_CEC_DIRECTION[{ti}]=0",
                f"$AN_CEC_MULT_BY_TABLE[{ti}]=0", f"$AN_CEC_IS_MODULO[{ti}]=0",
                f"$SN_CEC_TABLE_ENABLE[{ti}]=1"]
    return {LEC_FILE: "\n".join([*lec, "M17"]) + "\n", CEC_FILE: "\n".join([*cec, "M17"]) + "\n"}


_ASSIGN = re.compile(r"^\$(AA_ENC_COMP|AN_CEC|SN_CEC)(_[A-Z_]+)?\[([^\]]+)\]=\s*(\S+)$")


def _parse(path: Path) -> dict[tuple[str, tuple[str, ...]], str]:
    try:
        lines = path.read_text(encoding="ascii").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    out = {}
    for i, raw in enumerate(lines, start=1):
        line = raw.split(";", 1)[0].strip()
        if not line or line in ("CHANDATA(1)", "M17") or line.startswith("%_N_"):
            continue
        m = _ASSIGN.match(line)
        if not m:
            raise VolcalInputError(f"unexpected line {line!r}", path, i)
        key = (m.group(1) + (m.group(2) or ""), tuple(s.strip() for s in m.group(3).split(",")))
        out[key] = m.group(4)
    return out


def _table(vals: dict[int, float], step: float, lo: float, hi: float, path: Path, what: str):
    n = int(round((hi - lo) / step)) + 1
    if sorted(vals) != list(range(n)):
        raise VolcalInputError(f"{what}: points 0..{n - 1} expected from MIN, MAX, STEP", path)
    return lo + step * np.arange(n), np.array([vals[i] for i in range(n)]) * 1000.0


def read_lec(path: str | Path, sign: str) -> list[AxisTable]:
    """Read an LEC program back into tables (positions [mm], values [um]).

    Parameters
    ----------
    path : str or Path
        The ``%_N_AX_EEC_INI`` part program (``$AA_ENC_COMP`` assignments in mm).
    sign : str
        ``'error'`` or ``'correction'``: the convention the values were written in (the
        program does not record it); stored on the returned tables.

    Returns
    -------
    list of AxisTable
        The pitch tables of AX1, AX2, AX3 (X, Y, Z).
    """
    path = Path(path)
    d = _parse(path)
    out = []
    for k in range(3):
        ax = f"AX{k + 1}"
        vals = {int(i[1]): float(v) for (name, i), v in d.items()
                if name == "AA_ENC_COMP" and i[2] == ax}
        try:
            step, lo, hi = (float(d[(f"AA_ENC_COMP_{w}", ("0", ax))])
                            for w in ("STEP", "MIN", "MAX"))
        except KeyError as exc:
            raise VolcalInputError(f"missing {exc.args[0][0]} of {ax}", path) from None
        p, v = _table(vals, step, lo, hi, path, ax)
        out.append(AxisTable(k, k, p, v, sign, RESOLUTION_UM))
    return out


def read_cec(path: str | Path, sign: str) -> list[AxisTable]:
    """Read a CEC program back into tables (positions [mm], values [um]).

    Parameters
    ----------
    path : str or Path
        The ``%_N_NC_CEC_INI`` part program (``$AN_CEC`` assignments in mm).
    sign : str
        ``'error'`` or ``'correction'``: the convention the values were written in (the
        program does not record it); stored on the returned tables.

    Returns
    -------
    list of AxisTable
        One table per CEC table number, in ascending order.
    """
    path = Path(path)
    d = _parse(path)
    out = []
    ids = sorted({int(i[0]) for (name, i) in d if name == "AN_CEC_INPUT_AXIS"})
    for t in ids:
        par = {w: d.get((f"AN_CEC_{w}", (str(t),)), "")
               for w in ("INPUT_AXIS", "OUTPUT_AXIS", "STEP", "MIN", "MAX")}
        try:
            a_in, a_out = (int(par[w].strip("()").removeprefix("AX")) - 1
                           for w in ("INPUT_AXIS", "OUTPUT_AXIS"))
            step, lo, hi = (float(par[w]) for w in ("STEP", "MIN", "MAX"))
        except ValueError as exc:
            raise VolcalInputError(f"table {t}: incomplete or bad parameters ({exc})",
                                   path) from None
        vals = {int(i[1]): float(v) for (name, i), v in d.items()
                if name == "AN_CEC" and int(i[0]) == t}
        p, v = _table(vals, step, lo, hi, path, f"table {t}")
        out.append(AxisTable(a_in, a_out, p, v, sign, RESOLUTION_UM))
    return out
