"""Hard checks of a measurement's commanded poses: inside the travel, on the planned geometry.

A pose outside the machine's travel, or not where the measurement's kind puts it, is
a corrupted file, not a reading: :func:`check_travel` and :func:`check_geometry` raise a
:class:`~volcal.errors.VolcalInputError` naming the file, row and column
(``docs/formats.md``, "Plausibility").
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["GEOMETRY_TOLERANCE_MM", "TRAVEL_MARGIN_FRACTION", "TRAVEL_MARGIN_MM",
           "check_geometry", "check_travel", "travel_margin"]

TRAVEL_MARGIN_MM = 2.0
"""Smallest margin beyond the travel accepted for a commanded pose (overrun) [mm]."""
TRAVEL_MARGIN_FRACTION = 0.02
"""Margin beyond the travel as a fraction of the axis' travel, when larger [-]."""
GEOMETRY_TOLERANCE_MM = 0.01
"""Largest departure of a pose from the measurement's planned geometry [mm]."""

_COLS = ("x_mm", "y_mm", "z_mm")


def travel_margin(travel: NDArray[np.float64]) -> NDArray[np.float64]:
    """Margin accepted beyond each axis' travel [mm].

    Parameters
    ----------
    travel : ndarray, shape (3, 2)
        Travel limits [mm].

    Returns
    -------
    ndarray, shape (3,)
        ``max(TRAVEL_MARGIN_MM, TRAVEL_MARGIN_FRACTION * (max - min))`` [mm].
    """
    return np.maximum(TRAVEL_MARGIN_MM, TRAVEL_MARGIN_FRACTION * np.ptp(travel, axis=1))


def check_travel(positions: NDArray[np.float64], rows: NDArray[np.int64],
                 travel: NDArray[np.float64], file: str | Path) -> None:
    """Refuse a commanded pose outside the travel (plus the margin of :func:`travel_margin`).

    Parameters
    ----------
    positions : ndarray, shape (n, 3)
        Commanded positions [mm].
    rows : ndarray of int, shape (n,)
        CSV row of each position (header = row 1).
    travel : ndarray, shape (3, 2)
        Travel limits [mm].
    file : str or Path
        CSV file, for the message.

    Raises
    ------
    VolcalInputError
        Naming the first row and column outside.
    """
    margin = travel_margin(travel)
    out = (positions < travel[:, 0] - margin) | (positions > travel[:, 1] + margin)
    if out.any():
        i, k = np.argwhere(out)[0]
        raise VolcalInputError(
            f"{'xyz'[k]} = {positions[i, k]:g} mm is outside the travel "
            f"{travel[k, 0]:g}..{travel[k, 1]:g} mm of session.toml (margin {margin[k]:g} mm)",
            file, int(rows[i]), _COLS[k])


def check_geometry(kind: str, positions: NDArray[np.float64], rows: NDArray[np.int64],
                   meta: dict[str, Any], file: str | Path,
                   beam: NDArray[np.float64] | None = None) -> None:
    """Refuse poses that do not follow the measurement's planned geometry.

    A linear test's poses lie on one line along its axis; a diagonal's on one line (its
    diagonal); a step diagonal's follow its stepping pattern: single-axis moves in the
    axis order (``axis_order``, else the order of the first moves), equal increments per
    axis. Tolerance :data:`GEOMETRY_TOLERANCE_MM`.

    Parameters
    ----------
    kind : str
        Measurement kind.
    positions : ndarray, shape (n, 3)
        Commanded positions [mm].
    rows : ndarray of int, shape (n,)
        CSV row of each position (header = row 1).
    meta : dict
        The measurement's metadata (``axis``, ``axis_order``).
    file : str or Path
        CSV file, for the message.
    beam : ndarray, shape (3,), optional
        Nominal direction of a linear test or diagonal (unit vector); default the
        direction from the first pose to the farthest.

    Raises
    ------
    VolcalInputError
        Naming the first row and column off the geometry.
    """
    if positions.shape[0] < 2:
        return
    if kind == "step_diagonal":
        _check_steps(positions, rows, meta, file)
        return
    d = positions - positions[0]
    if beam is None:
        far = int(np.argmax(np.linalg.norm(d, axis=1)))
        if np.linalg.norm(d[far]) < 1e-12:
            return
        beam = d[far] / np.linalg.norm(d[far])
    if kind == "linear":
        a = meta.get("axis")
        k = ("XYZ".index(a.upper()) if isinstance(a, str) and a.upper() in ("X", "Y", "Z")
             else int(np.argmax(np.abs(beam))))
        beam = np.eye(3)[k]
    perp = d - np.outer(d @ beam, beam)
    bad = np.abs(perp) > GEOMETRY_TOLERANCE_MM
    if bad.any():
        i = int(np.flatnonzero(bad.any(axis=1))[0])
        k = int(np.argmax(np.abs(perp[i])))
        what = ("on the line of this linear test" if kind == "linear"
                else "on the diagonal of this test")
        raise VolcalInputError(
            f"pose not {what} (from row {int(rows[0])} along "
            f"[{', '.join(f'{v:.4g}' for v in beam)}]): {'xyz'[k]} = {positions[i, k]:g} mm, "
            f"expected {positions[i, k] - perp[i, k]:g} mm", file, int(rows[i]), _COLS[k])


