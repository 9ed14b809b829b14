"""Rotary axes in a session: the ``[machine]`` list, the ``rotary`` entries, their CSV files.

A rotary test reads the angular positioning of one rotary axis (``A``, ``B`` or ``C``) with
an angular interferometer on a rotary calibrator (Renishaw XR20) or against a precision
index table (Keysight 5530 360-tooth table). Its CSV holds ``target_deg, run, direction,
deviation_urad`` (``deviation_arcsec`` accepted on reading), ``missed`` marking a missed
capture as in every kind; ``docs/formats.md`` ("Rotary tests") documents the keys and
``docs/conventions.md`` ("Rotary axes") the sign: deviation = actual - commanded angle,
positive counter-clockwise looking from the positive end of the axis towards the origin
(ISO 841).

The rotary kind (:mod:`volcal.kinds.rotary`) does not enter the identification of the
linear axes: its readings are evaluated per axis (ISO 230-2, ECC of a C axis, EAA of an A
axis); the location errors of rotary axes (EX0C ...) come with the 5-axis issue.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.io.table import Column, TableSpec, read_table
from volcal.session.missed import FIRST_ROW_MISSED, MISSED

__all__ = [
    "ARCSEC_URAD",
    "MOUNTINGS",
    "ROTARY_AXES",
    "ROTARY_COLUMNS",
    "RotaryAxis",
    "RotaryReadings",
    "arcsec_to_urad",
    "check_rotary_keys",
    "read_rotary_axes",
    "read_rotary_csv",
    "rotary_csv",
    "rotary_readings",
    "urad_to_arcsec",
]

ARCSEC_URAD = math.pi / 648000.0 * 1e6
"""One arcsecond in microradians: pi / 648000 rad = 4.8481368 urad."""
ROTARY_AXES: tuple[str, ...] = ("a", "b", "c")
"""Names of rotary axes (about X, Y, Z; ISO 841)."""
MOUNTINGS: tuple[str, ...] = ("on_axis", "off_axis")
"""Values of a rotary test's ``mounting``."""
ROTARY_COLUMNS: tuple[str, ...] = ("target_deg", "run", "direction", "deviation_urad")
"""Columns of a rotary CSV as volcal writes it (``deviation_arcsec`` read as well)."""
DEVIATION_ABS_MAX_URAD = 1.0e5
"""Largest plausible |deviation| [urad] (0.1 rad, 5.7 deg): larger values are errors."""


def arcsec_to_urad(v: Any) -> Any:
    """Arcseconds to microradians (1 arcsec = pi/648000 rad = 4.8481368 urad).

    Parameters
    ----------
    v : float or ndarray
        Angle [arcsec].

    Returns
    -------
    float or ndarray
        Angle [urad].
    """
    return (v if isinstance(v, float | int) else np.asarray(v, dtype=float)) * ARCSEC_URAD


def urad_to_arcsec(v: Any) -> Any:
    """Microradians to arcseconds (1 urad = 0.206265 arcsec).

    Parameters
    ----------
    v : float or ndarray
        Angle [urad].

    Returns
    -------
    float or ndarray
        Angle [arcsec].
    """
    return (v if isinstance(v, float | int) else np.asarray(v, dtype=float)) / ARCSEC_URAD


@dataclass(frozen=True)
class RotaryAxis:
    """One rotary axis of the machine (``[[machine.rotary_axes]]``).

    Attributes
    ----------
    name : str
        ``'a'``, ``'b'`` or ``'c'``.
    range_deg : tuple of float
        Its range [deg]: ``(0, 360)`` for a full-circle axis.
    modulo : bool
        Turns full circles (modulo 360): 0 and 360 deg are one physical position.
    """

    name: str
    range_deg: tuple[float, float] = (0.0, 360.0)
    modulo: bool = True

    def to_toml(self) -> dict[str, Any]:
        """The axis' entry of ``[[machine.rotary_axes]]``."""
        return {"name": self.name, "range_deg": [float(v) for v in self.range_deg],
                "modulo": bool(self.modulo)}


def _range(v: Any, file: Any, key: str, modulo: bool | None = None) -> tuple[float, float]:
    if (not isinstance(v, list) or len(v) != 2
            or any(isinstance(x, bool) or not isinstance(x, int | float) for x in v)
            or not all(math.isfinite(x) and abs(x) <= 3600.0 for x in v)):
        raise VolcalInputError("expected [min, max] in degrees (within +-3600)", file, None, key)
    if v[1] <= v[0]:
        raise VolcalInputError("the range's max must exceed its min", file, None, key)
    if modulo and v[1] - v[0] > 360.0 + 1e-9:
        raise VolcalInputError(f"a full-circle (modulo 360) axis spans at most 360 deg, got "
                               f"{v[1] - v[0]:g}", file, None, key)
    return float(v[0]), float(v[1])


