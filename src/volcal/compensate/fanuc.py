"""Fanuc pitch error compensation: parameters 3620-3627 and data by point number.

Fanuc Series 0i/16i/18i/30i store the pitch error compensation of all axes in one
numbered table. Per axis (FANUC Series 30i/31i/32i-MODEL A parameter manual
B-63950EN/02, 6.x "Parameters of pitch error compensation"; Series 0i-PB parameter
manual B-63980EN/01, parameters 3620-3627, with its worked example):

======  ==================================================================
3605#0  BDPx: bidirectional pitch error compensation (1 = on)
3620    compensation point number of the reference position
3621    number of the most distant point on the negative side
3622    number of the most distant point on the positive side
3623    magnification (the stored values are multiplied by it)
3624    interval between compensation points (30i class: a length [mm], real type;
        16i/18i/0i-C: detection units)
3626    most distant point on the negative side, negative-direction table
3627    compensation at the reference position when moving opposite to the
        reference return direction
======  ==================================================================

The value stored at point ``N`` is **incremental**: the change of the compensation
over the section that ends at point ``N`` (section ``N`` is
``(ref + (N - n_ref - 1) d, ref + (N - n_ref) d]``), in detection units times the
magnification, added to the command (volcal writes the **correction**, -error, by
default); the compensation at the reference position is zero. Hence
``n_neg = n_ref - (negative stroke / d) + 1`` and ``n_pos = n_ref + positive stroke / d``.

Parameter 1240 (machine coordinate of the reference position) is **never written**:
loading it would move machine zero. The table is anchored at the reference position
of the model (``reference_mm``), which must be the machine's reference position: the
notes file says where it is.

Syntax (``series``):

* ``'30i'`` (default; 30i/31i/32i, 0i-D, 0i-F): the current parameter I/O format,
  ``N03620Q1A1P40A2P140A3P240`` (5-digit number, ``Q1`` = parameter data), real
  parameters with a decimal point (``N03624Q1A1P20.0``), pitch data
  ``N10000Q0P0`` (data number 10000 + point number, ``Q0`` = pitch data);
* ``'16i'`` (16i/18i/21i, 0i-A/B/C): the older tape format ``N3620A1P40...``,
  3624 in detection units, data ``N10000P0``.

References
----------
FANUC Series 30i/31i/32i-MODEL A Parameter Manual B-63950EN/02 (parameter tape
format with ``Q1``; parameters 3605, 3620-3627). FANUC Series 0i-PB Parameter Manual
B-63980EN/01 (parameters 3620-3627 and the incremental example). FANUC Series
16i/18i-MA technical report A-77810E (bidirectional pitch error compensation).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from volcal.compensate.tables import AxisTable, axis_grid, require_finite, sign_factor
from volcal.errors import ParameterError, VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

PARAM_FILE = "FANUC_PARAM.TXT"
PITCH_FILE = "FANUC_PITCH.TXT"
NOTES_FILE = "FANUC_NOTES.TXT"
SERIES: tuple[str, str] = ("30i", "16i")
"""Parameter I/O syntaxes: current (``Q1``/``Q0``) and the older tape format."""
DEFAULT_SIGN = "correction"
SIGN_SOURCE = ("FANUC B-63980EN/01 and B-63950EN/02, parameters 3620-3624: the "
               "compensation pulses are added to the command (value = -error)")
COORDINATE_PARAMETERS: tuple[int, ...] = (1220, 1221, 1222, 1223, 1224, 1225, 1226, 1240,
                                          1241, 1242, 1243, 1260, 1320, 1321)
"""Parameters that define coordinates or limits: volcal never writes them."""


def _fmt_param(n: int, values: list, series: str) -> str:
    """One parameter line with a value per axis (``N03620Q1A1P..A2P..``)."""
    body = "".join(f"A{a + 1}P{v}" for a, v in enumerate(values))
    return f"N{n:05d}Q1{body}" if series == "30i" else f"N{n:04d}{body}"


def _fmt_data(n: int, v: int, series: str) -> str:
    """One pitch data line (``N10000Q0P..``)."""
    return f"N{10000 + n}Q0P{v}" if series == "30i" else f"N{10000 + n}P{v}"


def fanuc_files(errors: MachineErrors, spacing: float, sign: str, reference_mm,
                unit_um: float = 1.0, magnification: int = 1, max_increment: int = 7,
                max_points: int = 1024, series: str = "30i", directional=None
                ) -> dict[str, str]:
    """Fanuc parameter and pitch data files of the positioning errors of X, Y, Z.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Interval of the compensation points [mm]; a whole number of detection units.
    sign : str
        ``'error'`` or ``'correction'`` (Fanuc adds the value to the command: the
        default is ``'correction'``; see ``docs/compensation.md``).
    reference_mm : array_like, shape (3,)
        Reference position of X, Y, Z in the model's coordinates [mm]: the machine's
        reference position (the table is zero there). Not written as a parameter.
    unit_um : float
        Detection unit [um] (1 for IS-B, 0.1 for IS-C).
    magnification : int
        Parameter 3623, 1..100.
    max_increment : int
        Largest stored value per point (7 is accepted by every series; real 30i
        backups hold larger values: raise it for your control).
    max_points : int
        Size of the controller's table shared by all axes (1024 on a 0i).
    series : str
        ``'30i'`` (current I/O syntax, default) or ``'16i'`` (older tape format).
    directional : DirectionalErrors, optional
        Measured reversal: writes bidirectional pitch error compensation (3605#0 = 1,
        3626, 3627 and a second table for the negative direction).

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
    if series not in SERIES:
        raise ParameterError(f"{{fanuc_series=}}{series!r}: expected one of {', '.join(SERIES)}")
    if not 1 <= magnification <= 100:
        raise ParameterError(f"{{magnification=}}{magnification}: Fanuc allows 1..100")
    interval = spacing * 1000.0 / unit_um
    if abs(interval - round(interval)) > 1e-6 or round(interval) < 1:
        raise ParameterError(f"{{spacing=}}{spacing:g} mm is not a whole number of detection "
                             f"units ({unit_um:g} um)")
    res = unit_um * magnification
    ref = np.asarray(reference_mm, dtype=float).reshape(3)
    bidir = directional is not None and any(directional.has(k) for k in range(3))
    keys = (3620, 3621, 3622, 3623, 3624) + ((3626, 3627) if bidir else ())
    params: dict[int, list] = {n: [] for n in keys}
    data: list[tuple[int, int]] = []
    first = 0
    notes = []
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
        e_mod = errors.component(k, p)[:, k]
        e_ref = errors.component(k, [ref[k]])[0, k]
        half = directional.half_reversal(k, p) if bidir else np.zeros_like(p)
        half_ref = float(directional.half_reversal(k, [ref[k]])[0]) if bidir else 0.0
        # (table values, value at the reference) in the table's sign; the forward table
        # is zero at the reference, the reverse table keeps its offset (parameter 3627)
        fwd_ref = s * (e_ref + half_ref)
        tables = [s * (e_mod + half)]
        if bidir:
            tables.append(s * (e_mod - half))
        n_ref = first - (int(j[0]) + 1)
        numbers = n_ref + j[1:]
        for ti, e in enumerate(tables):
            require_finite(e, p, f"Fanuc {AXES[k]}" + (" (negative direction)" if ti else ""))
            c = np.rint((e - fwd_ref) / res).astype(int)
            inc = np.diff(c)
            nums = numbers + ti * (numbers[-1] + 1 - numbers[0])
            if nums[-1] >= max_points:
                raise VolcalInputError(
                    f"Fanuc {AXES[k]}: point numbers up to {nums[-1]} exceed the table of "
                    f"{max_points} points shared by the axes; use a larger --spacing")
            big = np.flatnonzero(np.abs(inc) > max_increment)
            if big.size:
                i = int(big[0])
                raise VolcalInputError(
                    f"Fanuc {AXES[k]}: point {int(nums[i])} at {p[i + 1]:g} mm needs an "
                    f"increment of {int(inc[i])} x {res:g} um, beyond +-{max_increment}; use "
                    "a larger --magnification, a smaller --spacing or, if your control "
                    "allows it, a larger --max-increment")
            data += list(zip(nums.tolist(), inc.tolist(), strict=True))
            if ti == 1:
                params[3626].append(int(nums[0]))
                e_rev_ref = s * (e_ref - half_ref)
                params[3627].append(int(np.rint((e_rev_ref - fwd_ref) / res)))
        params[3620].append(int(n_ref))
        params[3621].append(int(numbers[0]))
        params[3622].append(int(numbers[-1]))
        params[3623].append(int(magnification))
        params[3624].append(f"{spacing:.3f}" if series == "30i" else int(round(interval)))
        first = (int(data[-1][0]) + 1)
        notes.append(f"{AXES[k]}: reference position {ref[k]:g} mm (model coordinates) = "
                     f"point {n_ref}; points {numbers[0]}..{numbers[-1]}"
                     + (f", negative-direction table from point {params[3626][-1]}"
                        if bidir else ""))
    plines = ["%"]
    if bidir:
        plines.append(_fmt_param(3605, ["00000001"] * 3, series))
    plines += [_fmt_param(n, vals, series) for n, vals in params.items()] + ["%"]
    dlines = ["%"] + [_fmt_data(n, v, series) for n, v in data] + ["%"]
    from volcal.compensate.reference import reference_line_notes

    note = _notes(sign, series, res, notes + reference_line_notes(errors), bidir, directional)
    return {PARAM_FILE: "\n".join(plines) + "\n", PITCH_FILE: "\n".join(dlines) + "\n",
            NOTES_FILE: note}


