"""SINUMERIK 840D LEC of a rotary (modulo) axis, direction-dependent part as CEC tables.

The leadscrew/encoder error compensation (function manual K3, 4.4 "Interpolatory
compensation") of a rotary axis uses the same system variables as a linear axis
(:mod:`volcal.compensate.siemens`), in the axis' unit, **degrees**: ``$AA_ENC_COMP[e,N,AXi]``
(value of point N), ``$AA_ENC_COMP_STEP`` (distance between points, equidistant),
``$AA_ENC_COMP_MIN`` / ``_MAX`` (first and last point) and, for a modulo rotary axis,
``$AA_ENC_COMP_IS_MODULO[e,AXi] = 1``: the table then covers the modulo range (MD30330
``$MA_MODULO_RANGE``, 360 deg, from MD30340 ``MODULO_RANGE_START``, 0) and is evaluated
modulo that range; its first and last values (0 and 360 deg, one position) are equal. The
table holds the **error** ("a positive compensation value causes the machine axis to move
in the negative direction", as for linear axes). Activation: MD32700
``$MA_ENC_COMP_ENABLE[0,AXi] = 1`` after the program has run, MD38000
``$MA_MM_ENC_COMP_MAX_POINTS`` at least the number of points, NCK reset.

The LEC has one table per axis and measuring system, used in both directions: it holds
the mean of the two approach directions. The difference (the reversal) is written as two
direction-dependent compensation tables of the CEC (K3 "Direction-dependent leadscrew error
compensation": input and output axis the axis itself, ``$AN_CEC_DIRECTION[t] = 1``
effective only while the axis moves in the positive direction, ``-1`` only in the negative
one, ``$AN_CEC_IS_MODULO[t] = 1``), values +/- half the reversal (error sign), tables 6 and
7 (after the six tables of the linear axes). Activation: MD32710 ``$MA_CEC_ENABLE[AXi] = 1``,
MD18342 ``$MN_MM_CEC_MAX_POINTS[t]``, SD41300 ``$SN_CEC_TABLE_ENABLE[t] = 1``.

The rotary machine axes are named ``AX4``, ``AX5`` in the order of the session's rotary
tests: rename them to your machine's axes.

References
----------
SINUMERIK 840D sl Function Manual Extended Functions (6FC5397-1BP40-3BA1, 03/2013), K3:
4.4 Interpolatory compensation (LEC system variables, ``$AA_ENC_COMP_IS_MODULO``, CEC
``$AN_CEC_DIRECTION``, ``$AN_CEC_IS_MODULO``); Function Manual Axes and Spindles R2 (MD30330,
MD30340 modulo range).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.compensate.rotary.profile import DEG_PER_URAD, RotaryProfile
from volcal.compensate.tables import sign_factor
from volcal.errors import ParameterError, VolcalInputError

__all__ = ["ROT_CEC_FILE", "ROT_LEC_FILE", "read_siemens_rotary", "siemens_grid",
           "siemens_rotary_files"]

ROT_LEC_FILE = "SIEMENS_LEC_ROTARY_EEC_INI.SPF"
ROT_CEC_FILE = "SIEMENS_CEC_ROTARY_CEC_INI.SPF"
DEFAULT_SIGN = "error"
FIRST_CEC_TABLE = 6
"""The linear axes' CEC tables are 0..5."""


def siemens_grid(p: RotaryProfile, spacing_deg: float) -> NDArray[np.float64]:
    """Equidistant points [deg]: 0..360 on a full-circle axis, the targets' span otherwise.

    Parameters
    ----------
    p : RotaryProfile
        The axis' error.
    spacing_deg : float
        Distance between points [deg].

    Returns
    -------
    ndarray
    """
    if not math.isfinite(spacing_deg) or spacing_deg <= 0:
        raise ParameterError(f"{{rotary_spacing=}}{spacing_deg}: expected a positive angle "
                             "[deg]")
    if p.modulo:
        n = 360.0 / spacing_deg
        if abs(n - round(n)) > 1e-6:
            raise ParameterError(f"{{rotary_spacing=}}{spacing_deg:g}: a modulo table needs "
                                 "a spacing that divides 360 deg")
        return np.asarray(spacing_deg * np.arange(int(round(n)) + 1), dtype=np.float64)
    lo, hi = float(p.targets_deg[0]), float(p.targets_deg[-1])
    n = math.ceil((hi - lo) / spacing_deg - 1e-9)
    return np.asarray(lo + spacing_deg * np.arange(n + 1), dtype=np.float64)