def _axis_name(v: Any, file: Any, key: str) -> str:
    if not isinstance(v, str) or v.lower() not in ROTARY_AXES:
        raise VolcalInputError(f"axis must be \"a\", \"b\" or \"c\", got {v!r}", file, None, key)
    return v.lower()


def _bool(v: Any, file: Any, key: str) -> bool:
    if not isinstance(v, bool):
        raise VolcalInputError(f"expected true or false, got {v!r}", file, None, key)
    return v


def read_rotary_axes(machine: dict[str, Any], file: Any = None) -> list[RotaryAxis]:
    """The rotary axes ``[[machine.rotary_axes]]`` lists (name, range_deg, modulo).

    Parameters
    ----------
    machine : dict
        The ``[machine]`` table (or a session's ``meta``).
    file : str or Path, optional
        ``session.toml``, for errors.

    Returns
    -------
    list of RotaryAxis
        Empty when the machine lists none.

    Raises
    ------
    VolcalInputError
        Naming the key (``machine.rotary_axes[0].range_deg``) of what is wrong.
    """
    raw = machine.get("rotary_axes")
    if raw is None:
        return []
    if not isinstance(raw, list):
        raise VolcalInputError("rotary_axes must be a list of tables [[machine.rotary_axes]] "
                               "with name, range_deg, modulo", file, None, "machine.rotary_axes")
    out: list[RotaryAxis] = []
    for i, e in enumerate(raw):
        where = f"machine.rotary_axes[{i}]"
        if not isinstance(e, dict):
            raise VolcalInputError("expected a table with name, range_deg, modulo", file, None,
                                   where)
        unknown = sorted(set(e) - {"name", "range_deg", "modulo"})
        if unknown:
            raise VolcalInputError(f"unknown key {unknown[0]!r}: expected name, range_deg, "
                                   "modulo", file, None, f"{where}.{unknown[0]}")
        name = _axis_name(e.get("name"), file, f"{where}.name")
        if any(a.name == name for a in out):
            raise VolcalInputError(f"rotary axis {name!r} listed twice", file, None,
                                   f"{where}.name")
        modulo = _bool(e.get("modulo", True), file, f"{where}.modulo")
        rng = _range(e.get("range_deg", [0.0, 360.0]), file, f"{where}.range_deg", modulo)
        out.append(RotaryAxis(name, rng, modulo))
    return out


ECCENTRICITY_MAX_MM = 100.0
"""Largest accepted eccentricity of an off-axis mounting [mm]."""


def check_rotary_keys(entry: dict[str, Any], file: Any, where: str,
                      machine_axes: list[Any] | None = None) -> dict[str, Any]:
    """Check a rotary entry's own keys; the checked values (defaults filled in).

    Parameters
    ----------
    entry : dict
        The ``[[measurements]]`` entry.
    file : str or Path
        ``session.toml``, for errors.
    where : str
        The entry's key (``measurements[3]``).
    machine_axes : list of RotaryAxis, optional
        ``[[machine.rotary_axes]]``: the test's axis, range and modulo must agree.

    Returns
    -------
    dict
        ``axis``, ``range_deg`` (tuple), ``modulo``, ``mounting``, ``eccentricity_mm``.

    Raises
    ------
    VolcalInputError
        Naming the key.
    """
    if "axis" not in entry:
        raise VolcalInputError("missing axis = \"a\", \"b\" or \"c\": the rotary axis tested",
                               file, None, f"{where}.axis")
    axis = _axis_name(entry["axis"], file, f"{where}.axis")
    if entry["axis"] != axis:
        raise VolcalInputError(f"axis must be \"a\", \"b\" or \"c\" (lower case), got "
                               f"{entry['axis']!r}", file, None, f"{where}.axis")
    modulo = _bool(entry.get("modulo", True), file, f"{where}.modulo")
    rng = _range(entry.get("range_deg", [0.0, 360.0]), file, f"{where}.range_deg", modulo)
    mounting = entry.get("mounting", "on_axis")
    if not isinstance(mounting, str) or mounting not in MOUNTINGS:
        raise VolcalInputError(f"unknown mounting {mounting!r}: expected one of "
                               f"{', '.join(MOUNTINGS)}", file, None, f"{where}.mounting")
    ecc = entry.get("eccentricity_mm")
    if mounting == "off_axis" and ecc is None:
        raise VolcalInputError("an off-axis mounting needs eccentricity_mm: the distance of "
                               "the calibrator's centre from the axis [mm]", file, None,
                               f"{where}.eccentricity_mm")
    if ecc is not None:
        if mounting != "off_axis":
            raise VolcalInputError("eccentricity_mm belongs to mounting = \"off_axis\"", file,
                                   None, f"{where}.eccentricity_mm")
        if (isinstance(ecc, bool) or not isinstance(ecc, int | float) or not math.isfinite(ecc)
                or not 0.0 <= ecc <= ECCENTRICITY_MAX_MM):
            raise VolcalInputError(f"eccentricity_mm must be a number of mm between 0 and "
                                   f"{ECCENTRICITY_MAX_MM:g}, got {ecc!r}", file, None,
                                   f"{where}.eccentricity_mm")
    for a in machine_axes or []:
        if a.name != axis:
            continue
        if a.modulo != modulo:
            raise VolcalInputError(f"modulo = {str(modulo).lower()} but [machine] lists axis "
                                   f"{axis} with modulo = {str(a.modulo).lower()}", file, None,
                                   f"{where}.modulo")
        if rng[0] < a.range_deg[0] - 1e-9 or rng[1] > a.range_deg[1] + 1e-9:
            raise VolcalInputError(f"range_deg {list(rng)} leaves the range of axis {axis} in "
                                   f"[machine] {list(a.range_deg)}", file, None,
                                   f"{where}.range_deg")
    return {"axis": axis, "range_deg": rng, "modulo": modulo, "mounting": mounting,
            "eccentricity_mm": float(ecc or 0.0)}