_SIGN_TEXT = {
    "correction": "value = -error, added to the command",
    "error": "value = error; Fanuc adds the value to the command, so this DOUBLES the error "
             "unless your machine builder inverted the convention",
}


def _notes(sign: str, series: str, res: float, lines: list[str], bidir: bool,
           directional) -> str:
    out = [
        "volcal: Fanuc pitch error compensation",
        f"syntax: {series} parameter I/O format; load {PARAM_FILE} and {PITCH_FILE} on the "
        "parameter / pitch error compensation screens (EDIT mode, parameter write enabled, "
        "READ), then switch the control off and on.",
        f"sign: {sign} ({_SIGN_TEXT[sign]}). Source: {SIGN_SOURCE}.",
        f"resolution: {res:g} um per count (detection unit x magnification 3623).",
        "Parameter 1240 (reference position) and every other coordinate parameter are NOT "
        "written: the table is zero at the reference position below, which must be the "
        "machine's reference position.",
        *lines,
        "Before use: reference the axes, then check one point where the table is large: "
        "the deviation must shrink, not double.",
        "Not corrected: straightness, squareness, angular (Abbe) errors.",
    ]
    if bidir:
        out.insert(3, "bidirectional: 3605#0 = 1, negative-direction tables from 3626, "
                   f"reversal from {directional.source} (ISO 230-2).")
    if directional is not None:
        out[-2:-2] = directional.notes()
    return "\n".join(out) + "\n"


