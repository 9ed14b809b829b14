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
             tables: Any, edition: str = "2014", n: int = 11, model: Any = None
             ) -> list[Verdict]:
    """The verdict of every tolerance given, before and (with tables) after.

    Parameters
    ----------
    tolerance : Tolerance
        Volumetric and/or per-axis tolerances [um] (``A`` per axis, other ISO 230-2
        parameters in ``tolerance.parameters``), the decision rule and guard band; with
        ``tolerance.budget`` (:func:`volcal.uncertainty.budget.read_budget`) U of the
        per-axis parameters is computed (their values are those without it).
    session : Session, optional
        Measured session (its linear tests give the ISO 230-2 parameters).
    errors : MachineErrors, optional
        Identified model (needed for the volumetric tolerance).
    tables : WrittenTables, optional
        Compensation tables as written (read back from their folder); without them
        there is no "after".
    edition : str
        ISO 230-2 edition.
    n : int
        Grid points per axis of the volumetric evaluation.
    model : IdentificationResult, optional
        The identified model of ``errors`` with its covariance: U of the volumetric
        values before and after (:func:`volcal.standards.model_uncertainty.
        largest_length`, noise and systematic parts), the guard band of the guarded rule.

    Returns
    -------
    list of Verdict
    """
    from volcal.errors import VolcalInputError
    from volcal.standards.decision import check_rule
    from volcal.standards.positioning_data import from_measurement

    rule = check_rule(tolerance.rule)
    guard_band_um, budget = tolerance.guard_band_um, tolerance.budget
    out: list[Verdict] = []
    if tolerance.volumetric_um is not None:
        if errors is None:
            raise VolcalInputError("a volumetric tolerance needs the identified model "
                                   "(--model MODEL.json)")
        if rule == "guarded" and guard_band_um is None and model is None:
            raise VolcalInputError("--decision-rule guarded on the volumetric tolerance (V) "
                                   "needs the identified model's uncertainty (--model "
                                   "MODEL.json) or --guard-band-um W",
                                   column="--guard-band-um")
        q = work_zone_grid(errors.travel, n)
        e = volumetric_error(errors, q)
        after = U_before = U_after = None
        corr = None if tables is None else tables.correction(q)
        if corr is not None:
            after = float(np.linalg.norm(e - corr, axis=1).max())
        if model is not None:
            from volcal.standards.model_uncertainty import largest_length

            U_before = largest_length(model, q).U
            if corr is not None:
                U_after = largest_length(model, q, corr).U
        out.append(Verdict(f"volumetric |e|, largest of {n}³ points",
                           tolerance.volumetric_um, float(np.linalg.norm(e, axis=1).max()),
                           after, rule, U_before, U_after, guard_band_um))
    axes = [a for a in AXES if a in tolerance.axis_um or a in tolerance.parameters]
    for axis in axes:
        k = AXES.index(axis)
        tols = {"A": tolerance.axis_um[axis]} if axis in tolerance.axis_um else {}
        tols.update(tolerance.parameters.get(axis, {}))
        tests = [] if session is None else [
            m for m in session.measurements if m.kind == "linear" and m.axis == k
            and m.deviation is not None and "run" in m.columns and "direction" in m.columns]
        if rule == "guarded" and guard_band_um is None and budget is None and tests:
            raise VolcalInputError("--decision-rule guarded needs the expanded uncertainty "
                                   "(--budget FILE) or a guard band (--guard-band-um W)",
                                   column="--decision-rule")
        before: list[tuple[Any, Any]] = []
        after_v: list[tuple[Any, Any]] = []
        for m in tests:
            d = from_measurement(m, session.path if session is not None else None)
            before.append(_evaluate(d, d.deviation_um, edition, budget))
            if tables is not None:
                after_v.append(_evaluate(d, compensated_deviation(m, tables), edition,
                                         budget))
        for param, tol in tols.items():
            vb, ub = _largest(before, param)
            va, ua = _largest(after_v, param)
            out.append(Verdict(f"{axis}: ISO 230-2 {param} ({len(tests)} tests)", tol, vb, va,
                               rule, ub, ua, guard_band_um))
    return out


def _evaluate(d: Any, deviation: Any, edition: str, budget: Any) -> tuple[Any, Any]:
    """ISO 230-2 of one test's readings, with its uncertainty when a budget is given."""
    from dataclasses import replace

    from volcal.standards.iso230_2 import evaluate

    if budget is None:
        kw = d.evaluate_kwargs() if hasattr(d, "evaluate_kwargs") else {}
        return evaluate(d.targets_mm, d.run, d.direction, deviation, edition, **kw), None
    from volcal.standards.iso230_2_uncertainty import evaluate_with_budget

    res, unc, _ = evaluate_with_budget(replace(d, deviation_um=np.asarray(deviation)),
                                       budget, edition)
    return res, unc


def _largest(results: list[tuple[Any, Any]], param: str) -> tuple[float | None, float | None]:
    """The largest value of a parameter over the tests, and its U (None: no test)."""
    if not results:
        return None, None
    vals = [abs(float(getattr(r, param))) for r, _ in results]
    i = int(np.argmax(vals))
    unc = results[i][1]
    return vals[i], None if unc is None else unc.parameters[param].U