# ------------------------------------------------------------------------------ CSV

ROTARY_TABLE = TableSpec(
    columns=(
        Column("target_deg", abs_max=3600.0),
        Column("run", kind="int", required=False, min=0),
        Column("direction", kind="choice", required=False, choices=("+", "-")),
        Column("deviation_urad", required=False, empty=True, abs_max=DEVIATION_ABS_MAX_URAD,
               markers=(MISSED,)),
        Column("deviation_arcsec", required=False, empty=True,
               abs_max=DEVIATION_ABS_MAX_URAD / ARCSEC_URAD, markers=(MISSED,)),
        Column("time_s", required=False),
        Column("status", kind="choice", required=False, empty=True, choices=("ok", MISSED)),
    ),
    min_rows=2,
    min_rows_message="need at least {min} readings, found {n}",
    what="rotary measurement file",
    delimiters=",;\t",
    decimal_comma=True,
)
"""Columns of a rotary CSV (``docs/formats.md``, "Rotary tests")."""


@dataclass
class RotaryRows:
    """A rotary CSV as read (missed captures NaN, flagged in ``missed``)."""

    target_deg: NDArray[np.float64]
    deviation_urad: NDArray[np.float64] | None
    columns: dict[str, NDArray[Any]]
    rows: NDArray[np.int64]
    missed: NDArray[np.bool_]


def read_rotary_csv(path: str | Path) -> RotaryRows:
    """Read a rotary CSV: ``target_deg``, ``deviation_urad`` or ``deviation_arcsec``, ...

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    RotaryRows
        ``target_deg`` [deg], ``deviation_urad`` [urad] (NaN at missed captures, None when
        the column is empty: a planned skeleton), ``columns`` (``target_deg``, ``run``,
        ``direction``, ``time_s``), CSV ``rows`` (header = 1), ``missed``.

    Raises
    ------
    VolcalInputError
        Naming file, row and column.
    """
    t = read_table(path, ROTARY_TABLE)
    has_u, has_a = t.has("deviation_urad"), t.has("deviation_arcsec")
    if has_u == has_a:
        what = "both" if has_u else "neither"
        raise t.error(f"expected one reading column, deviation_urad [urad] or "
                      f"deviation_arcsec [arcsec]; the header has {what}", None,
                      "deviation_urad")
    col = "deviation_urad" if has_u else "deviation_arcsec"
    dev = np.asarray(t[col], dtype=float)
    if not has_u:
        dev = dev * ARCSEC_URAD
    missed = t.marked[col].copy()
    if t.has("status"):
        missed |= t["status"] == MISSED
    cols: dict[str, NDArray[Any]] = {"target_deg": np.asarray(t["target_deg"], dtype=float)}
    for c in ("run", "direction", "time_s"):
        if t.has(c):
            cols[c] = t[c]
    target = cols["target_deg"]
    empty = np.isnan(dev) & ~missed
    if (empty | missed).all():
        return RotaryRows(target, None, cols, t.rows, missed)
    if empty.any():
        raise t.error(f"missing deviation: write the reading, or '{MISSED}' for a missed "
                      "capture (docs/formats.md)", int(np.argmax(empty)), col)
    if missed[0]:
        raise t.error(FIRST_ROW_MISSED, 0, col)
    return RotaryRows(target, np.where(missed, np.nan, dev), cols, t.rows, missed)


