"""Steps ``evaluate`` and ``verdict``: a session to the standards (``volcal evaluate session``).

One call evaluates the session once (:func:`volcal.standards.session.evaluate_session`:
every linear test to ISO 230-2 with its U when a budget is given, the diagonals, the
model's indices) and, with a tolerance, decides the verdicts from that evaluation
(:func:`volcal.standards.verdict.verdicts`) before and, with the compensation tables as
written, after. ``volcal evaluate session`` and :meth:`volcal.Calibration.evaluate` /
:meth:`~volcal.Calibration.verdict` call it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from volcal import defaults as D
from volcal.errors import ParameterError
from volcal.io.sniff import is_model_file
from volcal.steps import _checks

if TYPE_CHECKING:
    from volcal.identify.result import IdentificationResult
    from volcal.model.errorfunctions import MachineErrors
    from volcal.session.format import Session
    from volcal.standards.session import SessionEvaluation
    from volcal.standards.tolerance import Tolerance
    from volcal.standards.verdict import Verdict
    from volcal.uncertainty.budget import Budget

__all__ = ["Evaluated", "evaluate"]


@dataclass(frozen=True)
class Evaluated:
    """What :func:`evaluate` found.

    Attributes
    ----------
    evaluation : SessionEvaluation
        The one evaluation of the session.
    verdicts : tuple of Verdict or None
        The tolerance's verdicts (None without a tolerance).
    model : IdentificationResult or None
        The model evaluated with the session (None without one, or for an error table).
    warnings : tuple of str
        Tables of another machine let through by ``force`` (their manifest's
        differences).
    other_session : tuple of str
        How the model's session differs from this one (a model of another session is
        evaluated, not refused: the as-found model with the as-left session).
    """

    evaluation: SessionEvaluation
    verdicts: tuple[Verdict, ...] | None
    model: IdentificationResult | None
    warnings: tuple[str, ...] = ()
    other_session: tuple[str, ...] = ()


def evaluate(session: Session, *, model: str | Path | IdentificationResult | None = None,
             edition: str = D.EDITION, budget: Budget | None = None,
             tolerance: Tolerance | None = None, compensation: str | Path | None = None,
             force: bool = False, model_label: str | None = None) -> Evaluated:
    """Evaluate a session once and decide the tolerance's verdicts from that evaluation.

    Parameters
    ----------
    session : Session
        The measured session.
    model : str, Path or IdentificationResult, optional
        The identified model (``MODEL.json``, or an error table ``.csv`` for the
        volumetric verdict only): its ISO 230-1 indices with U are evaluated with the
        session.
    edition : str
        ISO 230-2 edition.
    budget : Budget, optional
        Uncertainty budget: U of every ISO 230-2 parameter (values unchanged).
    tolerance : Tolerance, optional
        The tolerance with its decision rule and guard band (checked by the face).
    compensation : str or Path, optional
        Folder written by ``compensate`` from ``model``: the verdict after its tables,
        read back from the files.
    force : bool
        Use tables whose manifest names another machine (a warning).
    model_label : str, optional
        How the warnings name the model.

    Returns
    -------
    Evaluated
    """
    from volcal.standards.session import evaluate_session

    result, errors = _model(model)
    label = model_label or (str(model) if isinstance(model, str | Path)
                            else "the model in use")
    warned: list[str] = []
    tables = None
    if compensation is not None and tolerance is not None:
        tables = _written_tables(Path(compensation), session, errors, label, force, warned)
    other: tuple[str, ...] = ()
    if result is None and errors is not None:  # an error table: of this machine?
        why = _checks.table_machine(errors, session)
        if why is not None:
            text = f"the error table is not of this session's machine ({why})"
            if not force:
                raise ParameterError(text + "; give {force=True} to evaluate it anyway",
                                     model if isinstance(model, str | Path) else None)
            warned.append(text)
    if result is not None:
        from volcal.identify.modelfile import check_model_session

        other = tuple(check_model_session(result, session, force=True))
    grid = None
    if tolerance is not None and tolerance.volumetric_um is not None and errors is not None:
        from volcal.standards.verdict import GRID_N

        grid = GRID_N
    ev = evaluate_session(session, result, edition, model_uncertainty=result is not None,
                          budget=budget, work_zone_n=grid)
    out = None
    if tolerance is not None:
        from volcal.standards.verdict import verdicts

        out = tuple(verdicts(tolerance, ev, errors, tables, model=result, session=session))
    return Evaluated(ev, out, result, tuple(warned), other)


def _model(model: str | Path | IdentificationResult | None
           ) -> tuple[IdentificationResult | None, MachineErrors | None]:
    """The model (None for an error table) and its error functions."""
    if model is None:
        return None, None
    if isinstance(model, str | Path):
        from volcal.compensate.source import load_errors

        if is_model_file(model):  # either reader refuses a path that is no file, saying why
            from volcal.identify.modelfile import load_model

            result = load_model(model)
            return result, result.errors
        return None, load_errors(model)
    return model, model.errors


def _written_tables(folder: Path, session: Session, errors: MachineErrors | None,
                    label: str, force: bool, warned: list[str]) -> Any:
    """Check the tables' manifest against the session and the model; read them back."""
    from volcal.compensate.manifest import check_manifest, errors_digest, read_manifest
    from volcal.compensate.readback import read_written_tables
    from volcal.session.identity import MachineIdentity

    manifest = read_manifest(folder)
    warned += check_manifest(manifest, folder, MachineIdentity.of(session),
                             None if errors is None else errors_digest(errors), force, label)
    return read_written_tables(folder, manifest, session.travel)
