"""Fanuc pitch error compensation: parameters 3620-3624 and data by point number.

Fanuc Series 0i/16i/18i/30i store the pitch error compensation of all axes in one
numbered table (data numbers 0..1023 on a 0i). Per axis (parameter manual B-63980EN,
parameters 3620-3624):

======  ==================================================================
3620    compensation point number of the reference position
3621    number of the most distant point on the negative side
3622    number of the most distant point on the positive side
3623    magnification (the stored values are multiplied by it)
3624    interval between compensation points [mm, real with decimal point]
======  ==================================================================

The value stored at point ``N`` is **incremental**: the change of the compensation
over the section that ends at point ``N`` (section ``N`` is
``(ref + (N - n_ref - 1) d, ref + (N - n_ref) d]``), in detection units times the
magnification; the compensation at the reference position is zero. Hence
``n_neg = n_ref - (negative stroke / d) + 1`` and ``n_pos = n_ref + positive stroke / d``.
The per-point increment is limited (-7..+7 on the 0i/16i family; larger on newer
series, see ``max_increment``).

volcal never writes parameter 1240 (machine coordinate of the reference position) nor
any other parameter that defines machine coordinates: loading it would move machine
zero. The reference position the table assumes is stated in ``FANUC_README.TXT``.

Files written, in the I/O syntax of current controls (30i/0i-D/0i-F parameter
backups): ``FANUC_PARAM.TXT`` (``N03620Q1A1P..A2P..A3P..``: five-digit number, ``Q1`` =
parameter data, 3624 as a length with a decimal point, ``N03624Q1A1P20.0``) and
``FANUC_PITCH.TXT`` (``N1xxxxQ0P..``: data number 10000 + point number, ``Q0`` =
pitch data), both between ``%`` lines, plus ``FANUC_README.TXT`` (sign, reference
position, activation). The values are rounded from the absolute table, so the
rounding does not accumulate along the axis.

References
----------
FANUC Series 30i/300i/300is-MODEL A parameter manual B-63950EN/02 (parameter
I/O format with ``N``/``Q``/``A``/``P``; parameters 3620-3627). FANUC Series 0i-PB
parameter manual B-63980EN/01, parameters 3620-3627 (with the
worked example of the incremental values). FANUC Series 16i/18i-MA technical report
A-77810E (bidirectional pitch error compensation, parameters 3620-3627).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from volcal.compensate.tables import AxisTable, axis_grid, sign_factor
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

PARAM_FILE = "FANUC_PARAM.TXT"
PITCH_FILE = "FANUC_PITCH.TXT"
NOTES_FILE = "FANUC_README.TXT"
FORBIDDEN_PARAMETERS: tuple[int, ...] = (1240, 1241, 1242, 1243, 1250, 1260, 1850)
"""Parameters that (re)define machine coordinates or the reference position; never
written (1240-1243 reference positions, 1250 coordinate system at reference return,
1260 rotation amount, 1850 grid shift)."""


def fanuc_files(errors: MachineErrors, spacing: float, sign: str, reference_mm,
                unit_um: float = 1.0, magnification: int = 1, max_increment: int = 7,
                max_points: int = 1024) -> dict[str, str]:
    """Fanuc parameter and pitch data files of the positioning errors of X, Y, Z.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Interval of the compensation points [mm]; a whole number of detection units.
    sign : str
        ``'error'`` or ``'correction'`` (Fanuc adds the value to the command: use
        ``'correction'``; see ``docs/compensation.md``).
    reference_mm : array_like, shape (3,)
        Reference position of X, Y, Z in the model's coordinates [mm].
    unit_um : float
        Detection unit [um] (1 for IS-B, 0.1 for IS-C).
    magnification : int
        Parameter 3623, 1..100.
    max_increment : int
        Largest stored value per point (7 on 0i/16i/18i).
    max_points : int
        Size of the controller's table shared by all axes (1024 on a 0i).

    Returns
    -------
    dict of str to str
        File name -> content.

    Raises
    ------
    VolcalInputError
        A limit of the controller exceeded, naming the axis and the point.
    """
    s = sign_factor(sign)
    if not 1 <= magnification <= 100:
        raise VolcalInputError(f"--magnification {magnification}: Fanuc allows 1..100")
    interval = spacing * 1000.0 / unit_um
    if abs(interval - round(interval)) > 1e-6 or round(interval) < 1:
        raise VolcalInputError(f"--spacing {spacing:g} mm is not a whole number of detection "
                               f"units ({unit_um:g} um)")
    res = unit_um * magnification
    ref = np.asarray(reference_mm, dtype=float).reshape(3)
    params: dict[int, list] = {n: [] for n in (3620, 3621, 3622, 3623, 3624)}
    data: list[tuple[int, int]] = []
    first = 0
    for k in range(3):
        lo, hi = errors.travel[k]
        if not lo - 1e-9 <= ref[k] <= hi + 1e-9:
            raise VolcalInputError(f"reference position {AXES[k]}={ref[k]:g} mm lies outside "
                                   f"the travel {lo:g}..{hi:g} mm")
        p = axis_grid(lo, hi, spacing, anchor=ref[k], what=f"Fanuc {AXES[k]}")
        j = np.rint((p - ref[k]) / spacing).astype(int)
        if j[0] > -1:  # the reference section itself is always stored
            j = np.concatenate([[-1], j])
            p = ref[k] + spacing * j
        e = s * errors.component(k, p)[:, k]
        e0 = s * errors.component(k, [ref[k]])[0, k]
        c = np.rint((e - e0) / res).astype(int)
        inc = np.diff(c)  # section j[1..] ends at point j
        n_ref = first - (int(j[0]) + 1)
        numbers = n_ref + j[1:]
        if numbers[-1] >= max_points:
            raise VolcalInputError(
                f"Fanuc {AXES[k]}: point numbers up to {numbers[-1]} exceed the table of "
                f"{max_points} points shared by the axes; use a larger --spacing")
        big = np.flatnonzero(np.abs(inc) > max_increment)
        if big.size:
            i = int(big[0])
            raise VolcalInputError(
                f"Fanuc {AXES[k]}: point {int(numbers[i])} at {p[i + 1]:g} mm needs an "
                f"increment of {int(inc[i])} x {res:g} um, beyond +-{max_increment}; use a "
                "larger --magnification or a smaller --spacing")
        params[3620].append(int(n_ref))
        params[3621].append(int(numbers[0]))
        params[3622].append(int(numbers[-1]))
        params[3623].append(int(magnification))
        params[3624].append(_mm(spacing))
        data += list(zip(numbers.tolist(), inc.tolist(), strict=True))
        first = int(numbers[-1]) + 1
    plines = ["%"] + [f"N{n:05d}Q1" + "".join(f"A{a + 1}P{v}" for a, v in enumerate(vals))
                      for n, vals in params.items()] + ["%"]
    dlines = ["%"] + [f"N{10000 + n}Q0P{v}" for n, v in data] + ["%"]
    notes = [
        "volcal: FANUC pitch error compensation of EXX, EYY, EZZ (axes 1, 2, 3 = X, Y, Z).",
        f"Sign: {sign}" + (" (FANUC's convention: the values are added to the command)."
                           if sign == "correction" else
                           " (OVERRIDE: FANUC adds the values to the command)."),
        f"Unit of the data: {unit_um:g} um detection unit x magnification {magnification}.",
        "The compensation is zero at the reference position, which the table assumes at "
        + ", ".join(f"{AXES[k]} = {ref[k]:g} mm" for k in range(3)) + " (model coordinates).",
        "Parameter 1240 (machine coordinate of the reference position) is NOT written:",
        "check that the control's reference position is the one above.",
        "Load FANUC_PARAM.TXT and FANUC_PITCH.TXT through the parameter and pitch data",
        "input screens (PWE = 1, emergency stop), then power the control off and on.",
        "Straightness, angular and squareness errors stay uncorrected."]
    return {PARAM_FILE: "\n".join(plines) + "\n", PITCH_FILE: "\n".join(dlines) + "\n",
            NOTES_FILE: "\n".join(notes) + "\n"}


def _mm(v: float) -> str:
    """A length [mm] with a decimal point and no trailing zeros beyond one (``20.0``)."""
    t = f"{v:.4f}".rstrip("0")
    return t + "0" if t.endswith(".") else t


_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)"
_PARAM = re.compile(rf"^N0*(\d+)(?:Q[01])?((?:A\d+P{_NUM})+|P{_NUM})$")
_DATA = re.compile(r"^N(1\d{4})(?:Q0)?P([-+]?\d+)$")


def read_fanuc(folder: str | Path, sign: str, unit_um: float = 1.0,
               reference_mm=(0.0, 0.0, 0.0)) -> list[AxisTable]:
    """Read Fanuc parameter and pitch files back into absolute tables.

    Accepts the current I/O syntax (``N03620Q1A1P40``, ``N03624Q1A1P20.0``,
    ``N10000Q0P1``) and the older one (``N3620A1P40``, ``N10000P1``, 3624 in detection
    units); other parameters in a full backup (``N01240Q1A1P0.0A2P0.0``, bit and
    non-axis parameters) are read and ignored.

    Parameters
    ----------
    folder : str or Path
        Folder with ``FANUC_PARAM.TXT`` and ``FANUC_PITCH.TXT``.
    sign : str
        Sign convention the values were written in.
    unit_um : float
        Detection unit [um].
    reference_mm : array_like, shape (3,)
        Position of the reference point of X, Y, Z [mm] (not in the files).

    Returns
    -------
    list of AxisTable
        X, Y, Z; positions [mm] and absolute compensation [um], zero at the reference.
    """
    folder = Path(folder)
    params: dict[int, dict[int, int]] = {}
    for i, line in enumerate(_lines(folder / PARAM_FILE), start=1):
        if line == "%":
            continue
        m = _PARAM.match(line)
        if not m:
            raise VolcalInputError(f"not a Fanuc parameter line: {line!r}", folder / PARAM_FILE, i)
        params[int(m.group(1))] = {int(a): v for a, v in
                                   re.findall(rf"A(\d+)P({_NUM})", m.group(2))}
    data: dict[int, int] = {}
    for i, line in enumerate(_lines(folder / PITCH_FILE), start=1):
        if line == "%":
            continue
        m = _DATA.match(line)
        if not m:
            raise VolcalInputError(f"not a pitch data line: {line!r}", folder / PITCH_FILE, i)
        data[int(m.group(1)) - 10000] = int(m.group(2))
    out = []
    for k in range(3):
        try:
            n_ref, n_neg, n_pos, mag, interval = (
                params[n][k + 1] for n in (3620, 3621, 3622, 3623, 3624))
            n_ref, n_neg, n_pos, mag = (int(v) for v in (n_ref, n_neg, n_pos, mag))
        except KeyError as exc:
            raise VolcalInputError(f"parameter missing for axis {k + 1}: {exc}",
                                   folder / PARAM_FILE) from None
        except ValueError as exc:
            raise VolcalInputError(f"axis {k + 1}: {exc}", folder / PARAM_FILE) from None
        # 3624 with a decimal point is a length [mm]; an integer is in detection units
        d = float(interval) if "." in interval else int(interval) * unit_um / 1000.0
        j = np.arange(n_neg - n_ref - 1, n_pos - n_ref + 1)
        inc = np.array([data.get(int(n), 0) for n in range(n_neg, n_pos + 1)])
        c = np.concatenate([[0], np.cumsum(inc)])
        c = c - c[int(np.flatnonzero(j == 0)[0])]
        res = unit_um * mag
        out.append(AxisTable(k, k, float(reference_mm[k]) + d * j, c * res, sign, res))
    return out


def _lines(path: Path) -> list[str]:
    try:
        return [ln.strip() for ln in path.read_text(encoding="ascii").splitlines() if ln.strip()]
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
