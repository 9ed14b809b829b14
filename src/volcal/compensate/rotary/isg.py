"""ISG / Beckhoff TwinCAT CNC: leadscrew error compensation (SSFK) of a rotary axis.

The ISG kernel (Beckhoff TF5200 "Axis compensation", FCT-C5) corrects one axis by its own
position with the **leadscrew error compensation** (SSFK, *Spindelsteigungsfehler-
kompensation*, LSEC): "The position setpoint of the compensated axis is changed by a
compensation value in the position controller timing ... This correction is cancelled by
computation for the measured actual position values so that the correction performed does
not appear in the display data". It is defined for translatory (T), rotary (R) and spindle
(S) axes and is the axis' own table, one per direction ("bilateral"), with a modulo mode
for rotary axes: the angular positioning error of a rotary axis belongs there (the
volumetric compensation TF5280 reads the component errors of the kinematic chain; volcal's
rotary tables wrote into its ISG CSV before, without the reversal).

The compensation value list of the axis (one ASCII list per axis, ``#`` comments):

===========================  =============  ===========================================
``kopf.achs_nr``             P-COMP-00001   logical axis number (placeholder: 4, 5, ...)
``kopf.log_achs_name``       P-COMP-00002   axis name
``kw.ssfk.unit``             P-COMP-00017   1: metric, "R,S: 0.0001°"
``kw.ssfk.interval``         P-COMP-00018   0: each interpolation point given
``kw.ssfk.kw_startpos``      P-COMP-00019   start position [0.0001°]
``kw.ssfk.kw_nr_max``        P-COMP-00020   number of entries (< P-COMP-00059, 1500)
``kw.ssfk.bilateral``        P-COMP-00021   1: a table per direction of motion
``kw.ssfk.modulo``           P-COMP-00022   1: "a modulo transition also takes place in
                                            the compensation table"
``kw.ssfk.table[i].setpoint`` P-COMP-00025  interpolation point [0.0001°]
``kw.ssfk.table[i].pos``     P-COMP-00023   value moving in the positive direction
``kw.ssfk.table[i].neg``     P-COMP-00024   value moving in the negative direction
===========================  =============  ===========================================

**Sign: the error.** The manual's worked example computes each value as
``Δs_i = s_ist,i - s_soll,i`` (actual minus programmed position: programmed 19866.7 µm,
measured 19856.5 µm moving positive, value -102 x 0.1 µm), i.e. volcal's error, which the
control subtracts from the set point. **Unit** 0.0001 deg (1.745 µrad): the values are
rounded to it. Between points the control interpolates linearly; on a full-circle axis
the table runs from 0 to 360 deg with the same value at both ends (the modulo table's
"first and last entry" alike) and wraps.

Activation: ``lr_param.ssfk 1`` (P-AXIS-00175) in the axis parameter list of the axis,
optionally ``lr_param.n_backlash_cyc`` (P-AXIS-00243: the reversal of a bilateral table
spread over cycles); the list is the axis' compensation value list.

References
----------
Beckhoff TF5200 TwinCAT 3 CNC, Axis compensation: "Leadscrew error compensation
(kw.ssfk.*)", P-COMP-00017 ... P-COMP-00025, P-COMP-00059, "Example of a compensation value
list" (bilateral, non-equidistant); Axis parameters P-AXIS-00175, P-AXIS-00243
(infosys.beckhoff.com, tf5200_axis_compensation_parameters, tf5200_axis_parameter).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.compensate.rotary.profile import DEG_PER_URAD, RotaryProfile
from volcal.compensate.tables import sign_factor
from volcal.errors import VolcalInputError

__all__ = ["isg_rotary_files", "read_isg_rotary"]

DEFAULT_SIGN = "error"
UNIT_DEG = 1e-4
"""``kw.ssfk.unit = 1`` on a rotary axis: positions and values in 0.0001 deg."""
MAX_POINTS = 1500
"""P-COMP-00059 default: the table holds fewer entries than this."""


def isg_rotary_files(p: RotaryProfile, name: str, sign: str = DEFAULT_SIGN,
                     axis_number: int = 4) -> tuple[dict[str, str], list[str]]:
    """The SSFK compensation value list of one rotary axis, bilateral, modulo when full.

    Parameters
    ----------
    p : RotaryProfile
        The axis' error.
    name : str
        File name.
    sign : str
        ``'error'`` (the ISG convention, default) or ``'correction'``.
    axis_number : int
        Logical axis number written as ``kopf.achs_nr`` (a placeholder).

    Returns
    -------
    files : dict of str to str
    notes : list of str
    """
    s = sign_factor(sign)
    ax = p.axis.upper()
    t = np.asarray(p.targets_deg, dtype=float)
    if p.modulo:
        t = np.unique(np.r_[0.0, np.mod(t, 360.0), 360.0])
    if t.size >= MAX_POINTS:
        raise VolcalInputError(f"ISG rotary table of {p.id}: {t.size} points, the SSFK "
                               f"table holds fewer than {MAX_POINTS} (P-COMP-00059)")
    up = np.round(s * p.error_urad(t, np.full(t.size, "+")) * DEG_PER_URAD / UNIT_DEG)
    down = np.round(s * p.error_urad(t, np.full(t.size, "-")) * DEG_PER_URAD / UNIT_DEG)
    pos = np.round(t / UNIT_DEG).astype(np.int64)
    rows = [f"# volcal: leadscrew error compensation (SSFK) of rotary axis {ax}, test {p.id}",
            "# deviation = actual - commanded angle (ISO 841 positive); values are the "
            + ("error (the ISG convention, table example: ds = s_ist - s_soll)"
               if sign == DEFAULT_SIGN else
               "correction = -error: NOT the ISG convention, the error doubles"),
            "# positions and values in 0.0001 deg (kw.ssfk.unit 1, rotary axis)",
            "# activate: lr_param.ssfk 1 (P-AXIS-00175) in the axis parameter list",
            f"kopf.achs_nr {axis_number}",
            f"kopf.log_achs_name {ax}",
            "kw.ssfk.unit 1",
            "kw.ssfk.interval 0",
            f"kw.ssfk.kw_startpos {int(pos[0])}",
            f"kw.ssfk.kw_nr_max {t.size}",
            "kw.ssfk.bilateral 1",
            f"kw.ssfk.modulo {1 if p.modulo else 0}"]
    rows += [f"kw.ssfk.table[{i}].setpoint {int(v)}" for i, v in enumerate(pos)]
    rows += [f"kw.ssfk.table[{i}].pos {int(v)}" for i, v in enumerate(up)]
    rows += [f"kw.ssfk.table[{i}].neg {int(v)}" for i, v in enumerate(down)]
    notes = ["", f"Rotary axis {ax} (test {p.id}): {name}, the ISG leadscrew error "
             f"compensation list (kw.ssfk.*) of the axis, {t.size} points "
             + ("0..360 deg, modulo (the same value at both ends)" if p.modulo
                else "at the targets (a limited axis)"),
             "Bilateral: kw.ssfk.table[i].pos for the positive approach (ISO 230-2 up), .neg "
             "for the negative one; " + ("both measured." if p.bidirectional else
                                         "one direction measured: both the same."),
             "Values in 0.0001 deg (1.745 urad), rounded; sign " + sign + ".",
             f"Activate: lr_param.ssfk 1 (P-AXIS-00175) for the axis; kopf.achs_nr "
             f"{axis_number} is a placeholder: the machine's logical axis number."]
    return {name: "\n".join(rows) + "\n"}, notes


def read_isg_rotary(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                               NDArray[np.float64], bool]:
    """Points [deg] and the positive- and negative-direction values [deg] of an SSFK list.

    Parameters
    ----------
    path : str or Path
        The list written by :func:`isg_rotary_files` (``kw.ssfk.unit 1``).

    Returns
    -------
    points, pos, neg : ndarray
        Interpolation points and the values of each direction [deg].
    modulo : bool
        ``kw.ssfk.modulo``.
    """
    path = Path(path)
    scalars: dict[str, int] = {}
    table: dict[str, dict[int, int]] = {"setpoint": {}, "pos": {}, "neg": {}}
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        mt = re.fullmatch(r"kw\.ssfk\.table\[(\d+)\]\.(setpoint|pos|neg)\s+([-+]?\d+)", line)
        if mt:
            table[mt.group(2)][int(mt.group(1))] = int(mt.group(3))
            continue
        ms = re.fullmatch(r"(kopf\.achs_nr|kw\.ssfk\.\w+)\s+([-+]?\d+)", line)
        if ms:
            scalars[ms.group(1)] = int(ms.group(2))
        elif not line.startswith("kopf."):
            raise VolcalInputError(f"not an SSFK list line: {line!r}", path, row=n)
    if scalars.get("kw.ssfk.unit") != 1 or scalars.get("kw.ssfk.interval") != 0:
        raise VolcalInputError("expected kw.ssfk.unit 1 and kw.ssfk.interval 0", path)
    count = scalars.get("kw.ssfk.kw_nr_max", -1)
    idx = list(range(count))
    if count < 2 or any(sorted(t) != idx for t in table.values()):
        raise VolcalInputError(f"kw.ssfk.kw_nr_max {count}: the table must have entries "
                               "0 .. kw_nr_max - 1 of setpoint, pos and neg", path)
    pts, up, down = (np.array([table[k][i] for i in idx], dtype=float) * UNIT_DEG
                     for k in ("setpoint", "pos", "neg"))
    if not np.all(np.diff(pts) > 0):
        raise VolcalInputError("kw.ssfk.table[i].setpoint not increasing", path)
    return pts, up, down, bool(scalars.get("kw.ssfk.modulo", 0))
