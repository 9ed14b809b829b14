"""``identify(session)``: one estimator for any combination of tests.

Flow: choose nodes -> assemble the observation system (:mod:`.design`) -> smoothness
prior (:mod:`.prior`) -> evidence-optimised Bayesian least squares (:mod:`.solver`) ->
identifiability report (:mod:`.identifiability`) -> residual check -> result
(:mod:`.result`). See ``docs/identification.md``.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.identify.between import between_factor, fitted_prior
from volcal.identify.design import (
    Design,
    build_design,
    choose_nodes,
    coarsen,
    known_functions,
    visited_positions,
)
from volcal.identify.identifiability import analyse
from volcal.identify.prior import PriorStructure
from volcal.identify.record import FitRecord, session_identity
from volcal.identify.result import IdentificationResult
from volcal.identify.settings import EstimatorSettings
from volcal.identify.settings_file import changed_settings
from volcal.identify.solver import Solution, covariance_roll_weight, solve_bayes, solve_min_norm
from volcal.model.names import ROLL_NAMES
from volcal.session.format import Measurement, Session
from volcal.session.kinds import kind_of

if TYPE_CHECKING:
    from volcal.identify.between_share import BetweenForecast

__all__ = ["IdentifyOptions", "advise", "default_outlier_threshold", "identify",
           "standardised_residuals"]


@dataclass
class IdentifyOptions:
    """Options of :func:`identify`.

    Attributes
    ----------
    prior : str
        ``'smooth'`` (Bayesian, smoothness prior, default) or ``'none'`` (minimum-norm
        least squares on the node values).
    noise_um : float, optional
        Stated repeatability of a reading [um]; default: estimated from the data.
    scales : tuple of 4 float, optional
        Prior amplitude scales (positioning [um], straightness [um], roll [urad], tilts
        [urad]); default: estimated (maximum evidence).
    kappa : float
        Curvature scale of the smoothness prior.
    squareness_std_urad : float
        Prior standard deviation of the squareness errors [urad].
    roll : str
        ``'estimate'`` (default; the prior keeps it finite when the data do not see it)
        or ``'zero'`` (the rolls EAX, EBY, ECZ fixed to zero, as the seeds assume).
    known : dict
        Errors measured separately: name -> ``(positions [mm], values)`` held fixed, or
        ``(positions, values, std)`` used as a prior with that standard uncertainty; a
        position array of None means the function is zero.
    zero : tuple of str
        Functions held at zero (e.g. all angular errors, to reproduce the small-angle
        assumption of the classic step-diagonal solution).
    tilts : bool
        Estimate the beam/mirror tilt of each measurement (default). False assumes a
        perfectly aligned set-up, as the classic solutions do.
    drift : bool
        Estimate a linear drift per measurement.
    refine : int
        Node refinement between measured positions.
    max_nodes : int
        Maximum nodes per axis (41: 20 mm on an 800 mm axis, finer than the smoothness the
        prior allows; beyond it a uniform grid is used, independent of the increments).
    measurement_ids : list of str, optional
        Use only these measurements.
    outlier_threshold : float, optional
        Standardised residual above which a reading is flagged; default the larger of 4
        and the Bonferroni bound for a 1 % family-wise false alarm rate over all readings.
    suggest : bool
        Try candidate extra measurements for the report.
    robust : bool
        Down-weight the readings the outlier check flags and fit again (at most
        ``settings.robust_iterations`` times): a flagged reading's noise is taken as its
        standardised residual times the others' (weight ``1/z^2``), so it enters the fit
        at one standard deviation; the readings stay in the residuals and the outlier list
        with their weight.
    blas_threads : int or None
        BLAS threads during the identification (threadpoolctl); None leaves the BLAS as
        configured. One by default: the dense algebra is a few hundred unknowns, where
        threads cost more than they save on a 2-core box (1000 increments: 2.0 s against
        2.9 s with two threads, benchmarks/README.md), and the result does not depend on
        the machine's thread count.
    settings : EstimatorSettings
        The estimator's settings (hyperprior, the rolls' prior, node grids, numerical
        limits); default volcal's (:class:`volcal.identify.settings.EstimatorSettings`).
    """

    prior: str = "smooth"
    noise_um: float | None = None
    scales: tuple[float, float, float, float] | None = None
    kappa: float = 40.0
    squareness_std_urad: float = 100.0
    roll: str = "estimate"
    known: dict = field(default_factory=dict)
    zero: tuple[str, ...] = ()
    tilts: bool = True
    drift: bool = False
    refine: int = 2
    max_nodes: int = 41
    measurement_ids: list[str] | None = None
    outlier_threshold: float | None = None
    suggest: bool = True
    robust: bool = False
    blas_threads: int | None = 1
    settings: EstimatorSettings = field(default_factory=EstimatorSettings)

    def __post_init__(self) -> None:
        if not isinstance(self.settings, EstimatorSettings):
            raise VolcalInputError("settings: expected a volcal.identify.EstimatorSettings "
                                   "(or, in volcal.steps.identify, a settings file), "
                                   f"got {type(self.settings).__name__}")


def _too_few_redundant(sol: Solution, design: Design) -> bool:
    """True when the residual degrees of freedom are too few to estimate the noise."""
    return sol.dof < max(10.0, 0.1 * design.y.size)


def _surely_redundant(design: Design) -> bool:
    """True when the readings show their own noise whatever the fit (:func:`_too_few_redundant`).

    The residual degrees of freedom ``n - edf`` are at least ``n - N`` (the effective
    number of parameters is at most the ``N`` unknowns); 1 % of ``N`` and one more are
    the margin for rounding. Then the fit need not be solved to know it.
    """
    n, N = design.A.shape
    return n - 1.01 * N - 1.0 >= max(10.0, 0.1 * design.y.size)


def _noise_note(sol: Solution, design: Design, repeatability_um: float) -> str:
    return (f"The readings have too little redundancy to show their own noise ({sol.dof:.0f} "
            f"residual degrees of freedom for {design.y.size} readings): a repeatability of "
            f"{repeatability_um:g} um is assumed; state yours with --noise-um, or "
            "repeat runs.")


def _drift_notes(session: Session, o: IdentifyOptions) -> list[str]:
    """Refuse drift where no measurement can separate it from geometry; else say where."""
    from volcal.identify.design import drift_separable

    used = [m for m in session.measurements
            if o.measurement_ids is None or m.id in o.measurement_ids]
    sep = [m.id for m in used if drift_separable(m)]
    if not sep:
        raise VolcalInputError(
            "--drift needs measurements that read the same position more than once at "
            "different times (repeated or bidirectional runs, repeated reference readings) "
            "with a time_s column: in a single pass a drift linear in time is also a function "
            "of position, so it cannot be told apart from the geometric errors (it would take "
            "the squareness and the slopes of the positioning errors). None of the "
            f"{len(used)} measurements does; identify without --drift, or repeat a reading "
            "at the start point at the end of each test.")
    other = [m.id for m in used if m.id not in sep]
    note = "Drift estimated for " + ", ".join(sep) + "."
    if other:
        note += (" Not for " + ", ".join(other) + ": each position is read once there, so "
                 "a drift cannot be told apart from the geometry.")
    return [note]


def candidate_designs(session: Session, nodes, known) -> dict[str, Design]:
    """Extra measurements to try for the identifiability report.

    The candidates are :func:`volcal.plan.additions.candidate_additions`, planned as
    ``volcal plan --add`` would plan them (so the command ``volcal advise`` prints adds
    exactly the tests it evaluated).

    Parameters
    ----------
    session : Session
        The session (travel, chain).
    nodes : list of 3 arrays
        Nodes at the measured positions.
    known : dict
        Known errors (as in the main design).

    Returns
    -------
    dict of str to Design
        Label -> design of the candidate's tests alone.
    """
    from volcal.plan.additions import candidate_additions
    from volcal.session.optics import vertical_axis

    t = session.travel
    steps = candidate_steps(nodes)
    vertical = vertical_axis(session.meta)
    # the candidates depend on the geometry alone (no reading): kept for the next
    # identification of the same travel, chain and nodes (a report's as-found and as-left,
    # Calibration, the studies); not with known errors (their values are in the design)
    key = None if known else (np.asarray(t, dtype=float).tobytes(), str(session.chain),
                              vertical, steps,
                              tuple(np.asarray(n, dtype=float).tobytes() for n in nodes))
    if key is not None:
        with _CANDIDATES_LOCK:
            kept = _CANDIDATES.get(key)
        if kept is not None:
            return dict(kept)
    out = {}
    for add in candidate_additions(t, vertical):
        ms = [Measurement(f"c-{m.id}", m.kind, m.target, m.positions, np.zeros(m.n),
                          m.beam_direction, m.tool_offset, f"c-{m.file}", m.columns, m.meta)
              for m in add.plan(t, session.chain, steps, vertical)]
        out[add.label] = build_design(Session(session.name, session.chain, t, ms), nodes, known)
    if key is not None:
        with _CANDIDATES_LOCK:
            while len(_CANDIDATES) >= _CANDIDATES_KEPT:
                _CANDIDATES.pop(next(iter(_CANDIDATES)))
            _CANDIDATES[key] = out
    return dict(out)


_CANDIDATES: dict[tuple, dict[str, Design]] = {}
"""The candidate designs of the last geometries (:func:`candidate_designs`)."""
_CANDIDATES_KEPT = 4
_CANDIDATES_LOCK = threading.Lock()


def candidate_steps(nodes) -> int:
    """Increments per test of the candidate measurements (from the analysis nodes).

    Parameters
    ----------
    nodes : list of 3 arrays
        Nodes of the analysis grid.

    Returns
    -------
    int
        Between 2 and 20: the intervals of the finest axis' nodes (an axis no test moves
        has only its two ends as nodes; taking the coarsest axis, as before session 18,
        suggested 2 increments per test after X's linear tests alone).
    """
    return max(2, min(20, max(len(n) for n in nodes) - 1))


def add_command(report, session: Session, steps: int) -> str | None:
    """The ``volcal plan --add`` command of the report's best extra measurement.

    Parameters
    ----------
    report : IdentifiabilityReport
        With its suggestions (``'<label>: volumetric ambiguity ...'``).
    session : Session
        The session (its ``path`` names the folder in the command).
    steps : int
        Increments per test of the candidates (:func:`candidate_steps`).

    Returns
    -------
    str or None
        ``volcal plan --add S --tests diagonal --tool-offset 0,0,150``; None without a
        suggestion.
    """
    return suggestion_command(report.suggestions[0], session, steps) if report.suggestions \
        else None


def suggestion_command(suggestion: str, session: Session, steps: int) -> str | None:
    """The ``volcal plan --add`` command that adds the tests of one suggestion.

    Parameters
    ----------
    suggestion : str
        A suggestion of the report (``'<label>: volumetric ambiguity ...'``).
    session : Session
        The session (its ``path`` names the folder in the command; its ``[machine]
        vertical_axis`` the direct optics).
    steps : int
        Increments per test of the candidates (:func:`candidate_steps`).

    Returns
    -------
    str or None
        ``volcal plan --add S --tests direct:level-x --steps 13``; None when no candidate
        has the suggestion's label.
    """
    from volcal.plan.additions import candidate_additions
    from volcal.session.optics import vertical_axis

    for add in candidate_additions(session.travel, vertical_axis(session.meta)):
        if suggestion.startswith(add.label + ":"):
            return add.command(session.path if session.path is not None else "SESSION", steps)
    return None


def _optic_command(report, session: Session, steps: int) -> list[str]:
    """``To add the direct optic: volcal plan --add ...`` when the best optic is not the best."""
    from volcal.plan.optics import OPTIC_LABEL

    optic = [sg for sg in report.suggestions[1:] if sg.startswith(OPTIC_LABEL)]
    if not optic or report.suggestions[0].startswith(OPTIC_LABEL):
        return []
    command = suggestion_command(optic[0], session, steps)
    return [] if command is None else [f"To add the direct optic: {command}"]


def advise(session: Session, options: IdentifyOptions | None = None):
    """Identifiability of a planned session, before anything is measured.

    The report depends only on the design (which readings, where, with which optics), so
    it can be computed from the planned poses: what the tests will determine, what they
    will not, the volumetric ambiguity and the best extra measurement. The prior scales
    are those of a typical machining centre (the centre of the hyperprior).

    Parameters
    ----------
    session : Session
        Planned (or measured) session; deviations are not used.
    options : IdentifyOptions, optional
        Known errors, roll, tilts and the like, as for :func:`identify`.

    Returns
    -------
    IdentifiabilityReport
    """
    from copy import copy

    from volcal.identify.identifiability import _reference_prior

    o = options or IdentifyOptions()
    st = o.settings
    known = known_functions(o)
    planned = copy(session)
    planned.measurements = [copy(m) for m in session.measurements]
    for m in planned.measurements:
        m.deviation = np.zeros(m.n)
    nodes_a = choose_nodes(planned, refine=1, max_nodes=min(o.max_nodes, st.analysis_max_nodes),
                           settings=st)
    design = build_design(planned, nodes_a, known, o.drift, o.measurement_ids, o.tilts)
    prior = _reference_prior(design, st)  # the hyperprior centres
    cands = candidate_designs(planned, nodes_a, known) if o.suggest else None
    report = analyse(design, prior, np.array(st.typical_scales), o.squareness_std_urad, cands,
                     settings=st)
    command = add_command(report, session, candidate_steps(nodes_a)) if o.suggest else None
    if command is not None:
        report.messages.append(f"To add it: {command}")
    if o.suggest:
        report.messages.extend(_optic_command(report, session, candidate_steps(nodes_a)))
    pos, straight, _, tilt = st.typical_scales
    report.messages.insert(0, "Before measuring: the figures assume a typical machining centre "
                              f"(prior scales: positioning {pos:g} um with a linear trend of "
                              f"{_trend_words(st)}, straightness "
                              f"{straight:g} um, roll and tilts {tilt:g} urad); the measured "
                              "data will refine them.")
    report.messages.extend(_kind_notes(design.measurements))  # what each kind adds
    report.between = _between_forecast(planned, o, known)
    if report.between is not None:
        report.messages.append(report.between.describe())
    from volcal.session.kinds import hooks_of

    for notes in hooks_of([m.kind for m in session.measurements], "advise_notes"):
        report.messages += notes(session, planned, o)  # a kind's own advice (tracker layout)
    return report


def _between_forecast(planned: Session, o: IdentifyOptions, known: dict
                      ) -> BetweenForecast | None:
    """:func:`~volcal.identify.between_share.forecast_between` on the identification's grid.

    The nodes and design :func:`identify` would use for the planned session (its fine grid:
    ``refine``, ``max_nodes``); None when the part is off or every node is read.
    """
    from volcal.identify.between_share import forecast_between

    st = o.settings
    if st.between_readings_factor <= 0:
        return None
    nodes = choose_nodes(planned, refine=o.refine, max_nodes=o.max_nodes, settings=st)
    design = build_design(planned, nodes, known, o.drift, o.measurement_ids, o.tilts)
    return forecast_between(design, st, planned.travel)


def identify(session: Session, options: IdentifyOptions | None = None) -> IdentificationResult:
    """Identify the machine's error functions from any combination of tests.

    Parameters
    ----------
    session : Session
        Measured session.
    options : IdentifyOptions, optional
        Estimator options.

    Returns
    -------
    IdentificationResult
        Functions with uncertainties, identifiability report, fit statistics, residuals.

    Notes
    -----
    The readings are modelled to first order (Soons, seed 004, eq. 1-4) with set-up
    nuisances per measurement; the gauge fixes every function to zero at the start of
    travel and the straightness functions also at the end.
    """
    o = options or IdentifyOptions()
    from volcal.identify import multilateration as _ml

    if _ml.needs_linearisation(session):  # tracker stations: Gauss-Newton around this function
        return _ml.identify_iterated(session, o, identify)
    with _blas_threads(o.blas_threads):
        result = _identify_weighted(session, o, None)
        if not o.robust:
            return result
        return _robust(session, o, result)


def _blas_threads(n: int | None):
    """Context limiting the BLAS thread pools to ``n`` threads (None: unchanged)."""
    if n is None:
        from contextlib import nullcontext

        return nullcontext()
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=int(n), user_api="blas")


def _robust(session: Session, o: IdentifyOptions,
            result: IdentificationResult) -> IdentificationResult:
    """Re-weighted fits: the readings flagged by the last fit weigh ``1/z^2``.

    See ``IdentifyOptions.robust``. A reading no longer flagged (judged by its prediction
    from the others) is back at full weight. Stops when the flagged set repeats.
    """
    weights: dict[str, NDArray[np.float64]] = {}
    seen: list[set] = []
    for _ in range(o.settings.robust_iterations):
        flagged = {(f["measurement"], f["row"]) for f in result.outliers}
        if not flagged or flagged in seen:
            break
        seen.append(flagged)
        weights = {}
        for f in result.outliers:
            w = weights.setdefault(f["measurement"],
                                   np.ones(len(result.residuals[f["measurement"]])))
            w[f["row"] - 2] = min(1.0, 1.0 / float(f["standardised"]) ** 2)
        result = _identify_weighted(session, o, weights)
    if weights:
        n_down = sum(int(np.sum(w < 1)) for w in weights.values())
        result.report.messages.append(
            f"Robust fit: {n_down} reading(s) down-weighted (weights in 'outliers'); the "
            "estimate and its uncertainty no longer lean on them.")
        for f in result.outliers:
            wm = weights.get(f["measurement"])
            f["weight"] = 1.0 if wm is None else float(wm[f["row"] - 2])
        result.fit["robust"] = {"downweighted": n_down}
    return result


def _identify_weighted(session: Session, o: IdentifyOptions,
                       weights: dict[str, NDArray[np.float64]] | None
                       ) -> IdentificationResult:
    """One fit with the given reading weights (None: all equal)."""
    known = known_functions(o)
    if o.prior not in ("smooth", "none"):
        raise VolcalInputError(f"prior must be 'smooth' or 'none', got {o.prior!r}")
    notes: list[str] = []
    if o.drift:
        notes.extend(_drift_notes(session, o))
    fit = _fit_min_norm if o.prior == "none" else _fit_smooth
    design, sol = fit(session, o, known, weights, notes)
    report = _identifiability(session, o, known, weights, design, sol)
    if o.prior == "none":
        report.messages.insert(0, "Minimum-norm least squares: combinations the data do not "
                                  "determine are set to zero and carry no uncertainty.")
    report.messages.extend(notes)
    if known:
        report.messages.append("Known errors given by the user (held fixed, or priors with "
                               "their uncertainty): " + ", ".join(design.fixed_names) + ".")
    report.messages.extend(_kind_notes(design.measurements))  # what each kind adds
    report.messages.extend(_outside_notes(session, o))
    return _result(session, design, sol, report, o)


def _trend_words(st: EstimatorSettings) -> str:
    """The positioning trend the prior assumes before measuring, in words."""
    if st.trend_per_metre:
        return f"{st.trend_centre_um_per_m:g} um per metre of travel"
    return f"{st.trend_centre_um:g} um over the travel"


def _outside_notes(session: Session, o: IdentifyOptions) -> list[str]:
    """The measurements left out for their kind, and what evaluates them instead.

    Kinds with ``in_design`` False (rotary, probe_sphere, r_test); their evaluation is
    :attr:`volcal.kinds.Kind.evaluated_by`.
    """
    from volcal.session.kinds import kind_of

    by_kind: dict[str, list] = {}
    for m in session.measurements:
        if (o.measurement_ids is None or m.id in o.measurement_ids) \
                and not kind_of(m.kind).in_design:
            by_kind.setdefault(m.kind, []).append(m)
    out = []
    for name, ms in by_kind.items():
        what = ", ".join(f"{m.id} ({name}, {m.n} readings)" for m in ms)
        how = kind_of(name).evaluated_by or "evaluated on its own"
        out.append(f"Left out of this identification of the linear axes: {what}: {how}.")
    return out


def _kind_notes(measurements: list) -> list[str]:
    """What the measurements of each kind add (:meth:`volcal.kinds.Kind.design_notes`)."""
    from volcal.session.kinds import hooks_of

    out: list[str] = []
    for notes in hooks_of([m.kind for m in measurements], "design_notes"):
        out.extend(notes(measurements))
    return out


def _fit_min_norm(session: Session, o: IdentifyOptions, known: dict, weights,
                  notes: list[str]) -> tuple[Design, Solution]:
    """Minimum-norm least squares on the visited positions (``prior='none'``).

    Appends to ``notes`` when the noise cannot be estimated and the default repeatability
    (:attr:`EstimatorSettings.default_repeatability_um`) is used instead.
    """
    st = o.settings
    nodes1 = choose_nodes(session, refine=1, max_nodes=o.max_nodes, settings=st)
    design = build_design(session, nodes1, known, o.drift, o.measurement_ids, o.tilts,
                          weights=weights)
    sol = solve_min_norm(design, o.noise_um)
    if o.noise_um is None and _too_few_redundant(sol, design):
        notes.append(_noise_note(sol, design, st.default_repeatability_um))
        sol = solve_min_norm(design, st.default_repeatability_um)
    return design, sol


def _hyper_nodes(session: Session, o: IdentifyOptions) -> list[NDArray[np.float64]]:
    """Nodes of the grid on which the hyperparameters are chosen.

    :attr:`EstimatorSettings.hyper_max_nodes` per axis, or the visited positions when the
    fine grid keeps them (:attr:`EstimatorSettings.nodes_at_readings`): a coarse uniform
    grid would put its nodes between the readings and the evidence would judge the prior
    on a misplaced grid.
    """
    st = o.settings
    n_h = st.hyper_max_nodes
    if st.nodes_at_readings:
        n_h = max([n_h, *(m for m in visited_positions(session)
                          if m <= st.visited_nodes_factor * o.max_nodes)])
    return choose_nodes(session, refine=o.refine, max_nodes=min(o.max_nodes, n_h), settings=st)


def _coarse_hyperparameters(session: Session, o: IdentifyOptions, known: dict, weights,
                            design: Design, nodes_h, noise: float | None, notes: list[str]
                            ) -> tuple[Solution, float | None]:
    """The hyperparameters chosen on the coarser grid ``nodes_h`` (fast).

    Hyperparameters are properties of the functions, not of the grid. Returns the coarse
    solution and the noise [um] (the default repeatability when the readings cannot show
    their own, with a note).
    """
    st = o.settings
    design_h = coarsen(design, nodes_h) or build_design(
        session, nodes_h, known, o.drift, o.measurement_ids, o.tilts, weights=weights)
    prior_h = PriorStructure.build(design_h.layout, design_h.free, o.kappa, settings=st)
    # the coarse estimate is not kept: solved only when its residual degrees of freedom
    # decide whether the noise can be estimated
    check = noise is None and not _surely_redundant(design_h)
    sol_h = solve_bayes(design_h, prior_h, None, noise, o.squareness_std_urad,
                        roll_presence=False, settings=st, estimate=check)
    if check and _too_few_redundant(sol_h, design_h):
        notes.append(_noise_note(sol_h, design_h, st.default_repeatability_um))
        noise = st.default_repeatability_um
        sol_h = solve_bayes(design_h, prior_h, None, noise, o.squareness_std_urad,
                            roll_presence=False, settings=st, estimate=False)
    return sol_h, noise


def _fit_smooth(session: Session, o: IdentifyOptions, known: dict, weights,
                notes: list[str]) -> tuple[Design, Solution]:
    """The Bayesian fit (``prior='smooth'``) on the fine grid.

    The hyperparameters are chosen on a coarser grid when it differs
    (:func:`_coarse_hyperparameters`), then the fine grid is solved with them,
    re-estimating the noise.
    """
    st = o.settings
    noise = o.noise_um
    nodes = choose_nodes(session, refine=o.refine, max_nodes=o.max_nodes, settings=st)
    design = build_design(session, nodes, known, o.drift, o.measurement_ids, o.tilts,
                          weights=weights)
    prior = PriorStructure.build(design.layout, design.free, o.kappa, settings=st)
    scales = None if o.scales is None else np.array(o.scales)
    tilt_std = None
    nodes_h = _hyper_nodes(session, o)
    if scales is None and any(len(a) != len(b) for a, b in zip(nodes_h, nodes, strict=True)):
        sol_h, noise = _coarse_hyperparameters(session, o, known, weights, design, nodes_h,
                                               noise, notes)
        scales = sol_h.function_scales
        tilt_std = sol_h.tilt_std_urad
        prior = (prior.with_kappa(sol_h.kappa).with_trend(sol_h.trend_um)
                 .with_kappa_factor(sol_h.kappa_factor).with_nugget(sol_h.nugget_um)
                 .with_axis_kappa(sol_h.axis_kappa).with_tilt_trend(sol_h.tilt_trend_urad))
        hyper_noise = noise if noise is not None else sol_h.sigma_um
        sol = solve_bayes(design, prior, scales, hyper_noise, o.squareness_std_urad,
                          tilt_std=tilt_std, settings=st)
        sol.convergence = dict(sol_h.convergence, grid="hyperparameters on "
                               f"{'x'.join(str(len(n)) for n in nodes_h)} nodes")
        sol.travel_exponent = sol_h.travel_exponent  # in the function scales it gave
        sol.kappa_travel_exponent = sol_h.kappa_travel_exponent  # in the axis factors
    else:
        sol = solve_bayes(design, prior, scales, noise, o.squareness_std_urad, settings=st)
    if noise is None and _too_few_redundant(sol, design):
        notes.append(_noise_note(sol, design, st.default_repeatability_um))
        noise = st.default_repeatability_um
        exponents = sol.travel_exponent, sol.kappa_travel_exponent
        sol = solve_bayes(design, prior, scales, noise, o.squareness_std_urad,
                          tilt_std=tilt_std, settings=st)
        if scales is not None:
            sol.travel_exponent, sol.kappa_travel_exponent = exponents
    return design, sol


def _identifiability(session: Session, o: IdentifyOptions, known: dict, weights,
                     design: Design, sol: Solution):
    """The identifiability report on the measured positions, with the fit's prior."""
    st = o.settings
    nodes_a = choose_nodes(session, refine=1, max_nodes=min(o.max_nodes, st.analysis_max_nodes),
                           settings=st)
    same = all(len(a) == len(b) and np.array_equal(a, b)
               for a, b in zip(nodes_a, design.layout.nodes, strict=True))
    design1 = design if same else build_design(session, nodes_a, known, o.drift,
                                               o.measurement_ids, o.tilts, weights=weights)
    kappa = sol.kappa if np.isfinite(sol.kappa) else o.kappa
    prior1 = fitted_prior(design1.layout, design1.free, sol, st, kappa)
    scales = (sol.function_scales if sol.function_scales is not None
              else sol.scales if np.all(np.isfinite(sol.scales))
              else np.array(st.typical_scales))
    cands = candidate_designs(session, nodes_a, known) if o.suggest else None
    return analyse(design1, prior1, scales, o.squareness_std_urad, cands,
                   ata=sol.ata if design1 is design else None, settings=st)


