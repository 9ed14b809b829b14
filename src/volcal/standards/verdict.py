"""Pass/fail verdict of a tolerance before and after compensation, from one evaluation.

The values come from the session's one evaluation
(:func:`volcal.standards.session.evaluate_session`); this module only picks them and
applies the decision rule (:mod:`volcal.standards.decision`):

* Volumetric tolerance: before = the largest length of the model's volumetric error over
  a grid of the work zone (:attr:`~volcal.standards.session.SessionEvaluation.
  largest_volumetric` when the evaluation has it for that grid); after = the largest
  length of what the tables, as written, leave (:mod:`volcal.compensate.readback`).
* Per-axis ISO 230-2 tolerance: before = the accuracy ``A`` (or the parameter named) of
  every evaluated linear test of the axis (the largest), with its U when the evaluation
  had a budget; after = the same parameter of the *after-compensation readings*: the
  readings with the correction the tables apply at each pose (read back from the files,
  the controller's sign and interpolation; bidirectional tables per approach direction),
  projected on the beam, taken off. Those are other readings, so they are evaluated here
  (once per test with tables). Repeatability and whatever the tables do not carry stay
  in ``A``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import volumetric_error
from volcal.model.names import AXES
from volcal.standards.tolerance import Tolerance, Verdict
from volcal.standards.volumetric import work_zone_grid

__all__ = ["GRID_N", "compensated_deviation", "verdicts", "work_zone_grid"]

GRID_N = 11
"""Grid points per axis of the volumetric verdict (``n**3`` points over the work zone)."""


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


def verdicts(tolerance: Tolerance, evaluation: Any = None, errors: MachineErrors | None = None,
             tables: Any = None, n: int = GRID_N, model: Any = None, session: Any = None
             ) -> list[Verdict]:
    """The verdict of every tolerance given, before and (with tables) after.

    Parameters
    ----------
    tolerance : Tolerance
        Volumetric and/or per-axis tolerances [um] (``A`` per axis, other ISO 230-2
        parameters in ``tolerance.parameters``), the decision rule and guard band.
    evaluation : SessionEvaluation, optional
        The session's evaluation (:func:`volcal.standards.session.evaluate_session`): the
        ISO 230-2 values of its linear tests and, when it was evaluated with a budget,
        their U (the guard band of the guarded rule). Without it there is no per-axis
        value.
    errors : MachineErrors, optional
        Identified model (needed for the volumetric tolerance).
    tables : WrittenTables, optional
        Compensation tables as written (read back from their folder); without them
        there is no "after".
    n : int
        Grid points per axis of the volumetric evaluation.
    model : IdentificationResult, optional
        The identified model of ``errors`` with its covariance: U of the volumetric
        values before and after (:func:`volcal.standards.model_uncertainty.
        largest_length`, noise and systematic parts), the guard band of the guarded rule.
    session : Session, optional
        The evaluated session: with ``tables``, its readings give the "after" of the
        per-axis tolerances.

    Returns
    -------
    list of Verdict

    Raises
    ------
    VolcalInputError
        A volumetric tolerance without the model; the guarded rule without U or guard
        band.
    """
    out: list[Verdict] = []
    if tolerance.volumetric_um is not None:
        out.append(_volumetric(tolerance, evaluation, errors, tables, n, model))
    axes = [a for a in AXES if a in tolerance.axis_um or a in tolerance.parameters]
    for axis in axes:
        out.extend(_axis(tolerance, axis, evaluation, tables, session))
    return out


def _volumetric(tolerance: Tolerance, evaluation: Any, errors: MachineErrors | None,
                tables: Any, n: int, model: Any) -> Verdict:
    """The volumetric line: largest |e| over the grid before and after, with U."""
    from volcal.errors import VolcalInputError

    rule, guard_band_um = tolerance.rule, tolerance.guard_band_um
    if errors is None:
        raise VolcalInputError("a volumetric tolerance needs the identified model "
                               "(--model MODEL.json)")
    if rule == "guarded" and guard_band_um is None and model is None:  # U of the model
        raise VolcalInputError("--decision-rule guarded on the volumetric tolerance (V) "
                               "needs the identified model's uncertainty (--model "
                               "MODEL.json) or --guard-band-um W",
                               column="--guard-band-um")
    q = work_zone_grid(errors.travel, n)
    largest = getattr(evaluation, "largest_volumetric", None)
    if largest is not None and largest.n == n:  # computed once with the evaluation
        before, U_before = largest.value_um, largest.U_um
    else:
        before = float(np.linalg.norm(volumetric_error(errors, q), axis=1).max())
        U_before = None
    if model is None:
        U_before = None
    elif U_before is None:
        from volcal.standards.model_uncertainty import largest_length

        U_before = largest_length(model, q).U
    after = U_after = None
    if tables is not None:
        corr = tables.correction(q)
        after = float(np.linalg.norm(volumetric_error(errors, q) - corr, axis=1).max())
        if model is not None:
            from volcal.standards.model_uncertainty import largest_length

            U_after = largest_length(model, q, corr).U
    T = tolerance.volumetric_um
    assert T is not None  # verdicts() asks for this line only with a volumetric tolerance
    return Verdict(f"volumetric |e|, largest of {n}³ points", T, before, after, rule,
                   U_before, U_after, guard_band_um)


def _axis(tolerance: Tolerance, axis: str, evaluation: Any, tables: Any, session: Any
          ) -> list[Verdict]:
    """The lines of one axis: every toleranced ISO 230-2 parameter, before and after."""
    from volcal.standards.decision import require_uncertainty

    rule, guard_band_um = tolerance.rule, tolerance.guard_band_um
    tols = {"A": tolerance.axis_um[axis]} if axis in tolerance.axis_um else {}
    tols.update(tolerance.parameters.get(axis, {}))
    ids = [] if evaluation is None else [k for k in evaluation.iso230_2
                                         if evaluation.axis.get(k) == axis]
    budget = None if evaluation is None else evaluation.budget
    if ids:
        require_uncertainty(rule, guard_band_um, budget is not None)
    before = [(evaluation.iso230_2[k], evaluation.uncertainties.get(k)) for k in ids]
    after: list[tuple[Any, Any]] = []
    if tables is not None and session is not None:
        after = [_after(session.get(k), session.path, tables, evaluation.edition, budget)
                 for k in ids]
    out = []
    for param, tol in tols.items():
        vb, ub = _largest(before, param)
        va, ua = _largest(after, param)
        out.append(Verdict(f"{axis}: ISO 230-2 {param} ({len(ids)} tests)", tol, vb, va,
                           rule, ub, ua, guard_band_um))
    return out


def _after(m: Any, folder: Any, tables: Any, edition: str, budget: Any) -> tuple[Any, Any]:
    """ISO 230-2 of a test's after-compensation readings (with U given a budget).

    These readings are not the session's: the one evaluation per test of the session
    does not cover them, so each is evaluated here, once.
    """
    from dataclasses import replace

    from volcal.standards import iso230_2
    from volcal.standards.positioning_data import from_measurement

    d = from_measurement(m, folder)
    dev = np.asarray(compensated_deviation(m, tables))
    if budget is None:
        return iso230_2.evaluate(d.targets_mm, d.run, d.direction, dev, edition,
                                 **d.evaluate_kwargs()), None
    from volcal.standards.iso230_2_uncertainty import evaluate_with_budget

    res, unc, _ = evaluate_with_budget(replace(d, deviation_um=dev), budget, edition)
    return res, unc


def _largest(results: list[tuple[Any, Any]], param: str) -> tuple[float | None, float | None]:
    """The largest value of a parameter over the tests, and its U (None: no test)."""
    if not results:
        return None, None
    vals = [abs(float(getattr(r, param))) for r, _ in results]
    i = int(np.argmax(vals))
    unc = results[i][1]
    return vals[i], None if unc is None else unc.parameters[param].U
