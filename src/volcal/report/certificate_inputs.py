"""What a certificate needs before it is built: whether one is issued, the model it states.

One definition for ``volcal report`` and :meth:`volcal.Calibration.report` (the messages
name the command line's options; the Python API re-words them with
:func:`volcal.flowargs.python_names`). The results and their U are the session's one
evaluation (:func:`volcal.standards.session.evaluate_session` with the budget; each test
with its U: :attr:`volcal.standards.session.SessionEvaluation.with_budget`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError


def session_uncertainties(session: Any, budget: Any, edition: str) -> dict[str, Any]:
    """ISO 230-2 (ISO 230-6) of every linear test (diagonal) of a session with its U.

    The session's one evaluation with the budget
    (:func:`volcal.standards.session.evaluate_session`), each test's results and U
    together (:attr:`volcal.standards.session.SessionEvaluation.with_budget`); ``volcal
    report`` and :meth:`volcal.Calibration.report` hand that evaluation to the
    certificate instead.

    Parameters
    ----------
    session : Session
        The session with readings.
    budget : Budget
        The uncertainty budget (:func:`volcal.uncertainty.budget.read_budget`).
    edition : str
        ISO 230-2 edition.

    Returns
    -------
    dict of str to EvaluatedWithBudget
        By measurement id.
    """
    from volcal.standards.session import evaluate_session

    return evaluate_session(session, None, edition, budget=budget).with_budget


def has_systematic(result: Any) -> bool:
    """Whether an identified model carries the systematic part of a budget.

    Parameters
    ----------
    result : IdentificationResult
        A fresh result or one read from a model file.

    Returns
    -------
    bool
        True when it was identified with a budget (``volcal identify --budget``,
        :func:`volcal.identify.systematic.attach_systematic`).
    """
    sf = getattr(result, "sys_factor", None)
    return sf is not None and getattr(sf, "ndim", 0) == 2 and sf.shape[1] > 0


def certificate_model(result: Any, budget: Any, budget_file: str | Path | None = None,
                      model_file: str | Path | None = None, session: Any = None,
                      identify_hint: str | None = None) -> Any:
    """The model a certificate with a budget states: the budget's systematic part included.

    A certificate with ``--budget`` states the volumetric indices' U; without the
    budget's systematic inputs (laser wavelength, air per set-up, material per axis) that
    U is the identification's noise and prior part only. A model identified here (it has
    its design) is re-propagated: the systematic part is linear in the fit's gain, so
    :func:`volcal.identify.systematic.attach_systematic` gives exactly what ``volcal
    identify --budget`` gives (on a copy; the values are unchanged). A model read from a
    file has no design and is refused.

    Parameters
    ----------
    result : IdentificationResult or None
        The model.
    budget : Budget or None
        The uncertainty budget of the certificate (None: ``result`` as it is).
    budget_file : str or Path, optional
        The budget's file, for the message and the model's record.
    model_file : str or Path, optional
        The model's file, for the message.
    session : Session, optional
        The session, for the message.
    identify_hint : str, optional
        How to identify with the budget (default ``volcal identify S --budget B -o M``).

    Returns
    -------
    IdentificationResult or None
        ``result`` when it carries a systematic part (or no budget is given), else a
        copy with the budget's systematic part.

    Raises
    ------
    VolcalInputError
        A model read from a file, identified without a budget.
    """
    if budget is None or result is None or has_systematic(result):
        return result
    if getattr(result, "design", None) is not None and getattr(result, "solution", None) \
            is not None:
        from copy import copy

        from volcal.identify.systematic import attach_systematic

        return attach_systematic(copy(result), budget, "" if budget_file is None
                                 else str(budget_file))
    s = "SESSION" if session is None or getattr(session, "path", None) is None \
        else str(session.path)
    b = "BUDGET" if budget_file is None else str(budget_file)
    m = "MODEL.json" if model_file is None else str(model_file)
    hint = identify_hint or f"`volcal identify {s} --budget {b} -o {m}`"
    raise VolcalInputError(
        f"--budget: the model was identified without an uncertainty budget, so its "
        "volumetric U would lack the systematic part (laser wavelength, air, material) "
        f"on the certificate. Identify it with the budget: run {hint}, and give that "
        "model", model_file)


def certificate_wanted(s: Any, s2: Any, tables: str | Path | None, certificate: bool,
                       strict: bool) -> bool:
    """Whether a certificate is issued; the refusals come before any work.

    Parameters
    ----------
    s : Session
        The as-found session.
    s2 : Session or None
        The as-left session (``--as-left``).
    tables : str or Path, optional
        Compensation folder loaded in between (``--tables``).
    certificate : bool
        Asked for explicitly (``--certificate``).
    strict : bool
        Refuse expired equipment (``--strict``).

    Returns
    -------
    bool

    Raises
    ------
    VolcalInputError
        ``--tables`` without ``--as-left``, ``--strict`` without a certificate, expired
        equipment with ``--strict``, damaged or foreign tables, two machines.
    """
    from volcal.report.certificate import certificate_applies, refuse_expired

    cert = certificate or certificate_applies(s) or s2 is not None
    if tables is not None and s2 is None:
        raise VolcalInputError("--tables names the compensation loaded between the as-found "
                               "and the as-left measurement: give --as-left SESSION2 too")
    if not cert:
        if strict:
            raise VolcalInputError("--strict applies to the certificate: the session has no "
                                   "[calibration] keys or [[equipment]] (or give --certificate)")
        return False
    sessions = {"as_found": s} if s2 is None else {"as_found": s, "as_left": s2}
    if strict:
        refuse_expired(sessions)
    if tables is not None:
        from volcal.report.certificate import tables_of

        tables_of(tables, s)  # a damaged manifest or another machine's tables: refused now
    if s2 is not None:
        from volcal.session.identity import same_machine

        if s.path is not None and s2.path is not None and (
                Path(s.path).resolve() == Path(s2.path).resolve()):
            raise VolcalInputError("--as-left: the as-left session is the as-found session "
                                   "itself: give the session measured after the compensation "
                                   "was loaded", s2.path)
        same, why = same_machine(s.identity, s2.identity)
        if not same:
            raise VolcalInputError(f"--as-left: the sessions are of two machines ({why})",
                                   s2.path)
    return True
