"""Read positioning-test readings for ISO 230-2 / VDI 3441 from a CSV file or a measurement.

Two CSV layouts are accepted:

* ``target_mm,run,direction,deviation_um`` (one reading per row, direction ``+``/``-``);
* a session measurement CSV of a linear test, ``x_mm,y_mm,z_mm,deviation_um,run,direction``
  (the target is the coordinate of the moving axis, the one with the largest range).

Every problem raises :class:`~volcal.errors.VolcalInputError` naming the file, row
(header = row 1) and column. A ``deviation_um`` cell reading ``missed`` (a missed
capture, in either layout) is skipped with a note; the evaluation then reports the run
that missed the target (``allow_incomplete=True`` of the evaluations).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.io.table import Column, TableSpec, parse_table, read_text

__all__ = ["PositioningData", "from_measurement", "read_positioning_csv"]

COLUMNS: tuple[str, ...] = ("target_mm", "run", "direction", "deviation_um")


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
    target_column : str
        Column of ``file`` holding the targets (``target_mm``, or ``x_mm``... in a
        session measurement CSV), named in error messages.
    notes : list of str
        What the reader skipped (missed captures, with their rows).
    thermal : dict, optional
        How the readings were compensated and referred to 20 degC, and the environment
        the session records (:func:`volcal.environment.apply.thermal_record`); None for
        a positioning CSV read alone.
    """

    targets_mm: NDArray[np.float64]
    run: NDArray[np.int64]
    direction: NDArray[np.str_]
    deviation_um: NDArray[np.float64]
    rows: NDArray[np.int64]
    file: str
    axis: str | None = None
    target_column: str = "target_mm"
    notes: list[str] = field(default_factory=list)
    thermal: dict[str, Any] | None = None

    def evaluate_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of the evaluations for these readings.

        File, rows, target column, and incomplete runs allowed.
        """
        return {"file": self.file, "rows": self.rows, "allow_incomplete": True,
                "target_column": self.target_column}


POSITIONING_TABLE = TableSpec(
    columns=(Column("target_mm", abs_max=1e6), Column("run", kind="int", min=0),
             Column("direction", kind="choice", choices=("+", "-")),
             Column("deviation_um", abs_max=10_000.0, markers=("missed",))),
    min_rows=1, min_rows_message="no readings below the header", what="positioning file",
    delimiters=",;\t", decimal_comma=True)  # as the session's CSVs: a spreadsheet's save
"""Columns of the ``target_mm,run,direction,deviation_um`` layout."""


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
    text = read_text(path, "positioning file")
    first = next((ln for ln in text.splitlines() if ln.strip()), "")
    header = [h.strip().lstrip("\ufeff") for h in re.split(r"[,;\t]", first)]
    if any(h in ("x_mm", "y_mm", "z_mm") for h in header):
        return _read_measurement_layout(path, header)
    t = parse_table(text, POSITIONING_TABLE, path)
    keep = ~t.marked["deviation_um"]
    notes = []
    if not keep.all():
        from volcal.session.format import _missed_note

        notes.append(_missed_note(path, t.rows, ~keep))
    return PositioningData(t["target_mm"][keep], t["run"][keep], t["direction"][keep],
                           t["deviation_um"][keep], t.rows[keep], str(path), notes=notes)


def _kind_in_session(path: Path) -> tuple[str, str] | None:
    """The id and kind ``session.toml`` beside ``path`` gives the file, if it names it."""
    from volcal.io.paths import session_entries

    for e in session_entries(path.parent) or []:
        if e["file"] == path.name:
            return str(e.get("id", path.stem)), str(e.get("kind", ""))
    return None


def _evaluated_by(kind: str, folder: Path) -> str:
    """What evaluates a measurement of ``kind`` (:attr:`volcal.kinds.Kind.evaluated_by`)."""
    from volcal.session.kinds import kind_of

    try:
        k = kind_of(kind)
    except VolcalInputError:
        return f"see docs/formats.md for the kinds (volcal evaluate session {folder})"
    if k.evaluated_by:
        return f"its readings give {k.evaluated_by}"
    if k.standard and k.standard != "ISO 230-2":
        return f"{k.standard}: volcal evaluate session {folder}"
    return (f"its readings enter the identification of the linear axes (volcal identify "
            f"{folder}), whose model volcal evaluate volumetric evaluates")


def _kind_by_columns(header: list[str]) -> tuple[str, str] | None:
    """The kind, and its value column, whose own value column ``header`` has.

    Only a value column one kind alone writes names the kind (an R-test's ``dx_um``, a
    rotary test's ``deviation_urad``); ``deviation_um`` and the positions are every linear
    kind's. None when no kind's or several kinds' columns are there.
    """
    from volcal.session.kinds import kinds

    shared = {"deviation_um", "x_mm", "y_mm", "z_mm"}
    found = [(k.name, k.value_column) for k in kinds()
             if k.value_column not in shared and k.value_column in header]
    return found[0] if len(found) == 1 else None


def _read_measurement_layout(path: Path, header: list[str]) -> PositioningData:
    named = _kind_in_session(path)
    if named is not None and named[1] not in ("", "linear"):
        raise VolcalInputError(f"{named[0]} is of kind {named[1]} (session.toml), not a "
                               "linear test with runs, which ISO 230-2 evaluates; "
                               + _evaluated_by(named[1], path.parent), path)
    by_columns = _kind_by_columns(header) if named is None else None
    if by_columns is not None:
        kind, column = by_columns
        raise VolcalInputError(f"column '{column}' is the readings' column of kind {kind} (no "
                               "session.toml beside the file names its kind), not of a linear "
                               "test with runs, which ISO 230-2 evaluates; "
                               + _evaluated_by(kind, path.parent), path, 1, column)
    for c in ("run", "direction"):
        if c not in header:
            hint = ("; a diagonal, step-diagonal or straightness test's file has none "
                    "(volcal evaluate session evaluates its session)" if named is None
                    else "")
            raise VolcalInputError(f"missing column '{c}': ISO 230-2 needs the run and the "
                                   f"approach direction of every reading{hint}", path, 1, c)
    from volcal.session.format import _drop_missed, _read_rows

    notes: list[str] = []
    r = _read_rows(path)
    if r.deviation is None:
        raise VolcalInputError("no readings yet: the deviation_um column is empty "
                               "(planned, not measured)", path, None, "deviation_um")
    r = _drop_missed(r, path, notes)
    assert r.deviation is not None  # checked above; dropping missed captures keeps it
    axis = int(np.argmax(np.ptp(r.positions, axis=0)))
    return PositioningData(r.positions[:, axis].copy(), r.columns["run"],
                           r.columns["direction"], r.deviation, r.rows, str(path), "XYZ"[axis],
                           f"{'xyz'[axis]}_mm", notes)


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
        Target = the measured axis' coordinate [mm]; ``thermal`` the measurement's
        record of compensation and referral.

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
    from volcal.environment.apply import thermal_record

    axis = meas.axis
    return PositioningData(meas.positions[:, axis].copy(), np.asarray(meas.columns["run"]),
                           np.asarray(meas.columns["direction"]), np.asarray(meas.deviation),
                           np.arange(2, meas.n + 2) if getattr(meas, "rows", None) is None
                           else np.asarray(meas.rows), file, "XYZ"[axis], f"{'xyz'[axis]}_mm",
                           thermal=thermal_record(meas))