def check_repeats(positions: NDArray[np.float64], rows: NDArray[np.int64],
                  columns: dict[str, NDArray[Any]], missed: NDArray[np.bool_],
                  file: str | Path) -> None:
    """Refuse a pose read twice in one run and direction (a duplicated line).

    Only for files with ``run`` and ``direction`` columns (ISO 230-2 runs); missed
    captures are not readings and are skipped. Poses equal to 1 nm are one pose (as the
    importer's check, which sees the same positions).

    Parameters
    ----------
    positions : ndarray, shape (n, 3)
        Commanded positions [mm].
    rows : ndarray of int, shape (n,)
        CSV row of each position (header = row 1).
    columns : dict
        The file's other columns by name (``run``, ``direction``).
    missed : ndarray of bool, shape (n,)
        Missed captures.
    file : str or Path
        CSV file, for the message.

    Raises
    ------
    VolcalInputError
        Naming the second row of the pose and its moving column.
    """
    if "run" not in columns or "direction" not in columns or positions.shape[0] < 2:
        return
    k = int(np.argmax(np.ptp(positions, axis=0)))
    seen: dict[tuple[Any, Any, float], int] = {}
    for i in range(positions.shape[0]):
        if missed[i]:
            continue
        key = (columns["run"][i], columns["direction"][i],
               round(float(positions[i, k]), 6))
        if key in seen:
            raise VolcalInputError(
                f"pose {'xyz'[k]} = {positions[i, k]:g} mm read twice in run {key[0]} "
                f"direction {key[1]} (also on row {seen[key]}): a duplicated line?", file,
                int(rows[i]), _COLS[k])
        seen[key] = int(rows[i])


def _check_steps(pos: NDArray[np.float64], rows: NDArray[np.int64], meta: dict[str, Any],
                 file: str | Path) -> None:
    moves = np.diff(pos, axis=0)
    order_txt = meta.get("axis_order")
    if isinstance(order_txt, str) and order_txt and set(order_txt.lower()) <= set("xyz") \
            and len(set(order_txt.lower())) == len(order_txt):
        order = ["xyz".index(c) for c in order_txt.lower()]
    else:  # infer: the axis moved by each of the first moves, until one repeats
        order = []
        for mv in moves:
            k = int(np.argmax(np.abs(mv)))
            if k in order:
                break
            order.append(k)
    m = len(order)
    n = pos.shape[0]
    if m == 0 or (n - 1) % m:
        raise VolcalInputError(
            f"a step diagonal with axis order {''.join('xyz'[k] for k in order)} has 1 + "
            f"{m}N rows (one reading after each single-axis move); found {n}", file,
            int(rows[-1]), None)
    axis = np.array([order[i % m] for i in range(n - 1)])
    inc = np.array([np.median(moves[axis == k, k]) if np.any(axis == k) else 0.0
                    for k in range(3)])
    expected = pos[0] + np.cumsum(np.vstack([np.zeros(3), np.eye(3)[axis] * inc[axis, None]]),
                                  axis=0)
    bad = np.abs(pos - expected) > GEOMETRY_TOLERANCE_MM
    if bad.any():
        i = int(np.flatnonzero(bad.any(axis=1))[0])
        k = int(np.argmax(np.abs(pos[i] - expected[i])))
        raise VolcalInputError(
            f"step-diagonal pose does not follow its stepping pattern (single-axis moves in "
            f"the order {''.join('xyz'[j] for j in order)}, equal increments): "
            f"{'xyz'[k]} = {pos[i, k]:g} mm, expected {expected[i, k]:g} mm", file,
            int(rows[i]), _COLS[k])
