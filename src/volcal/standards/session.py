"""Evaluate a whole session to the standards: one definition of every index.

:func:`evaluate_session` is the single place where a session is evaluated: ISO 230-2 for
every linear test with runs and directions, ISO 230-6 for every diagonal, and, given an
identified model, the ISO 230-1 volumetric indices. The command line (``volcal evaluate
session``), the report and :class:`volcal.Calibration` all call it.

ELv (seed 002, Wang) is ``sqrt(ELx^2 + ELy^2 + ELz^2)`` with ``ELx = max Dx(x) - min Dx(x)``
the range of the positioning error of X over its travel (and likewise Y, Z). Measured,
``Dx(x)`` is the mean bidirectional positional deviation at each target, so ``ELx`` is
ISO 230-2's ``M`` of the axis' linear test (the first one of the session on that axis,
the planned on-axis line); when some axis has no such test and a model is given, all
three ranges come from the model's ``EXX``, ``EYY``, ``EZZ`` over the travel. Either way
it is the same quantity, and :attr:`SessionEvaluation.elv_source` says which data gave it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from volcal.standards.iso230_6 import elv as _elv

if TYPE_CHECKING:
    import pandas

__all__ = ["EvaluatedWithBudget", "LargestVolumetric", "SessionEvaluation",
           "evaluate_session", "optics_evaluation"]


@dataclass(frozen=True)
class EvaluatedWithBudget:
    """A test evaluated with a budget: its results and their U, stated together.

    Attributes
    ----------
    res : Iso2302Result or DiagonalResult
        Results of the test as evaluated with the budget
        (:func:`volcal.standards.iso230_2_uncertainty.evaluate_with_budget`,
        :func:`volcal.standards.iso230_6_uncertainty.evaluate_diagonal_with_budget`).
    unc : object with ``to_dict()``
        Their uncertainties (``U_<key>``, ``k``).
    corrections : dict or None
        What the budget applied to the readings (ISO 230-2 tests).
    """

    res: Any
    unc: Any
    corrections: Any = None

    def to_dict(self) -> dict[str, Any]:
        """Parameters of the test, ``U_<key>``, ``k``, ``corrections`` (JSON-friendly)."""
        out = {**self.res.to_dict(), **self.unc.to_dict()}
        if self.corrections is not None:
            out["corrections"] = self.corrections
        return out


@dataclass(frozen=True)
class LargestVolumetric:
    """The largest length of the modelled volumetric error over the work zone.

    Attributes
    ----------
    value_um : float
        ``max |e|`` over the grid [um] (the value of a volumetric tolerance ``V``).
    U_um : float or None
        Its expanded uncertainty [um] (None when the model has no covariance).
    n : int
        Grid points per axis.
    uncertainty : IndexUncertainty or None
        :func:`volcal.standards.model_uncertainty.largest_length` (noise and systematic
        parts).
    """

    value_um: float
    U_um: float | None
    n: int
    uncertainty: Any = None


@dataclass(frozen=True)
class SessionEvaluation:
    """Indices of a session: the one evaluation every output formats.

    Attributes
    ----------
    iso230_2 : dict of str to ISO 230-2 result
        Per linear measurement id (A, E, M, R, B, mean reversal [um]...); with a budget,
        the results :func:`volcal.standards.iso230_2_uncertainty.evaluate_with_budget`
        gives (the values the U belong to).
    axis : dict of str to str
        Moving axis of each evaluated linear measurement.
    iso230_6 : dict of str to ISO 230-6 result
        Per diagonal measurement id (with a budget, as
        :func:`volcal.standards.iso230_6_uncertainty.evaluate_diagonal_with_budget`).
    volumetric : VolumetricIndices or None
        ISO 230-1 volumetric indices of the model [um] (given a model), with their U
        (noise and systematic parts) in ``volumetric.uncertainty`` when asked.
    elv : dict of str to float or None
        ``ELx``, ``ELy``, ``ELz``, ``ELv`` [um] (seed 002); ``None`` when neither the
        measured lines nor a model cover the three axes.
    elv_source : str
        ``'measured'`` (ISO 230-2 ``M`` of each axis' first linear test), ``'model'``
        (ranges of EXX, EYY, EZZ) or ``''``.
    skipped : dict of str to str
        Measurements not evaluated, with the reason.
    unmeasured : list of str
        Planned measurements without readings (``Session.unmeasured``).
    edition : str
        ISO 230-2 edition of the evaluation.
    budget : Budget or None
        The uncertainty budget the tests were evaluated with.
    uncertainties : dict of str to Iso2302Uncertainty
        With a budget: U of every ISO 230-2 parameter and target, per linear test [um].
    corrections : dict of str to dict
        With a budget: what it applied to each linear test's readings (``'text'``...).
    diagonal_uncertainties : dict of str to DiagonalUncertainty
        With a budget: U of every diagonal's E_D [um].
    optics : dict or None
        :func:`volcal.standards.optics.evaluate_optics` of the direct optics (with a
        budget, their ``U_<key>`` beside the values); None without straightness or
        angular readings.
    largest_volumetric : LargestVolumetric or None
        With a model and ``work_zone_n``: the largest length of the modelled volumetric
        error over the work-zone grid with its U (noise and systematic parts), the value
        of a volumetric tolerance.
    optics_evaluated : bool
        Whether the direct optics were evaluated (``evaluate_session(..., optics=True)``;
        otherwise ``optics`` is None without looking).
    rotary : dict of str to RotaryIso2302Result
        ISO 230-2 of every rotary test [urad], per measurement id (with U given a budget;
        :mod:`volcal.standards.iso230_2_rotary`).
    """

    iso230_2: dict[str, Any] = field(default_factory=dict)
    axis: dict[str, str] = field(default_factory=dict)
    iso230_6: dict[str, Any] = field(default_factory=dict)
    volumetric: Any = None
    elv: dict[str, float] | None = None
    elv_source: str = ""
    skipped: dict[str, str] = field(default_factory=dict)
    unmeasured: list[str] = field(default_factory=list)
    edition: str = "2014"
    budget: Any = field(default=None, repr=False)
    uncertainties: dict[str, Any] = field(default_factory=dict, repr=False)
    corrections: dict[str, dict[str, Any]] = field(default_factory=dict, repr=False)
    diagonal_uncertainties: dict[str, Any] = field(default_factory=dict, repr=False)
    optics: dict[str, Any] | None = field(default=None, repr=False)
    largest_volumetric: LargestVolumetric | None = field(default=None, repr=False)
    optics_evaluated: bool = field(default=False, repr=False)
    rotary: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def with_budget(self) -> dict[str, EvaluatedWithBudget]:
        """Every test evaluated with the budget, its results and U together, by id.

        Empty without a budget. Linear tests carry ``corrections``; diagonals do not.
        """
        out: dict[str, EvaluatedWithBudget] = {
            k: EvaluatedWithBudget(self.iso230_2[k], u, self.corrections.get(k))
            for k, u in self.uncertainties.items()}
        out.update({k: EvaluatedWithBudget(self.iso230_6[k], u)
                    for k, u in self.diagonal_uncertainties.items()})
        return out

    @property
    def corrections_text(self) -> str:
        """What the budget applied to the readings, one sentence ('' without a budget).

        The sentence of the last linear test without its per-test largest correction
        (the same for every test of a session).
        """
        texts = [c["text"].split("; correction at")[0] for c in self.corrections.values()]
        return texts[-1] if texts else ""

    @property
    def model_indices(self) -> dict[str, Any] | None:
        """Straightness [um] and squareness [urad] of the model with U, JSON-friendly.

        ``{'straightness': {name: {'value_um', 'U_um', ...}}, 'squareness': {name:
        {'value_urad', 'U_urad', ...}}}``; None without a model uncertainty.
        """
        u = getattr(self.volumetric, "uncertainty", None)
        if u is None:
            return None
        return {"straightness": {k: {"value_um": v.value, "U_um": v.U, "u_um": v.u,
                                     "u_noise_um": v.u_noise, "u_sys_um": v.u_sys,
                                     "k": v.k, "reference": "least_squares"}
                                 for k, v in u.straightness.items()},
                "squareness": {k: {"value_urad": v.value, "U_urad": v.U, "u_urad": v.u,
                                   "u_noise_urad": v.u_noise, "u_sys_urad": v.u_sys,
                                   "k": v.k} for k, v in u.squareness.items()}}

    @property
    def incomplete(self) -> list[str]:
        """Ids of the evaluated tests with missed readings (linear and diagonal)."""
        return [k for k, v in [*self.iso230_2.items(), *self.iso230_6.items()]
                if not getattr(v, "complete", True)]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (values [um])."""
        return {"measurements": {k: {"axis": self.axis[k], **v.to_dict()}
                                 for k, v in self.iso230_2.items()},
                "diagonals": {k: _plain(v) for k, v in self.iso230_6.items()},
                "volumetric": None if self.volumetric is None else self.volumetric.to_dict(),
                **({} if self.model_indices is None else self.model_indices),
                "ELv": None if self.elv is None else self.elv["ELv"],
                "elv": self.elv, "elv_source": self.elv_source,
                "skipped": list(self.skipped), "incomplete": self.incomplete,
                "unmeasured": list(self.unmeasured),
                **({"rotary": {k: v.to_dict() for k, v in self.rotary.items()}}
                   if self.rotary else {})}

    def to_rows(self, table: str = "iso230-2") -> list[dict[str, Any]]:
        """One table of the evaluation, one row per measurement.

        Parameters
        ----------
        table : str
            ``'iso230-2'`` (linear tests: ``id``, ``axis``, ``A_um`` ... ``B_mean_um``
            [um]) or ``'iso230-6'`` (diagonals: ``id``, ``diagonal``, ``length_mm``,
            ``E_D_um`` ...); see :func:`volcal.io.frames.session_rows`.

        Returns
        -------
        list of dict
        """
        from volcal.io.frames import session_rows

        return session_rows(self, table)

    def to_dataframe(self, table: str = "iso230-2") -> pandas.DataFrame:
        """:meth:`to_rows` as a pandas DataFrame (needs pandas).

        Parameters
        ----------
        table : str
            ``'iso230-2'`` or ``'iso230-6'``.

        Returns
        -------
        pandas.DataFrame
        """
        from volcal.io.frames import to_dataframe

        return to_dataframe(self.to_rows(table), "SessionEvaluation")

    def __repr__(self) -> str:
        """Short one-line description."""
        ev = "None" if self.elv is None else f"{self.elv['ELv']:.3f} um ({self.elv_source})"
        return (f"SessionEvaluation({len(self.iso230_2)} linear, {len(self.iso230_6)} "
                f"diagonal, ELv={ev}, skipped={len(self.skipped)})")


def _plain(v: Any) -> Any:
    if hasattr(v, "to_dict"):
        return v.to_dict()
    from dataclasses import asdict, is_dataclass

    if is_dataclass(v) and not isinstance(v, type):
        import numpy as np

        return {k: (x.tolist() if isinstance(x, np.ndarray) else x)
                for k, x in asdict(v).items()}
    return v


def _runs_per_direction(m: Any) -> int:
    """The fewest distinct runs of a test in one approach direction (readings present)."""
    import numpy as np

    run = np.asarray(m.columns["run"])
    direction = np.asarray(m.columns["direction"])
    counts = [len(np.unique(run[direction == d])) for d in np.unique(direction)]
    return min(counts) if counts else 0


def evaluate_session(session: Any, result: Any = None, edition: str = "2014",
                     model_uncertainty: bool = False, *, budget: Any = None,
                     work_zone_n: int | None = None, optics: bool = False
                     ) -> SessionEvaluation:
    """Evaluate every test of a session to its standard, once (one definition of every index).

    The command line (``volcal evaluate session``, ``volcal report``), the report, the
    certificate and :class:`volcal.Calibration` format what this returns: none of them
    evaluates a test again. The verdicts are computed from it
    (:func:`volcal.standards.verdict.verdicts`).

    Parameters
    ----------
    session : Session
        The session (measurements without readings are skipped and listed).
    result : IdentificationResult, optional
        Identified model: adds the volumetric indices and the model's ELv when the
        measured lines do not cover the three axes.
    edition : str
        ISO 230-2 edition (``'2014'``, ``'2006'``, ``'1997'``).
    model_uncertainty : bool
        With ``result``: the expanded uncertainty of the volumetric indices (``U_E_VX``
        ... in ``volumetric.to_dict()``), of the straightness and squareness of the model
        (:attr:`SessionEvaluation.model_indices`) from the model's covariance, noise and
        systematic parts (:mod:`volcal.standards.model_uncertainty`; about a second).
    budget : Budget, optional
        Uncertainty budget (:func:`volcal.uncertainty.budget.read_budget`): every linear
        test is evaluated with it (:func:`volcal.standards.iso230_2_uncertainty.
        evaluate_with_budget`: its results and the U of every parameter and target),
        likewise every diagonal (:func:`volcal.standards.iso230_6_uncertainty.
        evaluate_diagonal_with_budget`) and the direct optics' U.
    work_zone_n : int, optional
        With ``result``: the largest length of the modelled volumetric error over an
        ``n``-per-axis grid of the work zone with its U
        (:attr:`SessionEvaluation.largest_volumetric`, the value of a volumetric
        tolerance).
    optics : bool
        Also evaluate the direct optics (:attr:`SessionEvaluation.optics`, with U given a
        budget), as the report and the certificate state them.

    Returns
    -------
    SessionEvaluation

    Notes
    -----
    Each linear test is evaluated to ISO 230-2 exactly once
    (:func:`volcal.standards.iso230_2.evaluate`, directly or inside
    ``evaluate_with_budget``).

    A linear test with missed captures is evaluated per target over the runs that reached
    it and marked incomplete (``complete``, ``missing``, ``notes`` of its result); an
    incomplete diagonal is marked likewise (:mod:`volcal.standards.iso230_6`). A test with
    too few captures left for any evaluation (e.g. one run in a direction) is listed in
    ``skipped`` with the reason, and the others are evaluated; so is a test planned with
    one run per direction (``volcal plan --runs 1``: its readings serve the
    identification, not ISO 230-2).

    ELv = sqrt(ELx^2 + ELy^2 + ELz^2), ELx = max Dx(x) - min Dx(x) (seed 002); see the
    module docstring for the measured and model sources.

    References
    ----------
    ISO 230-2:2014, Test code for machine tools, part 2: positioning accuracy.
    ISO 230-6:2002, diagonal displacement tests. ISO 230-1:2012, Annex (volumetric
    indices). Seed 002 (ELv).
    """
    from volcal.errors import VolcalInputError
    from volcal.session.kinds import kind_of
    from volcal.standards.runs import MIN_RUNS

    lin: dict[str, Any] = {}
    axis: dict[str, str] = {}
    diag: dict[str, Any] = {}
    uncs: dict[str, Any] = {}
    corrs: dict[str, dict[str, Any]] = {}
    duncs: dict[str, Any] = {}
    skipped: dict[str, str] = {}
    rotary: dict[str, Any] = {}
    for m in session.measurements:
        if m.deviation is None:
            skipped[m.id] = "no readings yet"
            continue
        kind = kind_of(m.kind)
        standard = kind.standard  # which standard evaluates it (volcal.kinds)
        if standard not in ("ISO 230-2", "ISO 230-6"):
            continue
        if standard == "ISO 230-2" and ("run" not in m.columns or "direction" not in m.columns):
            skipped[m.id] = "no run/direction columns"
            continue
        if standard == "ISO 230-2" and (few := _runs_per_direction(m)) < MIN_RUNS:
            skipped[m.id] = (f"{few} run per direction as planned: ISO 230-2 needs at least "
                             f"{MIN_RUNS} to estimate the repeatability (it asks for 5)"
                             + ("; its readings still enter the identification"
                                if kind.in_design else ""))
            continue
        try:
            own = (kind.evaluate_positioning(m, edition, budget) if standard == "ISO 230-2"
                   else None)  # a rotary axis evaluates its angles itself
            if own is not None:
                rotary[m.id] = own
            elif standard == "ISO 230-2":
                lin[m.id], unc, corr, axis[m.id] = _linear(m, session.path, edition, budget)
                if unc is not None:
                    uncs[m.id], corrs[m.id] = unc, corr
            else:
                diag[m.id], dunc = _diagonal(m, edition, budget)
                if dunc is not None:
                    duncs[m.id] = dunc
        except VolcalInputError as exc:
            if not m.meta.get("_missed"):
                raise
            skipped[m.id] = f"too many missed captures: {exc.message}"
    elv, elv_source = _measured_elv(lin, axis)
    volumetric = largest = None
    if result is not None:
        from volcal.standards.volumetric import elv_from_model, volumetric_indices

        volumetric = volumetric_indices(result.errors)
        if model_uncertainty:
            from volcal.standards.model_uncertainty import model_uncertainty as _mu

            volumetric.uncertainty = _mu(result, n=volumetric.n)
        if elv is None:
            elv, elv_source = elv_from_model(result.errors), "model"
        if work_zone_n is not None:
            largest = _largest_volumetric(result, int(work_zone_n))
    return SessionEvaluation(
        lin, axis, diag, volumetric, elv, elv_source, skipped,
        [m.id for m in getattr(session, "unmeasured", [])], str(edition), budget, uncs,
        corrs, duncs, optics_evaluation(session, budget) if optics else None, largest,
        bool(optics), rotary)


def _linear(m: Any, folder: Any, edition: str, budget: Any) -> tuple[Any, Any, Any, str]:
    """ISO 230-2 of one linear test (with its U and corrections given a budget), its axis."""
    from volcal.standards import iso230_2
    from volcal.standards.positioning_data import from_measurement

    d = from_measurement(m, folder)
    if budget is None:
        res = iso230_2.evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, edition,
                                **d.evaluate_kwargs())
        return res, None, None, d.axis or "?"
    from volcal.standards.iso230_2_uncertainty import evaluate_with_budget

    res, unc, corr = evaluate_with_budget(d, budget, edition)
    return res, unc, corr, d.axis or "?"