def default_outlier_threshold(n: int) -> float:
    """The default threshold of the outlier check.

    Parameters
    ----------
    n : int
        Number of readings.

    Returns
    -------
    float
        The larger of 4 and the two-sided Bonferroni bound ``-Phi^-1(0.005 / n)``: on
        clean data with normal noise, at most 1 % of sessions have a reading beyond it.
    """
    from scipy.special import ndtri

    return max(4.0, float(-ndtri(0.005 / max(n, 1))))


def _standardised(design: Design, sol: Solution, resid: NDArray[np.float64],
                  cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """Residuals over their standard deviation ``s sqrt(1 - h_ii)`` (leverage ``h``)."""
    # leverages h_i = a_i' C a_i in single precision: they only scale the residuals by
    # sqrt(1 - h), where 1e-7 relative is far below anything the threshold resolves, and
    # the product with C is the costliest step of a large session (half the memory traffic)
    A = design.reading_matrix().astype(np.float32)
    c32 = np.ascontiguousarray(cov, dtype=np.float32)
    h = np.empty(A.shape[0])
    for i in range(0, A.shape[0], 4000):
        blk = A[i:i + 4000]
        h[i:i + 4000] = np.asarray(blk.multiply(blk @ c32).sum(axis=1), dtype=float).ravel()
    sigma = max(sol.sigma_um, sol.sigma_residual_um, 1e-12)
    lev = np.clip(h / sol.sigma_um**2 if sol.method == "bayes" else h / sigma**2, 0, 0.999)
    z = resid / (sigma * np.sqrt(1 - lev))
    if design.row_scale is not None:
        # a down-weighted reading is judged by its prediction from the others:
        # residual variance s^2 + a' C a (out of sample) instead of s^2 - a' C a
        out = design.row_scale < 1.0
        z[out] = resid[out] / np.sqrt(sigma**2 + h[out])
    return z


def standardised_residuals(result: IdentificationResult) -> dict[str, NDArray[np.float64]]:
    """Standardised residual of every reading, per measurement.

    This is what the outlier check compares with its threshold.

    Parameters
    ----------
    result : IdentificationResult
        A fresh result (one returned by :func:`identify`, not loaded from a file).

    Returns
    -------
    dict of str to ndarray
        Measurement id -> residual / (noise x sqrt(1 - leverage)), one per reading; on
        clean data about N(0, 1).
    """
    design, sol = result.design, result.solution
    if design is None or sol is None or sol.covariance is None:
        raise VolcalInputError("standardised residuals need a fresh identification result")
    resid = np.concatenate([result.residuals[m.id] for m in design.measurements])
    z = _standardised(design, sol, resid, sol.covariance)
    return {m.id: z[design.rows[m.id]] for m in design.measurements}


def _covariance_factor(cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """``L`` with ``L L^T = cov``.

    Cholesky when ``cov`` is positive definite (the Bayesian posterior), else the
    eigenvectors of its positive part (minimum norm: singular).
    """
    try:
        return np.asarray(np.linalg.cholesky(cov), dtype=np.float64)  # float64 for the stubs
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(cov)
        keep = w > max(w.max(), 1e-300) * 1e-12
        return V[:, keep] * np.sqrt(w[keep])


def _result(session: Session, design: Design, sol: Solution, report, o: IdentifyOptions
            ) -> IdentificationResult:
    nf = design.n_free
    theta = design.full_parameters(sol.x)
    errors = design.layout.unpack(theta, design.chain, name=session.name)
    cov = sol.covariance
    if cov is None:
        raise VolcalInputError("problem too large for the dense covariance: reduce --max-nodes "
                               "or the number of measurements")
    cff = cov[:nf, :nf]
    factor = _covariance_factor((cff + cff.T) / 2)
    between = between_factor(design, sol, o.settings)  # a part of its own, beside the noise
    var_full = np.zeros(design.layout.size)
    var_full[design.free] = np.clip(np.diag(cff), 0, None)
    if between is not None:
        var_full[design.free] += np.sum(between**2, axis=1)
    sd = np.sqrt(var_full)
    std = [sd[design.layout.starts[k]:design.layout.starts[k + 1]].reshape(-1, 6)
           for k in range(3)]
    sq_std = sd[design.layout.squareness_indices()]
    mean = design.prior_mean if design.prior_mean is not None else np.zeros(sol.x.size)
    resid_all = design.y - design.A @ (sol.x - mean)
    if design.row_scale is not None:  # robust fit: residuals of the readings themselves
        resid_all = resid_all / design.row_scale
    residuals, fitted = {}, {}
    for m in design.measurements:
        sl = design.rows[m.id]
        r = resid_all[sl]
        w = kind_of(m.kind).row_weight(m)  # weighted rows: back to the readings' unit
        if w != 1.0:
            r = r / w
        residuals[m.id] = r
        fitted[m.id] = m.deviation - r
    z = _standardised(design, sol, resid_all, cov)
    thr = o.outlier_threshold
    if thr is None:
        thr = default_outlier_threshold(z.size)
    outliers = []
    for m in design.measurements:
        sl = design.rows[m.id]
        for i in np.flatnonzero(np.abs(z[sl]) > thr):
            outliers.append({"measurement": m.id, "row": int(i) + 2,
                             "residual_um": float(resid_all[sl][i]),
                             "standardised": float(z[sl][i])})
    if outliers:
        report.messages.append(
            f"{len(outliers)} reading(s) have standardised residuals above "
            f"{thr:.2f} (see 'outliers'): check them for set-up faults.")
    nuis = {}
    for j, name in enumerate(design.nuisance_names):
        nuis[name] = (float(sol.x[nf + j]), float(np.sqrt(max(cov[nf + j, nf + j], 0))))
    fit: dict[str, Any] = {
        "method": sol.method,
        "n_readings": int(design.y.size),
        "n_parameters": int(nf),
        "n_nuisance": int(design.n_nuisance),
        "sigma_um": float(sol.sigma_um),
        "sigma_residual_um": float(sol.sigma_residual_um),
        "dof": float(sol.dof),
        "prior_scales": {"positioning_um": _fin(sol.scales[0]),
                         "straightness_um": _fin(sol.scales[1]),
                         "roll_urad": _fin(sol.scales[2]), "tilt_urad": _fin(sol.scales[3]),
                         "kappa": _fin(sol.kappa),
                         # the trend at the end of the longest axis' travel [um], and the
                         # evidence's scale per metre of travel when it is one
                         # (EstimatorSettings.trend_per_metre)
                         "positioning_trend_um": (_fin(sol.trend_um * max(sol.trend_length))
                                                  if sol.trend_um else None),
                         "positioning_trend_um_per_m": (
                             _fin(sol.trend_um) if sol.trend_um
                             and o.settings.trend_per_metre else None),
                         "positioning_nugget_um": (_fin(sol.nugget_um) if sol.nugget_um
                                                   else None),
                         "tilt_trend_urad": (_fin(sol.tilt_trend_urad) if sol.tilt_trend_urad
                                             else None),
                         # each group set's travel exponent (EstimatorSettings.
                         # travel_exponent_*): a function's scale is its group's times
                         # (L_axis / L_mean)^exponent; None when not searched
                         "travel_exponent": ([_fin(v) for v in sol.travel_exponent]
                                             if sol.travel_exponent else None),
                         "travel_exponent_groups": (
                             [list(g) for g in o.settings.travel_exponent_groups]
                             if sol.travel_exponent else None),
                         # each axis' curvature factor (EstimatorSettings.
                         # kappa_travel_exponent_spread, axis_kappa_spread)
                         "kappa_axis": ([_fin(v) for v in sol.axis_kappa]
                                        if any(v != 1.0 for v in sol.axis_kappa) else None),
                         # the factors' travel exponent: (L_axis / L_mean)^exponent
                         "kappa_travel_exponent": (_fin(sol.kappa_travel_exponent)
                                                   if sol.kappa_travel_exponent is not None
                                                   else None),
                         "setup_tilt_urad": (_fin(sol.tilt_std_urad)
                                             if sol.tilt_std_urad is not None else None)},
        "convergence": dict(sol.convergence),
        "log_evidence": _fin(sol.log_evidence),
        # the rolls' presence: Bayes factor and the two-model average (settings.roll_mixture_*)
        "roll_presence": ({"log_bayes_factor": _fin(sol.roll_log_bayes_factor),
                           "probability": (None if sol.roll_probability is None
                                           else float(sol.roll_probability)),
                           "prior_probability_absent": float(o.settings.roll_mixture_absent),
                           # the rolls' weight in the uncertainty (roll_mixture_covariance)
                           "uncertainty_weight": (
                               None if sol.roll_probability is None else covariance_roll_weight(
                                   o.settings.roll_mixture_covariance,
                                   float(sol.roll_log_bayes_factor),
                                   float(sol.roll_probability),
                                   o.settings.roll_covariance_absent))}
                          if sol.roll_log_bayes_factor is not None else None),
        "measurements": [m.id for m in design.measurements],
        "known": sorted(design.fixed_names),
        "gauge": "every function zero at the start of travel; straightness also at the end",
        # what the session reader noted (unmeasured, missed captures) and flagged as implausible
        "notes": [*session.notes, *(f"warning: {w}" for w in session.warnings)],
    }
    changed = changed_settings(o.settings)
    if changed:  # what differs from volcal's estimator, so that the fit can be repeated
        fit["estimator_settings"] = changed
    if sol.method == "bayes":
        report.messages.extend(_roll_messages(sol, std, o.settings,
                                              _roll_prior_rms(design, sol, o.settings)))
    return IdentificationResult(session.name, errors, design.layout, design.free, factor, std,
                                sq_std, report, FitRecord.from_dict(fit), residuals, fitted,
                                nuis, outliers,
                                design=design, solution=sol, between_factor=between,
                                session=session_identity(session))


def _roll_prior_rms(design: Design, sol: Solution, settings: EstimatorSettings
                    ) -> list[float | None]:
    """RMS prior standard deviation of each roll over its nodes [urad] (None: not estimated).

    The fit's prior (its hyperparameters) on the fit's nodes, the gauge node at zero as in
    the posterior's; what a roll's uncertainty is when no reading sees it.
    """
    if sol.function_scales is None:
        return [None, None, None]
    prior = fitted_prior(design.layout, design.free, sol, settings)
    out: list[float | None] = [None, None, None]
    for b, block in enumerate(prior.blocks):
        k, c = divmod(block[-1], 6)
        if c == 3 + k:
            var = np.diag(np.linalg.inv(prior.block_precision(b, sol.function_scales)))
            out[k] = float(np.sqrt(np.sum(var) / len(design.layout.nodes[k])))
    return out


def _roll_messages(sol: Solution, std, settings: EstimatorSettings,
                   prior_rms: list[float | None]) -> list[str]:
    """What the report says about the rolls: their uncertainty and their presence.

    Parameters
    ----------
    sol : Solution
        The Bayesian solution (its scales, the rolls' Bayes factor and weight).
    std : list of 3 ndarray
        Standard uncertainty of every function at the nodes, per axis [um, urad].
    settings : EstimatorSettings
        Its ``no_roll_note_factor``.
    prior_rms : list of 3 float or None
        Each roll's RMS prior standard deviation over the same nodes [urad]
        (:func:`_roll_prior_rms`).

    Returns
    -------
    list of str
    """
    out: list[str] = []
    roll_u = [float(np.sqrt(np.mean(std[k][:, 3 + k] ** 2))) for k in range(3)]
    out.append(
        "Rolls as measured (RMS standard uncertainty over the travel, noise included; in "
        "brackets the fitted prior's alone, what no reading of the roll leaves): "
        + ", ".join(f"{n} {u:.1f} urad" + ("" if p is None else f" (prior {p:.1f})")
                    for n, u, p in zip(ROLL_NAMES, roll_u, prior_rms, strict=True))
        + "; near the prior means not measured by these tests, whatever share the design "
        "could determine without noise.")
    lbf = sol.roll_log_bayes_factor
    if lbf is not None and -lbf > np.log(settings.no_roll_note_factor):
        p_roll = sol.roll_probability
        lean = ("the estimate is the average of the fits with and without rolls, "
                f"weighted {p_roll:.2g} / {1 - p_roll:.2g}, and keeps the uncertainty "
                "of rolls of the prior's size" if p_roll is not None else
                "the rolls are kept, as the prior allows them")
        out.append(
            f"The readings favour a machine without roll errors by a factor of "
            f"{np.exp(min(-lbf, 700.0)):.3g} over rolls of the prior's size (Bayes factor; "
            f"{lean}). If this machine is known to "
            "have no roll, identify with --roll zero (Python: roll='zero'), which leaves "
            "the other functions better determined; a level on each horizontal axis "
            "measures the rolls instead (volcal advise).")
    elif lbf is not None and sol.roll_probability is not None and sol.roll_probability < 0.99:
        p_roll = sol.roll_probability
        out.append(
            "The readings do not settle whether this machine has roll errors (Bayes "
            f"factor {np.exp(np.clip(lbf, -700.0, 700.0)):.3g} for rolls of the prior's "
            "size over none): the estimate is the average of the fits with and without "
            f"rolls, weighted {p_roll:.2g} / {1 - p_roll:.2g}, with the uncertainty of "
            "the fit with rolls. A level on each horizontal axis measures the rolls "
            "(volcal advise).")
    return out


def _fin(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def monte_carlo(result: IdentificationResult, q: NDArray[np.float64], n: int = 200,
                seed: int | None = 0, tool_offset=None):
    """Monte Carlo propagation of the reading noise to predicted volumetric errors.

    GUM Supplement 1 (JCGM 101:2008): the readings are redrawn ``n`` times with the
    estimated noise around the observed values and re-identified with the same
    hyperparameters; the spread of the predictions is the noise part of the uncertainty
    (the prior part of undetermined combinations is not resampled).

    Parameters
    ----------
    result : IdentificationResult
        A fresh result (with its design and solution).
    q : ndarray, shape (m, 3)
        Points [mm].
    n : int
        Number of trials.
    seed : int, optional
        Random seed.
    tool_offset : array_like, optional
        Tool offset [mm].

    Returns
    -------
    mean, std : ndarray, shape (m, 3)
        Mean and standard deviation of the predictions [um].
    low, high : ndarray, shape (m, 3)
        Probabilistically symmetric 95 % coverage interval [um].
    """
    design, sol = result.design, result.solution
    if design is None or sol is None or sol.solve is None:
        raise VolcalInputError("Monte Carlo needs a fresh identification (not a loaded model)")
    from volcal.model.kinematics import pose_jacobian

    rng = np.random.default_rng(seed)
    Je, _ = pose_jacobian(result.errors.chain_obj.order, design.layout.nodes, q, tool_offset)
    mean = design.prior_mean if design.prior_mean is not None else np.zeros(sol.x.size)
    base = design.y  # the observed readings, redrawn with the reading noise
    sig = sol.sigma_um
    At = design.A.T.tocsr()
    out = []
    for _ in range(n):
        ystar = base + rng.normal(0, sig, base.size)
        x = sol.solve(At @ ystar / sig**2) + mean
        theta = design.full_parameters(x)
        out.append((Je @ theta).reshape(-1, 3))
    arr = np.array(out)
    return arr.mean(0), arr.std(0, ddof=1), np.percentile(arr, 2.5, 0), np.percentile(arr, 97.5, 0)
