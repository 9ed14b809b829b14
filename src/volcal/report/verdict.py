"""Pass/fail verdict of a tolerance before and after compensation.

* Volumetric tolerance: before = the largest length of the model's volumetric error over
  a grid of the work zone; after = the largest length of what the tables, as written,
  leave (:mod:`volcal.compensate.readback`).
* Per-axis ISO 230-2 tolerance: before = the accuracy ``A`` of every measured linear test
  of the axis (the largest); after = ``A`` of the same readings with the correction the
  tables apply at each pose (read back from the files, the controller's sign and
  interpolation; bidirectional tables per approach direction), projected on the beam,
  taken off. Repeatability and whatever the tables do not carry stay in ``A``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import volumetric_error
from volcal.model.names import AXES
from volcal.session.format import Session
from volcal.standards.tolerance import Tolerance, Verdict
from volcal.standards.volumetric import work_zone_grid

__all__ = ["compensated_deviation", "verdicts", "work_zone_grid"]


def compensated_deviation(m: Any, tables: Any) -> NDArray[np.float64]:
    """Readings of a test as they would be with the tables active [um].

    Parameters
    ----------
    m : Measurement
        A measured test (deviations along its beam).
    tables : WrittenTables
        The tables as written (:func:`volcal.compensate.readback.read_written_tables`).

    Returns
    -------
    ndarray, shape (n,)
        ``deviation - correction . beam`` at every reading [um], the correction being
        what the tables remove at the reading's commanded position (per approach
        direction for bidirectional tables). A constant along the test (a table not zero
        at the test's first reading) is kept: ISO 230-2 ``A`` does not see it.
    """
    return tables.deviation_after(m)


def verdicts(tolerance: Tolerance, session: Session | None, errors: MachineErrors | None,
             tables: Any, edition: str = "2014", n: int = 11) -> list[Verdict]:
    """The verdict of every tolerance given, before and (with tables) after.

    Parameters
    ----------
    tolerance : Tolerance
        Volumetric and/or per-axis tolerances [um].
    session : Session, optional
        Measured session (its linear tests give ISO 230-2 ``A``).
    errors : MachineErrors, optional
        Identified model (needed for the volumetric tolerance).
    tables : WrittenTables, optional
        Compensation tables as written (read back from their folder); without them
        there is no "after".
    edition : str
        ISO 230-2 edition.
    n : int
        Grid points per axis of the volumetric evaluation.

    Returns
    -------
    list of Verdict
    """
    from volcal.errors import VolcalInputError
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.positioning_data import from_measurement

    out: list[Verdict] = []
    if tolerance.volumetric_um is not None:
        if errors is None:
            raise VolcalInputError("a volumetric tolerance needs the identified model "
                                   "(--model MODEL.json)")
        q = work_zone_grid(errors.travel, n)
        e = volumetric_error(errors, q)
        after = None
        if tables is not None:
            after = float(np.linalg.norm(e - tables.correction(q), axis=1).max())
        out.append(Verdict(f"volumetric |e|, largest of {n}³ points",
                           tolerance.volumetric_um, float(np.linalg.norm(e, axis=1).max()),
                           after))
    for axis, tol in tolerance.axis_um.items():
        k = AXES.index(axis)
        before: list[float] = []
        after_v: list[float] = []
        tests = [] if session is None else [
            m for m in session.measurements if m.kind == "linear" and m.axis == k
            and m.deviation is not None and "run" in m.columns and "direction" in m.columns]
        for m in tests:
            d = from_measurement(m, session.path if session is not None else None)
            before.append(evaluate(d.targets_mm, d.run, d.direction, d.deviation_um,
                                   edition, **d.evaluate_kwargs()).A)
            if tables is not None:
                after_v.append(evaluate(d.targets_mm, d.run, d.direction,
                                        compensated_deviation(m, tables), edition,
                                        **d.evaluate_kwargs()).A)
        out.append(Verdict(f"{axis}: ISO 230-2 A ({len(tests)} tests)",
                           tol, max(before) if before else None,
                           max(after_v) if after_v else None))
    return out
