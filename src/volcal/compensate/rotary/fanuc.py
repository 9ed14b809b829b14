"""Fanuc pitch error compensation of a rotary axis (parameters 3620-3625, rotary type).

The rotary case of the pitch error compensation (FANUC Series 0i-PB parameter manual
B-63980EN/01, parameters 3620-3625, "Example 2) For the rotation axis", p. 100):

======  ==================================================================
3620    compensation point number of the reference position (``n_ref``)
3621    most distant point on the negative side: for a rotation axis always ``n_ref``
3622    most distant point on the positive side: ``n_ref + 3625 / 3624``
3623    magnification
3624    interval between compensation points (30i class: deg, real type; 16i/18i/0i-C:
        detection units); it must divide 3625
3625    amount of travel per rotation (360 deg; 30i real, 16i detection units)
======  ==================================================================

As for a linear axis, the value at point ``n_ref + k`` is **incremental**: the change of
the compensation over the section ``((k - 1) d, k d]`` after the reference position, in
detection units (IS-B: 0.001 deg) divided by the magnification, added to the command
(volcal writes the **correction**, -error, as for the linear tables); the compensation at
the reference position is zero, so the table carries the error relative to its value at the
reference angle (0 deg: the reference position of the axis) and the constant part is the
zero offset of the axis. "If the sum of the compensation value from 61 to 68 is not zero,
the pitch error per rotation accumulates, resulting in a positional shift": volcal rounds
the cumulative compensation, so the increments of one revolution sum to exactly zero; and
"for compensation position 60 set the same compensation value as for 68": point ``n_ref``
repeats the value of point ``n_ref + N``.

The rotary table is unidirectional here (the mean of both approach directions; the
bidirectional function 3605#0 with 3626/3627 is not written for rotary axes): the notes
say so when the test measured a reversal. The axis is control axis ``axis_number``
(default 4, ``A4`` in the parameter lines); the points ``n_ref .. n_ref + N`` share the
table of all axes with the linear ones (volcal's linear tables start at 0): pick
``n_ref`` above them.

Sign: Fanuc's manuals name the value the "compensation value" output at each point (pulses
added to the command); the explicit rule is the GSK983Ma manual's (a FANUC-compatible
control, Appendix 8, stored pitch error compensation of a rotary axis): "When the error is
'+' (excessive movement), the compensation value is '-'", the **correction**. Not found in a
FANUC manual: that sentence, the unit of the real parameters 3624/3625 of a rotation axis
on the 30i class (deg is assumed, as mm for a linear axis), and the bidirectional rotary
case (docs/controllers.md).

References
----------
FANUC Series 0i-PB Parameter Manual B-63980EN/01, parameters 3620-3625 and the rotation
axis example (p. 100). FANUC Series 16i/18i-MA/TA technical report A-77810E (3605#0,
3620-3627; "3625 For a rotation axis, amount of travel per rotation"). GSK983Ma
connection and operation manual, Appendix 8 (the sign rule). FANUC Series
30i/31i/32i-MODEL A Parameter Manual B-63950EN/02 (parameter I/O format ``N03620Q1A4P..``,
real parameters 3624/3625 on the 30i class).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.compensate.fanuc import SERIES
from volcal.compensate.rotary.profile import DEG_PER_URAD, RotaryProfile
from volcal.compensate.tables import sign_factor
from volcal.errors import ParameterError, VolcalInputError

__all__ = ["ROT_PARAM_FILE", "ROT_PITCH_FILE", "TABLE_POINTS", "fanuc_point_clash",
           "fanuc_rotary_files", "read_fanuc_rotary", "table_points"]

ROT_PARAM_FILE = "FANUC_ROTARY_PARAM_{}.TXT"
ROT_PITCH_FILE = "FANUC_ROTARY_PITCH_{}.TXT"
"""File names; ``{}`` is the axis letter (with the test id when an axis repeats)."""
DEFAULT_SIGN = "correction"
DEFAULT_REFERENCE_NUMBER = 900
TABLE_POINTS = 1024
"""Points of the pitch error table all axes share (0..1023; parameters 3620-3622 of
FANUC B-63980EN/01 take 0..1023)."""


def table_points(spacing_deg: float) -> int:
    """Points a full-circle axis' table takes: ``n_ref .. n_ref + 360 / spacing`` [1].

    Parameters
    ----------
    spacing_deg : float
        Parameter 3624 [deg].

    Returns
    -------
    int
    """
    return int(round(360.0 / spacing_deg)) + 1


def fanuc_rotary_files(p: RotaryProfile, spacing_deg: float, sign: str = DEFAULT_SIGN,
                       unit_deg: float = 0.001, magnification: int = 1,
                       max_increment: int = 7, reference_number: int = DEFAULT_REFERENCE_NUMBER,
                       axis_number: int = 4, max_points: int = TABLE_POINTS, series: str = "30i",
                       stem: str = "C") -> tuple[dict[str, str], list[str]]:
    """Parameter and pitch data lines of one full-circle rotary axis.

    Parameters
    ----------
    p : RotaryProfile
        The axis' error (a full-circle axis).
    spacing_deg : float
        Parameter 3624 [deg]: divides 360 and is a whole number of detection units.
    sign : str
        ``'correction'`` (Fanuc adds the value to the command, default) or ``'error'``.
    unit_deg : float
        Detection unit [deg] (0.001 for IS-B).
    magnification : int
        Parameter 3623.
    max_increment : int
        Largest value per point.
    reference_number : int
        Parameter 3620.
    axis_number : int
        Control axis number of the rotary axis (``A<n>`` in the parameter lines).
    max_points : int
        Size of the shared table.
    series : str
        ``'30i'`` or ``'16i'`` parameter syntax.
    stem : str
        Axis name in the file names.

    Returns
    -------
    files : dict of str to str
    notes : list of str
    """
    s = sign_factor(sign)
    if series not in SERIES:
        raise ParameterError(f"{{fanuc_series=}}{series!r}: expected one of {', '.join(SERIES)}")
    if not p.modulo:
        raise VolcalInputError(f"Fanuc rotary table of {p.id}: the rotation-axis type of "
                               "parameters 3620-3625 is for full-circle axes; a limited rotary "
                               "axis takes a linear-type table (not written)")
    n = 360.0 / spacing_deg
    units = spacing_deg / unit_deg
    if (abs(n - round(n)) > 1e-6 or abs(units - round(units)) > 1e-6 or round(n) < 2):
        raise ParameterError(f"{{rotary_spacing=}}{spacing_deg:g}: parameter 3624 must divide "
                             f"360 deg and be a whole number of detection units ({unit_deg:g} "
                             "deg)")
    if not 1 <= magnification <= 100:
        raise ParameterError(f"{{magnification=}}{magnification}: Fanuc allows 1..100")
    npts = int(round(n))
    last = reference_number + npts
    if reference_number < 0 or last > max_points - 1:
        raise ParameterError(f"Fanuc rotary table of {p.id}: points {reference_number}.."
                             f"{last} do not fit the table of {max_points} points shared by "
                             "all axes; use a larger {rotary_spacing}")
    g = spacing_deg * np.arange(npts + 1)
    corr = s * p.error_urad(g) * DEG_PER_URAD  # mean of both directions [deg]
    corr = corr - corr[0]  # zero at the reference position
    corr[-1] = 0.0  # 360 deg = the reference position
    cum = np.round(corr / (unit_deg * magnification)).astype(int)
    inc = np.diff(cum)  # point n_ref + k: the change over ((k-1) d, k d]
    big = np.flatnonzero(np.abs(inc) > max_increment)
    if big.size:
        k = int(big[0]) + 1
        raise ParameterError(f"Fanuc rotary table of {p.id}: point {reference_number + k} "
                             f"({g[k]:g} deg) needs {inc[k - 1]} units, more than "
                             f"{max_increment}; use a smaller {{rotary_spacing}} or a larger "
                             "{magnification} / {max_increment}")
    real = series == "30i"

    def par(num: int, v: object) -> str:
        return (f"N{num:05d}Q1A{axis_number}P{v}" if real else f"N{num:04d}A{axis_number}P{v}")

    params = [par(3620, reference_number), par(3621, reference_number), par(3622, last),
              par(3623, magnification),
              par(3624, f"{spacing_deg:.3f}" if real else int(round(units))),
              par(3625, "360.000" if real else int(round(360.0 / unit_deg)))]
    data = [(reference_number, int(inc[-1]))]  # "set the same value as for the last point"
    data += [(reference_number + k, int(inc[k - 1])) for k in range(1, npts + 1)]
    pitch = [f"N{10000 + num}Q0P{v}" if real else f"N{10000 + num}P{v}" for num, v in data]
    head = ["%"]
    pname, dname = ROT_PARAM_FILE.format(stem), ROT_PITCH_FILE.format(stem)
    files = {pname: "\n".join([*head, *params, "%"]) + "\n",
             dname: "\n".join([*head, *pitch, "%"]) + "\n"}
    notes = [
        "", f"Rotary axis {p.axis.upper()} (test {p.id}) = control axis {axis_number}: "
        f"{pname}, {dname}",
        f"3620 = {reference_number} (reference position, 0 deg), 3621 = {reference_number}, "
        f"3622 = {last}, 3623 = {magnification}, 3624 = {spacing_deg:g} deg, 3625 = 360 deg; "
        f"detection unit {unit_deg:g} deg; sign {sign}"
        + ("" if sign == DEFAULT_SIGN else " (NOT the Fanuc convention: doubles the error)"),
        f"The increments of points {reference_number + 1}..{last} sum to zero (one revolution);"
        f" point {reference_number} repeats point {last}.",
        "Relative to the reference angle: the constant part of the error is the axis' zero "
        "offset (reference position shift), not in this table.",
        *(["One table for both directions: the mean of the measured approach directions "
           "(the bidirectional function 3605#0 is not written for rotary axes)."]
          if p.bidirectional else []),
        "Load: parameters first, then the pitch data; power off/on, reference return.",
    ]
    return files, notes


def read_fanuc_rotary(folder: str | Path, stem: str, unit_deg: float = 0.001
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points [deg] and cumulative compensation [deg] of a rotary table as written.

    Read from the parameter and pitch files; the compensation is zero at the reference.

    Parameters
    ----------
    folder : str or Path
        The compensation folder.
    stem : str
        Axis name in the file names (``C``).
    unit_deg : float
        Detection unit [deg].

    Returns
    -------
    points, compensation : ndarray
        Angles of the points from the reference [deg] and the compensation there [deg].
    """
    folder = Path(folder)
    pfile, dfile = folder / ROT_PARAM_FILE.format(stem), folder / ROT_PITCH_FILE.format(stem)
    ptxt = pfile.read_text(encoding="ascii")
    par: dict[int, float] = {}
    for mt in re.finditer(r"^N0?(\d{4})(?:Q1)?A\d+P([-+0-9.]+)$", ptxt, re.M):
        par[int(mt.group(1))] = float(mt.group(2))
    try:
        ref, last, mag, d = int(par[3620]), int(par[3622]), par[3623], par[3624]
    except KeyError as exc:
        raise VolcalInputError(f"parameter {exc.args[0]} missing", pfile) from None
    if "Q1" not in ptxt:  # 16i: 3624 in detection units
        d *= unit_deg
    data: dict[int, int] = {}
    for mt in re.finditer(r"^N1(\d{4})(?:Q0)?P([-+0-9]+)$",
                          dfile.read_text(encoding="ascii"), re.M):
        data[int(mt.group(1))] = int(mt.group(2))
    inc = np.array([data.get(ref + k, 0) for k in range(1, last - ref + 1)], dtype=float)
    cum = np.r_[0.0, np.cumsum(inc)] * unit_deg * mag
    if not math.isclose(cum[-1], 0.0, abs_tol=1e-12):
        raise VolcalInputError("the increments of one revolution do not sum to zero",
                               dfile)
    return d * np.arange(cum.size), cum


def fanuc_point_clash(files: dict[str, str]) -> str | None:
    """The first compensation point number used by two Fanuc pitch files, with their names.

    All axes share one numbered table: a rotary table must not reuse the points of the
    linear ones (``N1nnnn`` data lines).

    Parameters
    ----------
    files : dict of str to str
        The files of a compensation folder.

    Returns
    -------
    str or None
        ``"point 905 in FANUC_PITCH.TXT and FANUC_ROTARY_PITCH_C.TXT"``, or None.
    """
    seen: dict[int, str] = {}
    for name in sorted(files):
        if not (name.startswith("FANUC_") and "PITCH" in name):
            continue
        for mt in re.finditer(r"^N1(\d{4})(?:Q0)?P", files[name], re.M):
            n = int(mt.group(1))
            if n in seen and seen[n] != name:
                return f"point {n} in {seen[n]} and {name}"
            seen.setdefault(n, name)
    return None
