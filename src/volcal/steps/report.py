"""Steps ``report`` and ``certificate``: the report of a session (``volcal report``).

One function writes the technical report (HTML and PDF) and, when one is wanted, the
calibration certificate, from the one evaluation of each session
(:func:`volcal.standards.session.evaluate_session`): the report and the certificate only
format what it gives. The command line (``volcal report``) and
:meth:`volcal.Calibration.report` parse their arguments and call :func:`report`.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from volcal import defaults as D

if TYPE_CHECKING:
    from volcal.identify.location_evaluation import LocationTolerance
    from volcal.identify.result import IdentificationResult
    from volcal.model.errorfunctions import MachineErrors
    from volcal.report.certificate_files import CertificateFiles
    from volcal.report.writer import ReportFiles
    from volcal.session.format import Session
    from volcal.standards.session import SessionEvaluation
    from volcal.standards.tolerance import Tolerance
    from volcal.uncertainty.budget import Budget

__all__ = ["Reported", "check_report_inputs", "report"]


@dataclass(frozen=True)
class Reported:
    """What :func:`report` wrote.

    Attributes
    ----------
    files : ReportFiles
        ``.html``, ``.pdf``, ``.figures``, ``.pdf_pages`` of the report.
    certificate : CertificateFiles or None
        The certificate's files (in the report folder), when one was issued.
    report_id : str or None
        The certificate's number.
    model : IdentificationResult or None
        The model reported (with the budget's systematic part for a certificate).
    evaluation : SessionEvaluation
        The one evaluation of the session.
    as_left_evaluation : SessionEvaluation or None
        The one evaluation of the as-left session (certificate only).
    warnings : tuple of str
        The model's differences let through by ``force``, equipment overdue for
        calibration (``'certificate: EXPIRED ...'``), compensation warnings.
    moved : str or None
        With ``replace``: where the files volcal did not write were moved.
    """

    files: ReportFiles
    certificate: CertificateFiles | None
    report_id: str | None
    model: IdentificationResult | None
    evaluation: SessionEvaluation
    as_left_evaluation: SessionEvaluation | None
    warnings: tuple[str, ...] = ()
    moved: str | None = None


def check_report_inputs(output: str | Path, *, history: str | None = None,
                        replace: bool = False, option: str = "--replace") -> str | None:
    """The checks before any work: the history store, then the output folder claimed.

    Parameters
    ----------
    output : str or Path
        Report folder: new, empty, or an earlier report (its own files only, unless
        ``replace``).
    history : str, optional
        Calibration history (URL or SQLite file).
    replace : bool
        Move the files volcal did not write in ``output`` to ``backup/<UTC time>/``.
    option : str
        How the face spells ``replace`` in the refusal.

    Returns
    -------
    str or None
        Where ``replace`` moved foreign files (relative to ``output``), else None.
    """
    from volcal.io.paths import prepare_output_folder
    from volcal.report.writer import written_files

    if history is not None:
        from volcal.extras import HISTORY_STORE, require_extra

        require_extra("history", "volcal report --history", HISTORY_STORE)
        from volcal.history.previous import check_history

        check_history(history)
    return prepare_output_folder(output, "report", lambda p: (p / "report.html").is_file(),
                                 written=written_files, replace=replace, option=option)


def report(session: Session, *, output: str | Path,
           model: str | Path | IdentificationResult | None = None,
           truth: MachineErrors | None = None, title: str | None = None,
           edition: str = D.EDITION, tolerance: Tolerance | None = None,
           compensation: str | Path | None = None, history: str | None = None,
           force: bool = False, certificate: bool = False, as_left: Session | None = None,
           tables: str | Path | None = None, strict: bool = False,
           budget: Budget | None = None, budget_file: str | Path | None = None,
           model_label: str | None = None, identify_hint: str | None = None,
           moved: str | None = None,
           status: Callable[[str], AbstractContextManager[Any]] | None = None,
           angle_units: str = "urad",
           rotary_tolerance_urad: dict[str, float] | None = None,
           location_tolerance: LocationTolerance | None = None) -> Reported:
    """Evaluate a session once and write its report (and certificate).

    Parameters
    ----------
    session : Session
        The measured (as-found) session.
    output : str or Path
        Report folder, already checked (:func:`check_report_inputs`).
    model : str, Path or IdentificationResult, optional
        The identified model (a ``MODEL.json`` is loaded and checked against the
        session); identified now with the default options when omitted.
    truth : MachineErrors, optional
        Simulated truth (read from the session folder when omitted).
    title : str, optional
        Report title (default from the machine, naming the certificate when issued).
    edition : str
        ISO 230-2 edition.
    tolerance : Tolerance, optional
        The tolerance with its decision rule, guard band and budget.
    compensation : str or Path, optional
        Folder written by ``compensate`` from the model (the "after").
    history : str, optional
        Calibration history: the section "Previous calibration".
    force : bool
        Use a model of another session and tables of another machine (warnings).
    certificate : bool
        Issue the certificate (automatic with ``[calibration]``, ``[[equipment]]`` or
        ``as_left``).
    as_left : Session, optional
        The as-left session, paired on the certificate.
    tables : str or Path, optional
        Compensation folder loaded between the sessions, named on the certificate.
    strict : bool
        Refuse equipment overdue for calibration.
    budget : Budget, optional
        Uncertainty budget: every test's U; a certificate's model carries its
        systematic part.
    budget_file : str or Path, optional
        The budget's file, named in messages and in the model's record.
    model_label : str, optional
        How the report's warnings name the model.
    identify_hint : str, optional
        How to identify with the budget, for the refusal of a model file without one.
    moved : str, optional
        What :func:`check_report_inputs` moved (returned in the result).
    status : callable, optional
        ``status(text)`` -> context manager shown while a long part runs.
    angle_units : str
        ``'urad'`` or ``'arcsec'``: the rotary axes' angles in the report.
    rotary_tolerance_urad : dict of str to float, optional
        Tolerance of the accuracy A per rotary axis (``{'C': 25.0}`` [urad]): the verdict
        of the rotary section and of the certificate's rotary table.
    location_tolerance : LocationTolerance, optional
        With probe_sphere tests: the tolerance of the largest range of the sphere
        centre's deviation per path [um] with its decision rule
        (:func:`volcal.identify.location_evaluation.location_tolerance`): the
        ISO 10791-6-style test of the report's and the certificate's location sections.

    Returns
    -------
    Reported
    """
    from volcal.report.certificate_inputs import certificate_model, certificate_wanted
    from volcal.report.figures import watch_cores
    from volcal.report.pipeline import collect_inputs
    from volcal.report.sections import build_report
    from volcal.report.writer import write_report
    from volcal.standards.model_uncertainty import has_covariance
    from volcal.standards.session import evaluate_session
    from volcal.standards.verdict import GRID_N

    watch_cores()  # how busy the machine is while this report works: its drawing workers
    busy = status or (lambda text: nullcontext())
    warned: list[str] = []
    if compensation is not None:  # refuse another machine's tables before any work
        from volcal.compensate.manifest import check_manifest, read_manifest
        from volcal.session.identity import MachineIdentity

        check_manifest(read_manifest(compensation), compensation,
                       MachineIdentity.of(session), None, force)
    cert = certificate_wanted(session, as_left, tables, certificate, strict)
    model_file = None
    from volcal.session.kinds import kind_of

    if model is None and not any(kind_of(m.kind).in_design for m in session.measurements):
        result = None  # rotary tests only: evaluated per axis, nothing to identify
    elif model is None:
        from volcal.identify import identify

        with busy("identifying the machine's errors..."):
            result = identify(session)
    elif isinstance(model, str | Path):
        from volcal.identify.modelfile import check_model_session, load_model

        model_file = Path(model)
        result = load_model(model_file)
        result.require_uncertainty("the report (the uncertainty bands of the error functions "
                                   "and of the volumetric error)", model_file)
        warned += [f"--force: {d}" for d in check_model_session(result, session, force,
                                                                 model_file)]
    else:
        result = model
    if cert and budget is not None:  # the certificate's volumetric U with the systematic part
        result = certificate_model(result, budget, budget_file, model_file, session,
                                   identify_hint)
    grid = GRID_N if tolerance is not None and tolerance.volumetric_um is not None else None
    from volcal.identify.location_evaluation import locate_session

    with busy("evaluating..."):  # the one evaluation of each session
        ev = evaluate_session(session, result, edition, model_uncertainty=has_covariance(result),
                              budget=budget, work_zone_n=grid, optics=True)
        ev_left = None if as_left is None or not cert else evaluate_session(
            as_left, None, edition, budget=budget, optics=True)
        # the probe_sphere tests' location errors, once for the report and the certificate
        located = locate_session(session, result)
    written: list[CertificateFiles] = []
    extra = None
    report_id = None
    if cert:
        from volcal.report.certificate import build_certificate
        from volcal.report.certificate_files import write_certificate

        doc = build_certificate(session, result, as_left=as_left, tables=tables,
                                tolerance=tolerance, optics_budget=budget, edition=edition,
                                evaluation=ev, as_left_evaluation=ev_left,
                                rotary_tolerance_urad=rotary_tolerance_urad,
                                location=located, location_tolerance=location_tolerance)
        report_id = doc["report_id"]
        warned += [f"certificate: {w}" for w in doc["warnings"] if w.startswith("EXPIRED")]
        if title is None:  # the technical report names its certificate on every page
            title = (f"Calibration report: {session.name}, technical report to certificate "
                     f"{report_id}")

        def extra(tmp: Path) -> None:
            written.append(write_certificate(doc, tmp, angle_units))

    with busy("writing the report..."):
        inputs = collect_inputs(session, result, truth, edition, compensation,
                                tolerance=tolerance, force=force,
                                model_label=model_label or (
                                    "the model identified now" if model is None
                                    else str(model_file or "the model in use")),
                                budget=budget, evaluation=ev)
        inputs.angle_units, inputs.rotary_tolerance_urad = angle_units, rotary_tolerance_urad
        inputs.location, inputs.location_tolerance = located, location_tolerance
        if history is not None:  # the history (SQLAlchemy) is loaded only here
            from volcal.history.previous import previous_section

            inputs.extra_sections.append(previous_section(inputs, history))
        files = write_report(build_report(inputs, title), output, extra)
    if inputs.compensation is not None:
        warned += list(inputs.compensation.warnings)
    cfiles = None
    if written:
        from volcal.report.certificate_files import CertificateFiles

        c, out = written[0], Path(output)
        cfiles = CertificateFiles(out / c.pdf.name, out / c.html.name, out / c.json.name,
                                  c.pdf_pages)
    return Reported(files, cfiles, report_id, result, ev, ev_left, tuple(warned), moved)