def _diagonal(m: Any, edition: str, budget: Any) -> tuple[Any, Any]:
    """ISO 230-6 of one diagonal (with its U given a budget)."""
    if budget is None:
        from volcal.standards.iso230_6 import evaluate_diagonal

        return evaluate_diagonal(m, edition), None
    from volcal.standards.iso230_6_uncertainty import evaluate_diagonal_with_budget

    return evaluate_diagonal_with_budget(m, budget, edition)


def _measured_elv(lin: dict[str, Any], axis: dict[str, str]
                  ) -> tuple[dict[str, float] | None, str]:
    """Seed 002's ELv of the first linear test of each axis (None unless all three)."""
    first: dict[str, float] = {}
    for mid, r in lin.items():
        first.setdefault(axis[mid], float(r.M))
    if not all(a in first for a in "XYZ"):
        return None, ""
    elv = {"ELx": first["X"], "ELy": first["Y"], "ELz": first["Z"]}
    elv["ELv"] = _elv(first["X"], first["Y"], first["Z"])
    return elv, "measured"


def _largest_volumetric(result: Any, n: int) -> LargestVolumetric:
    """Largest length of the model's volumetric error over the grid, with U when it can."""
    import numpy as np

    from volcal.model.kinematics import volumetric_error
    from volcal.standards.model_uncertainty import has_covariance, largest_length
    from volcal.standards.volumetric import work_zone_grid

    q = work_zone_grid(result.errors.travel, n)  # the model's work zone, as the verdict
    value = float(np.linalg.norm(volumetric_error(result.errors, q), axis=1).max())
    unc = largest_length(result, q) if has_covariance(result) else None
    return LargestVolumetric(value, None if unc is None else unc.U, n, unc)


def optics_evaluation(session: Any, budget: Any = None) -> dict[str, Any] | None:
    """The direct optics' ISO 230-1 evaluation, with U given a budget.

    Parameters
    ----------
    session : Session
        The session.
    budget : Budget, optional
        Uncertainty budget (its ``[optics]`` section, data-sheet defaults when absent):
        ``U_<key>`` beside every value (:func:`volcal.standards.optics_uncertainty.
        add_optics_uncertainty`).

    Returns
    -------
    dict or None
        :func:`volcal.standards.optics.evaluate_optics`; None when the session has no
        straightness or angular readings.
    """
    from volcal.standards.optics import evaluate_optics

    ev = evaluate_optics(session)
    if not (ev["straightness"] or ev["angular"]):
        return None
    if budget is not None:
        from volcal.standards.optics_uncertainty import (
            add_optics_uncertainty,
            optics_uncertainty,
        )

        add_optics_uncertainty(ev, optics_uncertainty(session, budget, ev))
    return ev
