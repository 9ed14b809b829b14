"""ISO 230-6: diagonal displacement tests (body and face diagonals).

A diagonal displacement test is a linear positioning test whose line is a body or face
diagonal of the work zone, all axes moving together; the laser (retroreflector on the
tool) reads the displacement along the diagonal. ISO 230-6 evaluates it with the
parameters of ISO 230-2 along the diagonal. volcal therefore:

* with bidirectional runs (``run`` and ``direction`` columns, >= 2 runs each way) applies
  :func:`volcal.standards.iso230_2.evaluate` along the diagonal and reports its
  parameters (E_D = E, R_D = R, B_D = B ...);
* with one unidirectional run (the usual quick check, and what ``volcal plan`` writes)
  reports the diagonal displacement error ``E_D`` = range of the deviations along the
  diagonal and the largest absolute deviation from the start point.

The target coordinate along the diagonal is ``(p - p_0) . n`` [mm] with ``n`` the beam
direction.

A diagonal with missed captures (``missed`` cells, skipped by the session reader) is
evaluated over the points measured but marked incomplete (:attr:`DiagonalResult.complete`,
points measured of planned): its E_D covers part of the diagonal only, so it is left out
of the session's largest E_D (:func:`largest_e_d`).

Seed 002 (Wang) also gives the classic volumetric figure ELv, the root sum of squares of
the three axes' positioning ranges; see :func:`elv`.

References
----------
.. [1] ISO 230-6:2002, Test code for machine tools - Part 6: Determination of positioning
   accuracy on body and face diagonals (Diagonal displacement tests).
.. [2] ASME B5.54-2005, Methods for performance evaluation of computer numerically
   controlled machining centers (body diagonal displacement test).
.. [3] C. Wang, G. Liotto, "A laser non-contact measurement of static positioning and
   dynamic contouring accuracy of a CNC machine tool", Lamdamap 2003 (seed 000/002).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from volcal.errors import VolcalInputError
from volcal.standards.iso230_2 import Iso2302Result, evaluate

if TYPE_CHECKING:
    import pandas

__all__ = ["DiagonalResult", "elv", "evaluate_diagonal", "largest_e_d"]


@dataclass
class DiagonalResult:
    """ISO 230-6 result of one diagonal.

    Attributes
    ----------
    id : str
        Measurement id.
    diagonal : str
        Diagonal code (``'ppp'``... or face ``'pp'``/``'np'``).
    plane : str or None
        Plane of a face diagonal (``'xy'``, ``'yz'``, ``'xz'``); None for a body diagonal.
    length_mm : float
        Measured length along the diagonal [mm].
    E_D : float
        Diagonal displacement error: range of the (mean) deviations along the diagonal [um].
    max_abs_um : float
        Largest absolute (mean) deviation [um].
    iso230_2 : Iso2302Result or None
        Full ISO 230-2 evaluation along the diagonal when bidirectional runs exist.
    points_measured, points_planned : int
        Readings evaluated, and rows of the measurement file (readings + missed captures).
    missed : list of dict
        The missed captures: ``row`` of the file, ``position_mm`` and, if recorded,
        ``run`` and ``direction``.
    """

    id: str
    diagonal: str
    plane: str | None
    length_mm: float
    E_D: float
    max_abs_um: float
    iso230_2: Iso2302Result | None = None
    points_measured: int = 0
    points_planned: int = 0
    missed: list[dict[str, Any]] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when every planned point was measured."""
        return (not self.missed and self.points_measured >= self.points_planned
                and (self.iso230_2 is None or self.iso230_2.complete))

    def note(self) -> str:
        """Plain words on an incomplete diagonal (empty when complete)."""
        if self.complete:
            return ""
        rows = ", ".join(str(m["row"]) for m in self.missed)
        which = f" (missed: row{'s' if len(self.missed) > 1 else ''} {rows})" if rows else ""
        return (f"{self.id}: incomplete diagonal, {self.points_measured} of "
                f"{self.points_planned} points measured{which}; E_D covers the measured "
                "points only and is left out of the largest E_D")

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-friendly dict (``complete``, ``points_measured``/``planned``...)."""
        d: dict[str, Any] = {"id": self.id, "diagonal": self.diagonal, "plane": self.plane,
                             "length_mm": self.length_mm, "E_D": self.E_D,
                             "max_abs_um": self.max_abs_um, "complete": self.complete,
                             "points_measured": self.points_measured,
                             "points_planned": self.points_planned,
                             "missed": [dict(m) for m in self.missed]}
        if not self.complete:
            d["note"] = self.note()
        if self.iso230_2 is not None:
            d["iso230_2"] = self.iso230_2.to_dict()
        return d

    def to_rows(self) -> list[dict[str, Any]]:
        """The diagonal as a one-row table (:func:`volcal.io.frames.diagonal_row`).

        Returns
        -------
        list of dict
            ``id``, ``diagonal``, ``plane``, ``length_mm`` [mm], ``E_D_um``,
            ``max_abs_um``, ``R_um`` [um].
        """
        from volcal.io.frames import diagonal_row

        return [diagonal_row(self)]

    def to_dataframe(self) -> pandas.DataFrame:
        """:meth:`to_rows` as a pandas DataFrame (needs pandas).

        Returns
        -------
        pandas.DataFrame
        """
        from volcal.io.frames import to_dataframe

        return to_dataframe(self.to_rows(), "DiagonalResult")


def largest_e_d(results: Any) -> DiagonalResult | None:
    """The complete diagonal with the largest E_D (incomplete ones are left out).

    Parameters
    ----------
    results : iterable of DiagonalResult
        ISO 230-6 results.

    Returns
    -------
    DiagonalResult or None
        None when no diagonal is complete.
    """
    full = [r for r in results if r.complete]
    return max(full, key=lambda r: r.E_D) if full else None


def evaluate_diagonal(meas: Any, edition: str = "2014") -> DiagonalResult:
    """Evaluate one diagonal displacement measurement to ISO 230-6.

    Parameters
    ----------
    meas : Measurement
        A ``diagonal`` session measurement with deviations [um].
    edition : str
        ISO 230-2 edition used for bidirectional runs.

    Returns
    -------
    DiagonalResult

    Raises
    ------
    VolcalInputError
        Not a diagonal test or no deviations.
    """
    if meas.kind != "diagonal":
        raise VolcalInputError(f"measurement {meas.id!r} is a {meas.kind} test, not a "
                               "diagonal displacement test", meas.file)
    if meas.deviation is None:
        raise VolcalInputError("no deviations (planned, not measured)", meas.file, None,
                               "deviation_um")
    s = (meas.positions - meas.positions[0]) @ meas.beam_direction
    dev = np.asarray(meas.deviation, dtype=float)
    run, dirn = meas.columns.get("run"), meas.columns.get("direction")
    sub = None
    if (run is not None and dirn is not None and set(np.asarray(dirn).tolist()) == {"+", "-"}
            and min(np.unique(np.asarray(run)[np.asarray(dirn) == c]).size
                    for c in "+-") >= 2):
        sub = evaluate(s, run, dirn, dev, edition, file=meas.file,
                       rows=np.arange(2, meas.n + 2) if meas.rows is None else meas.rows,
                       allow_incomplete=True,
                       target_column="xyz"[int(np.argmax(np.ptp(meas.positions, axis=0)))]
                       + "_mm")
        e_d = sub.E
        max_abs = float(np.max(np.abs(np.concatenate([sub.targets.mean_up,
                                                       sub.targets.mean_down]))))
    else:
        e_d = float(np.ptp(dev))
        max_abs = float(np.max(np.abs(dev - dev[0])))
    missed = list(meas.meta.get("_missed", []))
    return DiagonalResult(meas.id, str(meas.meta.get("diagonal", "")),
                          meas.meta.get("plane"), float(np.ptp(s)), e_d, max_abs, sub,
                          meas.n, meas.n + len(missed), missed)


def elv(range_x_um: float, range_y_um: float, range_z_um: float) -> float:
    """Volumetric error ELv of seed 002: root sum of squares of the positioning ranges.

    Parameters
    ----------
    range_x_um, range_y_um, range_z_um : float
        Positioning error range of each axis, ``max D(q) - min D(q)`` [um].

    Returns
    -------
    float
        ``ELv = sqrt(ELx^2 + ELy^2 + ELz^2)`` [um].
    """
    return float(np.sqrt(range_x_um**2 + range_y_um**2 + range_z_um**2))