def siemens_rotary_files(profiles: list[RotaryProfile], spacing_deg: float,
                         sign: str = DEFAULT_SIGN, max_points: int = 5000
                         ) -> tuple[dict[str, str], list[str]]:
    """The LEC program (and the CEC program when a test is bidirectional) of the axes.

    Parameters
    ----------
    profiles : list of RotaryProfile
        One per rotary axis (AX4, AX5, ... in this order).
    spacing_deg : float
        Distance between points [deg] (divides 360 on a modulo axis).
    sign : str
        ``'error'`` (the Siemens convention, default) or ``'correction'``.
    max_points : int
        MD38000 ``MM_ENC_COMP_MAX_POINTS``.

    Returns
    -------
    files : dict of str to str
    notes : list of str
    """
    s = sign_factor(sign)
    warn = "" if sign == DEFAULT_SIGN else " (NOT the Siemens convention: doubles the error)"
    lec = ["%_N_VOLCAL_ROTARY_EEC_INI", "CHANDATA(1)",
           f"; volcal: angular positioning errors of rotary axes, sign = {sign}{warn}, "
           "values in degrees",
           "; activate: MD32700 $MA_ENC_COMP_ENABLE[0,AXi]=1 after running this program, "
           "MD38000 $MA_MM_ENC_COMP_MAX_POINTS >= points, NCK reset"]
    cec = ["%_N_VOLCAL_ROTARY_CEC_INI", "CHANDATA(1)",
           f"; volcal: direction-dependent part of the rotary LEC, sign = {sign}{warn}, deg",
           "; activate: MD32710 $MA_CEC_ENABLE[AXi]=1, MD18342 $MN_MM_CEC_MAX_POINTS[t] >= "
           "points, SD41300 $SN_CEC_TABLE_ENABLE[t]=1 (set below), NCK reset"]
    notes: list[str] = []
    table = FIRST_CEC_TABLE
    any_bidir = False
    for i, p in enumerate(profiles):
        ax = f"AX{4 + i}"
        g = siemens_grid(p, spacing_deg)
        if g.size > max_points:
            raise ParameterError(f"Siemens LEC {ax}: {g.size} points exceed "
                                 f"MD38000 = {max_points}; use a larger {{rotary_spacing}}")
        mean = s * p.error_urad(g) * DEG_PER_URAD
        if p.modulo:
            mean[-1] = mean[0]  # 0 and 360 deg: one position
        lec.append(f"; {ax} = rotary axis {p.axis.upper()} (test {p.id})")
        lec += [f"$AA_ENC_COMP[0,{n},{ax}]={v:.7f}" for n, v in enumerate(mean)]
        lec += [f"$AA_ENC_COMP_STEP[0,{ax}]={spacing_deg:.6f}",
                f"$AA_ENC_COMP_MIN[0,{ax}]={g[0]:.6f}", f"$AA_ENC_COMP_MAX[0,{ax}]={g[-1]:.6f}",
                f"$AA_ENC_COMP_IS_MODULO[0,{ax}]={1 if p.modulo else 0}"]
        notes += ["", f"Rotary axis {p.axis.upper()} (test {p.id}) = {ax}: LEC {g.size} points "
                  f"{g[0]:g}..{g[-1]:g} deg every {spacing_deg:g} deg"
                  + (", modulo (IS_MODULO = 1)" if p.modulo else "")]
        if not p.bidirectional:
            notes.append("One approach direction measured: no direction-dependent table.")
            continue
        any_bidir = True
        for direction, d in (("+", 1), ("-", -1)):
            half = s * (p.error_urad(g, direction) - p.error_urad(g)) * DEG_PER_URAD
            if p.modulo:
                half[-1] = half[0]
            cec.append(f"; table {table}: {ax} moving {'positive' if d > 0 else 'negative'}")
            cec += [f"$AN_CEC[{table},{n}]={v:.7f}" for n, v in enumerate(half)]
            cec += [f"$AN_CEC_INPUT_AXIS[{table}]=({ax})", f"$AN_CEC_OUTPUT_AXIS[{table}]=({ax})",
                    f"$AN_CEC_STEP[{table}]={spacing_deg:.6f}", f"$AN_CEC_MIN[{table}]={g[0]:.6f}",
                    f"$AN_CEC_MAX[{table}]={g[-1]:.6f}", f"$AN_CEC_DIRECTION[{table}]={d}",
                    f"$AN_CEC_MULT_BY_TABLE[{table}]=0",
                    f"$AN_CEC_IS_MODULO[{table}]={1 if p.modulo else 0}",
                    f"$SN_CEC_TABLE_ENABLE[{table}]=1"]
            table += 1
        notes.append(f"Reversal: CEC tables {table - 2} (positive) and {table - 1} (negative "
                     f"direction) in {ROT_CEC_FILE}.")
    files = {ROT_LEC_FILE: "\n".join([*lec, "M17"]) + "\n"}
    if any_bidir:
        files[ROT_CEC_FILE] = "\n".join([*cec, "M17"]) + "\n"
    return files, notes