def _fmt(v: float) -> str:
    return f"{float(v):.6f}".rstrip("0").rstrip(".")


def rotary_csv(target_deg: NDArray[np.float64], deviation_urad: NDArray[np.float64] | None,
               columns: dict[str, NDArray[Any]]) -> str:
    """The CSV text of a rotary test (``target_deg, run, direction, deviation_urad``...).

    Parameters
    ----------
    target_deg : ndarray, shape (n,)
        Commanded angles [deg].
    deviation_urad : ndarray, shape (n,) or None
        Readings [urad] (NaN: missed capture); None: a planned skeleton.
    columns : dict
        ``run``, ``direction``, ``time_s`` where present.

    Returns
    -------
    str
    """
    extra = [c for c in ("time_s",) if c in columns]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    head = ["target_deg", *(c for c in ("run", "direction") if c in columns),
            "deviation_urad", *extra]
    w.writerow(head)
    for i in range(len(target_deg)):
        row = [_fmt(target_deg[i])]
        row += [str(columns[c][i]) for c in ("run", "direction") if c in columns]
        if deviation_urad is None:
            row.append("")
        else:
            v = deviation_urad[i]
            row.append(MISSED if np.isnan(v) else f"{v:.6f}")
        row += [_fmt(columns[c][i]) for c in extra]
        w.writerow(row)
    return buf.getvalue()


# ----------------------------------------------------------------- readings helper

@dataclass(frozen=True)
class RotaryReadings:
    """A rotary test's readings per target, direction and run.

    Attributes
    ----------
    targets_deg : ndarray, shape (m,)
        Distinct commanded angles, ascending [deg]; on a full-circle axis 360 (or any
        angle equal to the first modulo 360) stays its own target: ISO 230-2 counts it
        as a target approached like the others, though it is the same physical position.
    runs : ndarray of int, shape (r,)
        Run numbers, ascending.
    up, down : ndarray, shape (m, r)
        Deviations [urad] approached in the positive (``'+'``) and negative (``'-'``)
        direction; NaN where a run did not read the target (missed, or not visited).
    modulo : bool
        The axis turns full circles.
    """

    targets_deg: NDArray[np.float64]
    runs: NDArray[np.int64]
    up: NDArray[np.float64]
    down: NDArray[np.float64]
    modulo: bool = True

    @property
    def closure_pairs(self) -> list[tuple[int, int]]:
        """Index pairs of targets that are the same physical position (0 and 360 deg)."""
        if not self.modulo:
            return []
        t = self.targets_deg
        return [(i, j) for i in range(t.size) for j in range(i + 1, t.size)
                if abs(((t[j] - t[i]) + 180.0) % 360.0 - 180.0) < 1e-6]


def rotary_readings(m: Any) -> RotaryReadings:
    """Readings of a rotary measurement in per-target/direction/run arrays.

    Parameters
    ----------
    m : Measurement
        A ``rotary`` measurement with readings and ``run``/``direction`` columns (a file
        without them is one run in the ``'+'`` direction).

    Returns
    -------
    RotaryReadings

    Raises
    ------
    VolcalInputError
        No readings, or one target read twice in one run and direction.
    """
    if m.deviation is None:
        raise VolcalInputError(f"{m.id}: no readings yet", m.file)
    t = np.round(np.asarray(m.columns["target_deg"], dtype=float), 6)
    run = m.columns.get("run")
    run = np.zeros(t.size, dtype=np.int64) if run is None else np.asarray(run, dtype=np.int64)
    d = m.columns.get("direction")
    d = np.full(t.size, "+") if d is None else np.asarray(d)
    targets, ti = np.unique(t, return_inverse=True)
    runs, ri = np.unique(run, return_inverse=True)
    up = np.full((targets.size, runs.size), np.nan)
    down = np.full_like(up, np.nan)
    for k in range(t.size):
        if np.isnan(m.deviation[k]):
            continue
        arr = up if d[k] == "+" else down
        if not np.isnan(arr[ti[k], ri[k]]):
            row = None if m.rows is None else int(m.rows[k])
            raise VolcalInputError(f"target {targets[ti[k]]:g} deg read twice in run "
                                   f"{runs[ri[k]]} direction {d[k]}", m.file, row, "target_deg")
        arr[ti[k], ri[k]] = m.deviation[k]
    return RotaryReadings(targets, runs, up, down, bool(m.meta.get("modulo", True)))
