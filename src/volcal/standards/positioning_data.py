"""Read positioning-test readings for ISO 230-2 / VDI 3441 from a CSV file or a measurement.

Two CSV layouts are accepted:

* ``target_mm,run,direction,deviation_um`` (one reading per row, direction ``+``/``-``);
* a session measurement CSV of a linear test, ``x_mm,y_mm,z_mm,deviation_um,run,direction``
  (the target is the coordinate of the moving axis, the one with the largest range).

Every problem raises :class:`~volcal.errors.VolcalInputError` naming the file, row
(header = row 1) and column.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.io.values import parse_finite

__all__ = ["PositioningData", "from_measurement", "read_positioning_csv"]

COLUMNS: tuple[str, ...] = ("target_mm", "run", "direction", "deviation_um")
_UNITS = {"target": "mm", "deviation": "um"}


@dataclass
class PositioningData:
    """Readings of one bidirectional positioning test.

    Attributes
    ----------
    targets_mm : ndarray, shape (n,)
        Target position of each reading [mm].
    run : ndarray of int, shape (n,)
        Run number.
    direction : ndarray of str, shape (n,)
        ``'+'`` or ``'-'``.
    deviation_um : ndarray, shape (n,)
        Actual minus target position [um].
    rows : ndarray of int, shape (n,)
        Row of each reading in ``file`` (header = row 1).
    file : str
        Source file.
    axis : str or None
        Moving axis, when known.
    """

    targets_mm: NDArray[np.float64]
    run: NDArray[np.int64]
    direction: NDArray[np.str_]
    deviation_um: NDArray[np.float64]
    rows: NDArray[np.int64]
    file: str
    axis: str | None = None


def _read_rows(path: Path) -> list[list[str]]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise VolcalInputError("file not found", path) from None
    except (UnicodeDecodeError, IsADirectoryError, PermissionError) as exc:
        raise VolcalInputError(f"cannot read the file as UTF-8 text ({exc.__class__.__name__})",
                               path) from None
    try:
        return list(csv.reader(io.StringIO(text)))
    except csv.Error as exc:
        raise VolcalInputError(f"malformed CSV: {exc}", path) from None


def read_positioning_csv(path: str | Path) -> PositioningData:
    """Read a positioning test from either accepted CSV layout.

    Parameters
    ----------
    path : str or Path
        CSV file.

    Returns
    -------
    PositioningData

    Raises
    ------
    VolcalInputError
        Missing column, unknown unit, bad number, bad direction, naming file, row, column.
    """
    path = Path(path)
    rows = _read_rows(path)
    numbered = [(i + 1, r) for i, r in enumerate(rows) if any(c.strip() for c in r)]
    if not numbered:
        raise VolcalInputError("empty file: expected the header "
                               "target_mm,run,direction,deviation_um", path, 1)
    header = [h.strip() for h in numbered[0][1]]
    if any(h in ("x_mm", "y_mm", "z_mm") for h in header):
        return _read_measurement_layout(path, header)
    for h in header:
        stem, _, unit = h.rpartition("_")
        if stem in _UNITS and unit != _UNITS[stem]:
            raise VolcalInputError(f"unknown or unsupported unit {unit!r}: expected "
                                   f"'{stem}_{_UNITS[stem]}'", path, 1, h)
    for c in COLUMNS:
        if c not in header:
            raise VolcalInputError(f"missing required column '{c}' (header: {','.join(header)})",
                                   path, 1, c)
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise VolcalInputError("duplicate column", path, 1, dup)
    idx = {h: i for i, h in enumerate(header)}
    data = numbered[1:]
    t, run, dirn, dev, rown = [], [], [], [], []
    for rownum, r in data:
        if len(r) != len(header):
            raise VolcalInputError(f"expected {len(header)} fields, found {len(r)}", path,
                                   rownum)
        t.append(_float(r[idx["target_mm"]], path, rownum, "target_mm"))
        dev.append(_float(r[idx["deviation_um"]], path, rownum, "deviation_um"))
        txt = r[idx["run"]].strip()
        try:
            run.append(int(txt))
        except ValueError:
            raise VolcalInputError(f"expected a whole run number, got {txt!r}", path, rownum,
                                   "run") from None
        d = r[idx["direction"]].strip()
        if d not in ("+", "-"):
            raise VolcalInputError(f"direction must be '+' or '-', got {d!r}", path, rownum,
                                   "direction")
        dirn.append(d)
        rown.append(rownum)
    if not data:
        raise VolcalInputError("no readings below the header", path, 2)
    return PositioningData(np.array(t), np.array(run, dtype=int), np.array(dirn),
                           np.array(dev), np.array(rown, dtype=int), str(path))


_float = parse_finite


def _read_measurement_layout(path: Path, header: list[str]) -> PositioningData:
    from volcal.session.format import read_measurement_csv

    for c in ("run", "direction"):
        if c not in header:
            raise VolcalInputError(f"missing column '{c}': ISO 230-2 needs the run and the "
                                   "approach direction of every reading", path, 1, c)
    pos, dev, cols = read_measurement_csv(path)
    axis = int(np.argmax(np.ptp(pos, axis=0)))
    return PositioningData(pos[:, axis].copy(), cols["run"], cols["direction"], dev,
                           np.arange(2, pos.shape[0] + 2), str(path), "XYZ"[axis])


def from_measurement(meas: Any, folder: str | Path | None = None) -> PositioningData:
    """Positioning readings of a linear session measurement.

    Parameters
    ----------
    meas : Measurement
        A ``linear`` measurement with ``run`` and ``direction`` columns.
    folder : str or Path, optional
        Session folder, for error messages.

    Returns
    -------
    PositioningData
        Target = the measured axis' coordinate [mm].

    Raises
    ------
    VolcalInputError
        Not a linear test, no deviations, no run/direction columns.
    """
    file = str(Path(folder) / meas.file) if folder is not None else meas.file
    if meas.kind != "linear":
        raise VolcalInputError(f"measurement {meas.id!r} is a {meas.kind} test, not linear",
                               file)
    if meas.deviation is None:
        raise VolcalInputError("no deviations (planned, not measured)", file, None,
                               "deviation_um")
    for c in ("run", "direction"):
        if c not in meas.columns:
            raise VolcalInputError(f"missing column '{c}': ISO 230-2 needs the run and the "
                                   "approach direction of every reading", file, 1, c)
    axis = meas.axis
    return PositioningData(meas.positions[:, axis].copy(), np.asarray(meas.columns["run"]),
                           np.asarray(meas.columns["direction"]), np.asarray(meas.deviation),
                           np.arange(2, meas.n + 2) if getattr(meas, "rows", None) is None
                           else np.asarray(meas.rows), file, "XYZ"[axis])