_PARAM = re.compile(r"^N0*(\d+)(?:Q(\d))?((?:[AL]\d+)?P.*)$")
_AXVAL = re.compile(r"[AL](\d+)P(-?\d+(?:\.\d*)?|-?\.\d+)")
_DATA = re.compile(r"^N(1\d{4,5})(?:Q0)?P(-?\d+)$")


def parse_fanuc_parameters(text: str, path: Path | str = "") -> dict[int, dict[int, float]]:
    """Parse a Fanuc parameter file (volcal's or a real backup such as ``CNC-PARA.TXT``).

    Accepts both syntaxes: ``N03620Q1A1P40A2P140`` / ``N01240Q1A1P0.0A2P0.0`` (30i class)
    and ``N3620A1P40`` (older), bit parameters ``N00000Q1P00001010`` and
    parameters without axis (``N03623Q1P1``). Pitch data lines (``N1xxxx``) are
    skipped here (see :func:`parse_fanuc_pitch`).

    Parameters
    ----------
    text : str
        File content.
    path : str or Path
        File name for messages.

    Returns
    -------
    dict
        Parameter number -> {axis number (0 for non-axis parameters): value}.
    """
    params: dict[int, dict[int, float]] = {}
    for i, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line == "%" or line.startswith("("):
            continue
        if _DATA.match(line) and not line.startswith("N0"):
            continue
        m = _PARAM.match(line)
        if not m:
            raise VolcalInputError(f"not a Fanuc parameter line: {line!r}", path, i)
        body = m.group(3)
        vals = {int(a): float(v) for a, v in _AXVAL.findall(body)}
        if not vals:
            v = body[1:] if body.startswith("P") else ""
            try:
                vals = {0: float(v)}
            except ValueError:
                raise VolcalInputError(f"not a Fanuc parameter line: {line!r}", path,
                                       i) from None
        params[int(m.group(1))] = vals
    return params


