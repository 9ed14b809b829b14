"""Gather what the report shows: evaluate a session to the standards around its model.

This is the thin glue between the analysis modules and the report document: ISO 230-2
for every linear test with runs and directions, ISO 230-6 for every diagonal, the
volumetric indices and seed 002's ELv of the identified machine, and the simulated truth
when the session has one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from volcal.compensate.manifest import read_manifest
from volcal.model.errorfunctions import MachineErrors
from volcal.report.sections import ReportInputs
from volcal.session.errortable import read_error_table
from volcal.session.format import Session

__all__ = ["CompensationSummary", "collect_inputs", "compensation_summary", "read_manifest",
           "read_truth"]


@dataclass(frozen=True)
class CompensationSummary:
    """What compensation tables were written and the error they leave.

    Attributes
    ----------
    folder : Path or None
        Folder of the tables (with ``volcal-compensation.toml``), if written.
    manifest : dict
        The folder's manifest: controller format, sign, spacing, files, what it carries.
    tables : TableSet or None
        What the tables carry and how the controller applies them, from the manifest
        (None without a folder).
    model_max_um, model_rms_um : float
        Largest and RMS length of the modelled volumetric error over the work zone [um].
    left_max_um, left_rms_um : float or None
        Largest and RMS length of the modelled volumetric error left after applying the
        tables as written (read back from their files, applied with the controller's
        interpolation rule: :mod:`volcal.compensate.readback`) [um]; None without
        tables.
    residual_u2_max_um : float
        Largest expanded uncertainty (k = 2) of the modelled volumetric error [um]: the
        estimation error no table can remove, at 95 %.
    truth_max_um : float or None
        Simulated sessions only: largest true volumetric error [um].
    truth_model_max_um : float or None
        Simulated sessions only: largest length of true minus modelled error [um] (the
        identification error).
    truth_residual_max_um, truth_residual_rms_um : float or None
        Simulated sessions with tables only: largest and RMS length of the true error
        left after applying the tables [um].
    verdicts : list of Verdict
        Tolerance verdicts before and after (empty without a tolerance).
    n : int
        Grid points per axis of the evaluation.
    warnings : list of str
        What the manifest check found (another model of the same machine, a manifest
        without identity, another machine used with ``force``).
    written : WrittenTables or None
        The tables read back from their files.
    """

    folder: Path | None
    manifest: dict[str, Any]
    tables: Any
    model_max_um: float
    model_rms_um: float
    left_max_um: float | None
    left_rms_um: float | None
    residual_u2_max_um: float
    truth_max_um: float | None
    truth_model_max_um: float | None
    truth_residual_max_um: float | None
    truth_residual_rms_um: float | None
    verdicts: list[Any]
    n: int
    warnings: list[str] = field(default_factory=list)
    written: Any = None


def _norms(v: np.ndarray) -> tuple[float, float]:
    r = np.linalg.norm(v, axis=1)
    return float(r.max()), float(np.sqrt(np.mean(r**2)))


def compensation_summary(result: Any, travel: Any, truth: MachineErrors | None = None,
                         folder: str | Path | None = None, n: int = 11,
                         tolerance: Any = None, session: Session | None = None,
                         edition: str = "2014", force: bool = False,
                         model_label: str = "the model in use",
                         evaluation: Any = None) -> CompensationSummary:
    """Summarise the compensation of a model: the files written and the error they leave.

    Parameters
    ----------
    result : IdentificationResult
        The identified model (``errors``; ``predict`` gives the volumetric error and its
        uncertainty).
    travel : array_like, shape (3, 2)
        Work zone [mm].
    truth : MachineErrors, optional
        Simulated truth.
    folder : str or Path, optional
        Compensation folder written by ``volcal compensate`` (its manifest says what the
        tables carry, see :func:`volcal.report.carried.table_set_from_manifest`; the
        tables themselves are read back, :func:`volcal.compensate.readback.read_written_tables`).
    n : int
        Grid points per axis.
    tolerance : Tolerance, optional
        Tolerances for a pass/fail verdict before and after
        (:func:`volcal.standards.tolerance.parse_tolerance`).
    session : Session, optional
        Measured session (its linear tests give the per-axis ISO 230-2 verdict).
    edition : str
        ISO 230-2 edition of the per-axis verdict.
    force : bool
        With ``session``: use tables written for another machine (a warning) instead of
        refusing them (:func:`volcal.compensate.manifest.check_manifest`).
    model_label : str
        How warnings name the model in use.
    evaluation : SessionEvaluation, optional
        The session's one evaluation (:func:`volcal.standards.session.evaluate_session`):
        the values the verdict judges. Without it, and with ``session`` and a per-axis
        tolerance, the session is evaluated here (with ``tolerance.budget``).

    Returns
    -------
    CompensationSummary

    Raises
    ------
    VolcalInputError
        If ``folder`` has no readable ``volcal-compensation.toml``, a table file is
        missing or damaged, or (with ``session``) the tables were written for another
        machine and ``force`` is false.
    """
    from volcal.compensate.readback import read_written_tables
    from volcal.model.kinematics import volumetric_error
    from volcal.report.carried import table_set_from_manifest
    from volcal.standards.model_uncertainty import has_covariance
    from volcal.standards.verdict import verdicts, work_zone_grid

    manifest: dict[str, Any] = {}
    tables = written = None
    warnings: list[str] = []
    if folder is not None:
        manifest = read_manifest(folder)
        if session is not None:
            from volcal.compensate.manifest import check_manifest, errors_digest
            from volcal.session.identity import MachineIdentity

            warnings = check_manifest(manifest, folder, MachineIdentity.of(session),
                                      errors_digest(result.errors), force, model_label)
        tables = table_set_from_manifest(manifest, folder)
        written = read_written_tables(folder, manifest, travel)
    q = work_zone_grid(travel, n)
    e, u = result.predict(q)
    model_max, model_rms = _norms(e)
    left_max = left_rms = None
    corr = None
    if written is not None:
        corr = written.correction(q)
        left_max, left_rms = _norms(volumetric_error(result.errors, q) - corr)
    tmax = tmodel = tres = trms = None
    if truth is not None:
        et = volumetric_error(truth, q)
        tmax = _norms(et)[0]
        tmodel = _norms(et - e)[0]
        if corr is not None:
            tres, trms = _norms(et - corr)
    if (tolerance is not None and evaluation is None and session is not None
            and (tolerance.axis_um or tolerance.parameters)):
        from volcal.standards.session import evaluate_session

        evaluation = evaluate_session(session, None, edition,
                                      budget=getattr(tolerance, "budget", None))
    vs = [] if tolerance is None else verdicts(tolerance, evaluation, result.errors, written,
                                                n, model=result if has_covariance(result)
                                                else None, session=session)
    return CompensationSummary(None if folder is None else Path(folder), manifest, tables,
                               model_max, model_rms, left_max, left_rms,
                               float(2.0 * np.linalg.norm(u, axis=1).max()), tmax, tmodel,
                               tres, trms, vs, n, warnings, written)


def read_truth(session: Session) -> MachineErrors | None:
    """Read the simulated truth ``SESSION/truth/machine.csv`` if there is one.

    None too for an as-left session simulated with a 3-D grid of corrections
    (``truth/compensation.toml`` ``grid = true``): its ``machine.csv`` is the machine as
    found, and the machine the readings show (that machine, its commanded positions
    shifted by the grid) has no error table to compare a model with.

    Parameters
    ----------
    session : Session
        A session read from disk.

    Returns
    -------
    MachineErrors or None
    """
    if session.path is None:
        return None
    path = session.path / "truth" / "machine.csv"
    if not path.is_file():
        return None
    comp = session.path / "truth" / "compensation.toml"
    if comp.is_file():
        import tomllib

        try:
            if tomllib.loads(comp.read_text(encoding="utf-8")).get("grid") is True:
                return None
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            return None  # a truth record volcal cannot read is no truth to compare with
    return read_error_table(path, chain=session.chain)


def collect_inputs(session: Session, result: Any = None, truth: MachineErrors | None = None,
                   edition: str = "2014", compensation: str | Path | None = None,
                   tolerance: Any = None, force: bool = False,
                   model_label: str = "the model in use", budget: Any = None,
                   model_uncertainty: bool = True, evaluation: Any = None) -> ReportInputs:
    """Evaluate the session and its model for the report.

    Parameters
    ----------
    session : Session
        Measured session.
    result : IdentificationResult, optional
        Identified model (from ``volcal.identify`` or a model file).
    truth : MachineErrors, optional
        Simulated truth; read from the session folder when omitted.
    edition : str
        ISO 230-2 edition.
    compensation : str or Path, optional
        Folder of compensation tables written from ``result``.
    tolerance : Tolerance, optional
        Tolerances for the pass/fail verdict of the compensation section (volumetric
        and/or per-axis ISO 230-2 ``A``).
    force : bool
        Use compensation tables written for another machine (with a warning).
    model_label : str
        How warnings name the model in use.
    budget : Budget, optional
        Uncertainty budget (:func:`volcal.uncertainty.budget.read_budget`): every
        ISO 230-2 parameter and target of the linear tests carries its U (the values are
        those without it) (:func:`volcal.standards.iso230_2_uncertainty.
        evaluate_with_budget`); likewise every diagonal's E_D
        (:func:`volcal.standards.iso230_6_uncertainty.evaluate_diagonal_with_budget`).
    model_uncertainty : bool
        U of the model's volumetric indices, straightness and squareness
        (:mod:`volcal.standards.model_uncertainty`, about a second).
    evaluation : SessionEvaluation, optional
        The session's one evaluation (:func:`volcal.standards.session.evaluate_session`
        with ``result`` and ``budget``), as the front doors give it; evaluated here when
        omitted. The report formats it and never evaluates a test again.

    Returns
    -------
    ReportInputs
    """
    ev = evaluation
    if ev is None:
        from volcal.standards.model_uncertainty import has_covariance
        from volcal.standards.session import evaluate_session

        ev = evaluate_session(session, result, edition,
                              model_uncertainty=model_uncertainty and has_covariance(result),
                              budget=budget, optics=True)
    if truth is None:
        truth = read_truth(session)
    comp = None
    if result is not None:
        comp = compensation_summary(result, session.travel, truth, compensation,
                                    tolerance=tolerance, session=session, edition=edition,
                                    force=force, model_label=model_label, evaluation=ev)
    return ReportInputs(session, result, truth, ev.iso230_2 or None, ev.iso230_6 or None,
                        ev.volumetric, comp, elv=ev.elv, budget=ev.budget,
                        iso230_2_uncertainty=ev.uncertainties or None,
                        corrections=ev.corrections_text,
                        iso230_6_uncertainty=ev.diagonal_uncertainties or None,
                        evaluation=ev)