_ASSIGN = re.compile(r"^\$(AA_ENC_COMP|AN_CEC)(_[A-Z_]+)?\[([^\]]+)\]=\s*\(?([^)\s]+)\)?$")


def read_siemens_rotary(folder: str | Path, ax: str
                        ) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64], bool]]:
    """The tables of one rotary machine axis, read from the programs.

    Parameters
    ----------
    folder : str or Path
        The compensation folder.
    ax : str
        The machine axis (``AX4``).

    Returns
    -------
    dict
        ``{'lec'|'+'|'-': (points, values, modulo)}`` [deg], points MIN + N * STEP.
    """
    folder = Path(folder)
    out: dict[str, tuple[NDArray[np.float64], NDArray[np.float64], bool]] = {}
    lec: dict[str, dict[str, str]] = {}
    cec: dict[str, dict[str, str]] = {}
    for fname, store in ((ROT_LEC_FILE, lec), (ROT_CEC_FILE, cec)):
        path = folder / fname
        if not path.is_file():
            continue
        for line in path.read_text(encoding="ascii").splitlines():
            mt = _ASSIGN.match(line.strip())
            if not mt:
                continue
            base, suffix, idx, val = mt.groups()
            parts = [x.strip() for x in idx.split(",")]
            key = parts[-1] if base == "AA_ENC_COMP" else parts[0]  # AXi, or table number
            field = suffix if suffix else f"#{parts[1]}"  # a point: its number
            store.setdefault(key, {})[field] = val

    def build(d: dict[str, str], what: str
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
        try:
            vals = sorted((int(k[1:]), float(v)) for k, v in d.items() if k.startswith("#"))
            step, lo = float(d["_STEP"]), float(d["_MIN"])
            modulo = d.get("_IS_MODULO", "0") == "1"
        except (KeyError, ValueError):
            raise VolcalInputError(f"{what}: incomplete table", folder) from None
        v = np.array([x for _, x in vals], dtype=np.float64)
        return np.asarray(lo + step * np.arange(v.size), dtype=np.float64), v, modulo

    if ax in lec:
        out["lec"] = build(lec[ax], f"LEC {ax}")
    for t, d in cec.items():
        if d.get("_INPUT_AXIS") == ax and d.get("_OUTPUT_AXIS") == ax:
            key = "+" if d.get("_DIRECTION") == "1" else "-"
            out[key] = build(d, f"CEC table {t}")
    return out