def parse_fanuc_pitch(text: str, path: Path | str = "") -> dict[int, int]:
    """Parse Fanuc pitch error compensation data (``N10000Q0P0`` or ``N10000P0``).

    Parameters
    ----------
    text : str
        File content.
    path : str or Path
        File name for messages.

    Returns
    -------
    dict
        Point number (data number - 10000) -> value [counts].
    """
    data: dict[int, int] = {}
    for i, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line == "%":
            continue
        m = _DATA.match(line)
        if not m:
            raise VolcalInputError(f"not a pitch data line: {line!r}", path, i)
        data[int(m.group(1)) - 10000] = int(m.group(2))
    return data


def read_fanuc(folder: str | Path, sign: str, unit_um: float = 1.0, reference_mm=None,
               direction: str = "+") -> list[AxisTable]:
    """Read Fanuc parameter and pitch files back into absolute tables.

    Parameters
    ----------
    folder : str or Path
        Folder with ``FANUC_PARAM.TXT`` and ``FANUC_PITCH.TXT``.
    sign : str
        Sign convention the values were written in.
    unit_um : float
        Detection unit [um].
    reference_mm : array_like, shape (3,), optional
        Reference position of each axis [mm] (default 0): the files do not hold it.
    direction : str
        ``'+'``: the table for the positive direction (the only one unless 3605#0);
        ``'-'``: the negative-direction table of bidirectional compensation.

    Returns
    -------
    list of AxisTable
        X, Y, Z; positions [mm] and absolute compensation [um], zero at the reference
        (forward table).
    """
    folder = Path(folder)
    params = parse_fanuc_parameters(_text(folder / PARAM_FILE), folder / PARAM_FILE)
    data = parse_fanuc_pitch(_text(folder / PITCH_FILE), folder / PITCH_FILE)
    ref = np.zeros(3) if reference_mm is None else np.asarray(reference_mm, dtype=float)
    out = []
    for k in range(3):
        try:
            n_ref, n_neg, n_pos, mag, interval = (
                params[n][k + 1] for n in (3620, 3621, 3622, 3623, 3624))
        except KeyError as exc:
            raise VolcalInputError(f"parameter missing for axis {k + 1}: {exc}",
                                   folder / PARAM_FILE) from None
        n_ref, n_neg, n_pos, mag = int(n_ref), int(n_neg), int(n_pos), int(mag)
        # 3624: a length with a decimal point (30i), detection units otherwise
        raw = _raw_value(folder / PARAM_FILE, 3624, k + 1)
        d = float(interval) if "." in raw else float(interval) * unit_um / 1000.0
        j = np.arange(n_neg - n_ref - 1, n_pos - n_ref + 1)
        start, offset = n_neg, 0
        if direction == "-":
            if 3626 not in params:
                raise VolcalInputError("no negative-direction table (parameter 3626)",
                                       folder / PARAM_FILE)
            start = int(params[3626][k + 1])
            offset = int(params.get(3627, {}).get(k + 1, 0))
        inc = np.array([data.get(int(n), 0) for n in range(start, start + n_pos - n_neg + 1)])
        c = np.concatenate([[0], np.cumsum(inc)])
        c = c - c[int(np.flatnonzero(j == 0)[0])] + offset
        res = unit_um * mag
        out.append(AxisTable(k, k, ref[k] + d * j, c * res, sign, res))
    return out


def _raw_value(path: Path, number: int, axis: int) -> str:
    for line in _text(path).splitlines():
        m = _PARAM.match(line.strip())
        if m and int(m.group(1)) == number:
            for a, v in _AXVAL.findall(m.group(3)):
                if int(a) == axis:
                    return v
    return ""


def _text(path: Path) -> str:
    try:
        return path.read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
