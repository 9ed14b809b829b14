"""Estimators over the assembled observation system.

* ``prior='smooth'`` (default): Bayesian least squares with the smoothness prior of
  :mod:`volcal.identify.prior`. The amplitude scales of the four function groups
  (positioning, straightness, roll, tilts), the curvature scale and the reading noise
  are chosen by maximising the marginal likelihood (type-II maximum likelihood,
  "evidence"; MacKay 1992, Rasmussen & Williams 2006 ch. 5) under a weak log-normal
  hyperprior, with a quasi-Newton optimiser (L-BFGS-B) whose convergence is recorded.
  ``A^T A`` is formed once; each evaluation factorises the dense posterior precision
  ``H = A^T A / sigma^2 + Q`` (Cholesky; a few hundred to ~1500 unknowns with the node grid
  capped by ``IdentifyOptions.max_nodes``), so the cost does not grow with the number of
  readings. Small problems are solved by QR of the stacked system so that noise-free data
  are fitted to numerical precision; larger ones by Cholesky with iterative refinement.
  The rolls, which the usual tests see only through lever arms, take the tilts' scale
  times a fixed factor, and the estimate averages the fits with and without rolls by
  their Bayes factor (Kass & Raftery 1995; Hoeting et al. 1999).
* ``prior='none'``: minimum-norm least squares on the node values (the floor any
  estimator must beat), uncertainty ``s^2 (A^T A)^+``.

Every tuning constant is a field of :class:`volcal.identify.settings.EstimatorSettings`;
the measurements that chose them are in ``benchmarks/README.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.optimize import minimize

from volcal.identify.design import Design
from volcal.identify.evidence import (  # noqa: F401  (re-exported for tests and callers)
    AXIS_KAPPA,
    N_HYPER,
    NUISANCE_PRECISION,
    TILT_TREND,
    _Evidence,
    _inverse_from_cholesky,
    _nuisance_precision,
)
from volcal.identify.prior import (
    GROUPS,
    TREND_FUNCTIONS,
    PriorStructure,
    function_group,
    function_scales,
)
from volcal.identify.settings import EstimatorSettings

__all__ = ["Solution", "covariance_roll_weight", "solve_bayes", "solve_min_norm"]

FREE_GROUPS: tuple[int, ...] = (0, 1, 3)
"""Groups of :data:`volcal.identify.prior.GROUPS` with a scale of their own in the
evidence; the roll (group 2) takes the tilts' scale (lines, diagonals and step diagonals
see the rolls only through a few lever arms, too little for the evidence to set their
scale), times :attr:`EstimatorSettings.roll_factor`."""

ROLL_FUNCTIONS: tuple[int, ...] = (3, 10, 17)
"""Function indices ``6 * axis + component`` of the rolls EAX, EBY, ECZ."""


@dataclass
class Solution:
    """Estimate of all unknowns (free function parameters, then nuisances).

    Attributes
    ----------
    x : ndarray
        Estimate [um, urad].
    covariance : ndarray or None
        Posterior covariance of ``x`` (dense), None when too large.
    sigma_um : float
        Reading noise used (estimated or stated) [um].
    sigma_residual_um : float
        RMS residual corrected for the effective number of parameters [um].
    scales : ndarray, shape (4,)
        Prior amplitude scales (positioning [um], straightness [um], roll [urad], tilts
        [urad]).
    kappa : float
        Curvature scale of the prior.
    log_evidence : float
        Log marginal likelihood at the optimum (nan for min-norm).
    dof : float
        Residual degrees of freedom ``n - trace(hat matrix)``.
    method : str
        ``'bayes'`` or ``'min-norm'``.
    solve : callable or None
        ``rhs -> H^-1 rhs`` with the factorised posterior precision (Monte Carlo).
    function_scales : ndarray, shape (18,) or None
        Prior amplitude scale of each function, ``6 * axis + component`` [um, urad].
    ata : ndarray or None
        ``A^T A`` of the design (dense), for the identifiability report.
    tilt_std_urad : float or None
        Prior standard deviation of the set-up tilts (beam and mirror) [urad]; None when
        the design has none.
    trend_um : float
        Prior standard deviation of the positioning errors' linear trend at the end of
        travel [um], or per metre of travel [um/m] (:attr:`trend_length`;
        :attr:`volcal.identify.prior.PriorStructure.trend_um`; 0: none).
    trend_length : tuple of 3 float
        Each axis' factor on ``trend_um``
        (:attr:`volcal.identify.prior.PriorStructure.trend_length`).
    tilt_trend_urad : float
        Prior standard deviation of the tilts' linear part at the end of travel [urad]
        (:attr:`volcal.identify.prior.PriorStructure.tilt_trend_urad`; 0: none).
    axis_kappa : tuple of 3 float
        Each axis' curvature factor
        (:attr:`volcal.identify.prior.PriorStructure.axis_kappa`).
    kappa_factor : tuple of 4 float
        Curvature scale of each prior group relative to ``kappa``
        (:attr:`volcal.identify.prior.PriorStructure.kappa_factor`).
    nugget_um : float
        Short-wavelength part of the positioning errors [um]
        (:attr:`volcal.identify.prior.PriorStructure.nugget_um`; 0: none).
    convergence : dict or None
        Evidence optimiser record: ``optimiser``, ``iterations``, ``evaluations``,
        ``converged`` (bool), ``message``.
    roll_log_bayes_factor : float or None
        Log Bayes factor of rolls at their prior scale over no roll
        (:func:`roll_log_bayes_factor`); None without a roll block or covariance.
    roll_probability : float or None
        ``P(roll | y)`` of the two-model average
        (:attr:`EstimatorSettings.roll_mixture_absent`); None when the average was not
        taken (off, no roll block, or rolls stated).
    travel_exponent : tuple of float
        The evidence's travel exponents, one per set of
        :attr:`EstimatorSettings.travel_exponent_groups` [1]; empty when not searched
        (off, scales given, or axes of one travel). Already in :attr:`function_scales`.
    kappa_travel_exponent : float or None
        The evidence's curvature travel exponent
        (:attr:`EstimatorSettings.kappa_travel_exponent_spread`) [1]; None when not
        searched. Already in :attr:`axis_kappa`.
    """

    x: NDArray[np.float64]
    covariance: NDArray[np.float64] | None
    sigma_um: float
    sigma_residual_um: float
    scales: NDArray[np.float64]
    log_evidence: float
    dof: float
    method: str
    solve: object = None  # callable: H^-1 @ rhs
    kappa: float = float("nan")
    convergence: dict = field(default_factory=dict)
    function_scales: NDArray[np.float64] | None = None
    ata: NDArray[np.float64] | None = field(default=None, repr=False)
    tilt_std_urad: float | None = None
    trend_um: float = 0.0
    kappa_factor: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0)
    trend_length: tuple[float, ...] = (1.0, 1.0, 1.0)
    axis_kappa: tuple[float, ...] = (1.0, 1.0, 1.0)
    tilt_trend_urad: float = 0.0
    nugget_um: float = 0.0
    roll_log_bayes_factor: float | None = None
    roll_probability: float | None = None
    travel_exponent: tuple[float, ...] = ()
    kappa_travel_exponent: float | None = None


def solve_bayes(design: Design, prior: PriorStructure, scales: NDArray[np.float64] | None = None,
                noise_um: float | None = None, squareness_std: float = 100.0,
                covariance: bool = True, tilt_std: float | None = None,
                roll_presence: bool = True, settings: EstimatorSettings | None = None,
                estimate: bool = True) -> Solution:
    """Bayesian least squares with evidence-optimised hyperparameters.

    Four steps, each a function of its own: the hyperparameters of maximum evidence
    (:class:`_HyperSearch`), the linear solve at them (:func:`_final_solve`), the rolls'
    presence (:func:`_roll_presence`: Bayes factor and two-model average) and the fit
    summary (:func:`_fit_summary`).

    Parameters
    ----------
    design : Design
        Observation system.
    prior : PriorStructure
        Smoothness prior blocks.
    scales : ndarray, shape (4,) or (18,), optional
        Fixed amplitude scales of the groups or of each function
        (:func:`volcal.identify.prior.function_scales`) [um, urad]; default estimated.
    noise_um : float, optional
        Stated reading repeatability [um]; default estimated.
    squareness_std : float
        Prior standard deviation of the squareness errors [urad].
    covariance : bool
        Compute the dense posterior covariance (when not too large).
    tilt_std : float, optional
        Prior standard deviation of the set-up tilts [urad]; default estimated with the
        scales (maximum evidence), or :data:`NUISANCE_PRECISION` when the scales are given.
    roll_presence : bool
        Weigh the rolls' presence (:func:`roll_log_bayes_factor`, the two-model average
        of :attr:`EstimatorSettings.roll_mixture_absent`). False for a solve that only
        chooses the hyperparameters, whose estimate is not kept.
    settings : EstimatorSettings, optional
        The estimator's settings; default ``EstimatorSettings()``.
    estimate : bool
        Solve the linear system at the hyperparameters found (default). False for a
        search that only chooses the hyperparameters (a coarse grid's): no estimate, no
        covariance, and the residual statistics (``dof``, ``sigma_residual_um``) nan.

    Returns
    -------
    Solution
    """
    st = settings if settings is not None else EstimatorSettings()
    ev = _Evidence(design, prior, squareness_std)
    search = _HyperSearch(ev, scales, noise_um, tilt_std, st)
    h_opt, neg2, convergence = search.run()
    f_opt, sigma, kappa = search.unpack(h_opt)  # also sets the tilts' scale
    if search.free_scales:
        f_opt = f_opt.copy()
        f_opt[list(ROLL_FUNCTIONS)] *= st.roll_factor  # the evidence cannot see the rolls
    scales_opt = _group_scales(f_opt)
    if kappa != ev.prior.kappa:
        ev.prior = ev.prior.with_kappa(kappa)
    if estimate:
        H, _, cf, x_fit, cov_fit = _final_solve(ev, design, f_opt, sigma, covariance, st)
        x, cov, solve, roll_lbf, p_roll = _roll_presence(ev.prior, design, f_opt, H, cf,
                                                         x_fit, cov_fit, roll_presence, st)
        x, dof, s_res = _fit_summary(ev, design, x, cov_fit, sigma)
    else:  # the hyperparameters alone: no linear solve
        x, cov, solve, roll_lbf, p_roll = np.zeros(0), None, None, None, None
        dof = s_res = float("nan")
    return Solution(x, cov, sigma, s_res, scales_opt, -0.5 * neg2, dof, "bayes",
                    solve=solve, kappa=kappa,
                    convergence=convergence, function_scales=f_opt, ata=ev.AtA,
                    tilt_std_urad=ev.tilt_std if ev.has_tilts else None,
                    trend_um=ev.prior.trend_um, kappa_factor=ev.prior.kappa_factor,
                    trend_length=ev.prior.trend_length, axis_kappa=ev.prior.axis_kappa,
                    tilt_trend_urad=ev.prior.tilt_trend_urad,
                    nugget_um=ev.prior.nugget_um, roll_log_bayes_factor=roll_lbf,
                    roll_probability=p_roll, travel_exponent=search.travel_exponents(h_opt),
                    kappa_travel_exponent=search.kappa_travel_exponent(h_opt))


class _HyperSearch:
    """The hyperparameters of :func:`solve_bayes` and their search for maximum evidence.

    The search vector ``h`` holds, when the scales are free, the log scales of
    :data:`FREE_GROUPS` (then, when searched, each axis' scale factors and the travel
    exponents, :attr:`EstimatorSettings.travel_exponent_groups`), then the extra
    scale-like hyperparameters (set-up tilts,
    positioning trend, short-wavelength nugget, where the design has them), then
    ``log kappa``; and last ``log sigma`` when the noise is not stated. Each carries a
    log-normal hyperprior (centres and spreads of :class:`EstimatorSettings`). The
    objective is ``-2 log evidence`` (:meth:`_Evidence.neg2_grad_functions`) plus the
    hyperprior's ``z'z``, with its exact gradient.

    Parameters
    ----------
    ev : _Evidence
        The evidence of the design (its prior is updated as the search moves).
    scales : ndarray, shape (4,) or (18,), optional
        Fixed scales [um, urad]; None: free.
    noise_um : float, optional
        Stated noise [um]; None: free.
    tilt_std : float, optional
        Fixed prior standard deviation of the set-up tilts [urad].
    st : EstimatorSettings
        The settings.
    """

    def __init__(self, ev: _Evidence, scales, noise_um: float | None, tilt_std: float | None,
                 st: EstimatorSettings) -> None:
        self.ev, self.st = ev, st
        self.free_scales = scales is None
        self.free_sigma = noise_um is None
        self.f_fixed = None if scales is None else function_scales(scales)
        self.sig0 = 0.5 if noise_um is None else float(noise_um)
        y_scale = max(float(np.sqrt(ev.yty / max(ev.n, 1))), 1e-3)
        self.sig_floor = 1e-7 * y_scale
        self.k0 = ev.prior.kappa
        centre = np.log([*st.hyper_centre, st.kappa_centre])
        self.kappa_centre = centre[-1]
        self.hyper_spread = np.log(st.hyper_spread)
        self.extra = self._extra_scales(tilt_std)
        # the travel exponents: where the scales are free and the axes' travels differ
        self.n_texp = (len(st.travel_exponent_groups) if self.free_scales
                       and st.travel_exponent_spread > 0 and self._travels_differ() else 0)
        self.texp_cols: list[int] = []
        self.M, self.centre, self.spread = self._hyper_map(centre[list(FREE_GROUPS)])
        self.ns = self.M.shape[1]
        # per-axis curvature factors: present only when the evidence may choose them
        self.kappa_travel = st.kappa_travel_exponent_spread > 0
        self.axes = self._axes_with_functions() if self.free_scales and (
            self.kappa_travel or st.axis_kappa_spread > 0) else []
        if self.kappa_travel:  # one exponent of the travels: log factor_k = gamma log(L_k/L)
            self.contrast = self._kappa_travel_column()
            self.axis_spread = float(st.kappa_travel_exponent_spread)
            self.axis_bounds = tuple(float(v) for v in st.kappa_travel_exponent_bounds)
        else:  # the axes' log factors as contrasts (their sum zero): the common kappa keeps
            # the mean, so the search has no direction only the hyperprior pins
            self.contrast = _contrasts(len(self.axes))
            self.axis_spread = np.log(st.axis_kappa_spread) if self.axes else 1.0
            self.axis_bounds = (float(np.log(0.05)), float(np.log(20.0)))
        self.na = self.contrast.shape[1]
        self.h0, self.bounds = self._start()

    def _extra_scales(self, tilt_std: float | None) -> list:
        """``(gradient index, hyperprior centre, bounds, spread)`` of the extra scales.

        The set-up tilts' scale (index 20) when the design has tilts, the positioning
        trend's (21) and the nugget's (26) when it has positioning functions; a given
        ``tilt_std`` is set on the evidence instead.
        """
        st, ev = self.st, self.ev
        extra = []
        if self.free_scales and tilt_std is None and ev.has_tilts:
            extra.append((20, np.log(st.tilt_centre_urad), (np.log(1e-1), np.log(1e5)),
                          np.log(st.tilt_spread)))
        elif tilt_std is not None:
            ev.set_tilt_std(tilt_std)
        positioning = any(f in TREND_FUNCTIONS for *_, f in ev.prior.blocks)
        if self.free_scales and positioning:
            centre = st.trend_centre_um_per_m if st.trend_per_metre else st.trend_centre_um
            extra.append((21, np.log(centre), (np.log(1e-2), np.log(1e4)),
                          np.log(st.trend_spread)))
        tilts = any(g == 3 for *_, g, _ in ev.prior.blocks)
        if self.free_scales and st.tilt_trend_centre_urad > 0 and tilts:
            extra.append((TILT_TREND, np.log(st.tilt_trend_centre_urad),
                          (np.log(1e-2), np.log(1e4)), np.log(st.tilt_trend_spread)))
        if self.free_scales and st.nugget and positioning:
            extra.append((26, np.log(st.nugget_centre_um), (np.log(1e-4), np.log(1e2)),
                          np.log(st.nugget_spread)))
        return extra

    def _travels_differ(self) -> bool:
        """Whether the axes with functions have travels differing by more than 1 %."""
        axes = self._axes_with_functions()
        return len(axes) > 1 and float(np.ptp(self.ev.prior.log_travel_ratios()[axes])) > 0.01

    def travel_exponents(self, h: NDArray[np.float64]) -> tuple[float, ...]:
        """The travel exponents in a search vector (empty when not searched)."""
        return tuple(float(h[i]) for i in self.texp_cols)

    def _kappa_travel_column(self) -> NDArray[np.float64]:
        """The curvature exponent's column: ``log(L_k / L_mean)`` of the axes with functions.

        Shape (n, 1); (n, 0) when their travels differ by at most 1 % (no exponent).
        """
        if not self.axes or not self._travels_differ():
            return np.zeros((len(self.axes), 0))
        return self.ev.prior.log_travel_ratios()[self.axes].reshape(-1, 1)

    def kappa_travel_exponent(self, h: NDArray[np.float64]) -> float | None:
        """The curvature's travel exponent in a search vector (None when not searched)."""
        if not (self.kappa_travel and self.na):
            return None
        return float(h[self.ns + 1])

    def _axes_with_functions(self) -> list[int]:
        """Axes with free function nodes (their curvature factor is searched)."""
        return self.ev.prior.axes_with_functions()

    def _hyper_map(self, group_centre: NDArray[np.float64]):
        """Log function scales and extra scales as a linear map of the search vector.

        Returns
        -------
        M : ndarray, shape (18 + e, 3 + e)
            ``log a_f = (M h)_f`` for the 18 functions (a roll takes the tilts' column),
            then one row and column per extra scale (:meth:`_extra_scales`).
        centre, spread : ndarray, shape (3 + e,)
            Log-normal hyperprior of each entry (centre, one standard deviation).
        """
        groups = list(FREE_GROUPS)
        M = np.zeros((18, len(groups)))
        for k in range(3):
            for c in range(6):
                g = function_group(k, c)
                M[6 * k + c, groups.index(g if g in groups else 3)] = 1.0  # roll -> tilt
        centre = np.asarray(group_centre, dtype=float)
        spread = np.full(len(groups), self.hyper_spread)
        if self.st.axis_scale_spread > 0:  # each axis' scale around its group's
            cols = []
            for g in groups:
                for k in range(3):
                    col = np.zeros(18)
                    for c in range(6):
                        gf = function_group(k, c)
                        if (gf if gf in groups else 3) == g:
                            col[6 * k + c] = 1.0
                    cols.append(col)
            M = np.hstack([M, np.array(cols).T])
            centre = np.append(centre, np.zeros(len(cols)))
            spread = np.append(spread, np.full(len(cols), np.log(self.st.axis_scale_spread)))
        if self.n_texp:  # each axis' amplitude grows with its travel (its exponents)
            self.texp_cols = list(range(M.shape[1], M.shape[1] + self.n_texp))
            M = np.hstack([M, self.ev.prior.travel_columns(self.st.travel_exponent_groups)])
            centre = np.append(centre, np.full(self.n_texp, self.st.travel_exponent_centre))
            spread = np.append(spread, np.full(self.n_texp, self.st.travel_exponent_spread))
        m0 = M.shape[1]
        for j, (_, c, _, sd) in enumerate(self.extra):
            M = np.vstack([np.hstack([M, np.zeros((M.shape[0], 1))]),
                           np.eye(1, m0 + j + 1, m0 + j)])
            centre = np.append(centre, c)
            spread = np.append(spread, sd)
        return M, centre, spread

    def _start(self) -> tuple[list, list]:
        """Starting point (the hyperprior centres, ``kappa`` and ``sigma`` given) and bounds."""
        h0: list = []
        bounds: list = []
        if self.free_scales:
            n_axis_scale = self.ns - len(FREE_GROUPS) - len(self.extra) - self.n_texp
            h0 += list(self.centre) + [np.log(self.k0)] + [0.0] * self.na
            texp_bounds = self.st.travel_exponent_bound_pairs() if self.n_texp else []
            bounds += ([(np.log(1e-2), np.log(1e4))] * len(FREE_GROUPS)
                       + [(np.log(1e-2), np.log(1e2))] * n_axis_scale
                       + list(texp_bounds)
                       + [bd for _, _, bd, _ in self.extra]
                       + [(np.log(1.0), np.log(1e4))]
                       + [self.axis_bounds] * self.na)
        if self.free_sigma:
            h0.append(np.log(self.sig0))
            bounds.append((np.log(self.sig_floor), np.log(1e3)))
        return h0, bounds

    def unpack(self, h: NDArray[np.float64]):
        """Search vector -> (function scales (18,), sigma [um], kappa).

        Also sets the evidence's tilts', trend and nugget scales.
        """
        ev, ns = self.ev, self.ns
        if not self.free_scales:
            fsc, kap, i = self.f_fixed, self.k0, 0
        else:
            logs = self.M @ h[:ns]
            fsc = np.exp(logs[:18])
            for j, (gi, *_) in enumerate(self.extra):
                v = float(np.exp(logs[18 + j]))
                if gi == 20:
                    ev.set_tilt_std(v)
                elif gi == 21:
                    ev.prior = ev.prior.with_trend(v)
                elif gi == TILT_TREND:
                    ev.prior = ev.prior.with_tilt_trend(v)
                else:
                    ev.prior = ev.prior.with_nugget(v)
            ev.prior = ev.prior.with_kappa_factor(np.ones(len(GROUPS)))  # one curvature scale
            kap = float(np.exp(h[ns]))
            i = ns + 1
            if self.na:
                fac = np.ones(3)
                fac[self.axes] = np.exp(self.contrast @ h[i:i + self.na])
                ev.prior = ev.prior.with_axis_kappa(fac)
                i += self.na
        sig = float(np.exp(h[i])) if self.free_sigma else self.sig0
        return fsc, sig, kap

    def objective(self, h: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        """``-2 log evidence`` plus the hyperprior's ``z'z``, and its gradient in ``h``."""
        ns = self.ns
        fsc, sig, kap = self.unpack(h)
        val, g20 = self.ev.neg2_grad_functions(fsc, sig, kap)
        grad = np.zeros(len(h))
        i = 0
        if self.free_scales:  # weak log-normal hyperprior: typical machines
            z = ((np.append(h[:ns], np.log(kap)) - np.append(self.centre, self.kappa_centre))
                 / np.append(self.spread, self.hyper_spread))
            val += float(z @ z)
            g_scales = np.append(g20[:18], [g20[gi] for gi, *_ in self.extra])
            grad[:ns] = self.M.T @ g_scales + 2.0 * z[:ns] / self.spread
            grad[ns] = g20[18] + 2.0 * z[ns] / self.hyper_spread
            i = ns + 1
            if self.na:  # log-normal around 1 (one curvature scale)
                za = h[i:i + self.na] / self.axis_spread
                val += float(za @ za)
                ga = np.array([g20[AXIS_KAPPA + k] for k in self.axes])
                grad[i:i + self.na] = self.contrast.T @ ga + 2.0 * za / self.axis_spread
            i += self.na
        if self.free_sigma:
            grad[i] = g20[19]
        return val, grad

    def run(self) -> tuple[NDArray[np.float64], float, dict]:
        """The hyperparameters of maximum evidence.

        Returns
        -------
        h : ndarray
            Search vector at the optimum (empty when everything is given).
        neg2 : float
            Objective there.
        convergence : dict
            ``optimiser``, ``converged``, ``iterations``, ``evaluations``, ``message``.
        """
        if not self.h0:
            neg2 = self.ev.neg2(self.f_fixed, self.sig0)
            return np.array([]), neg2, {"optimiser": "none (hyperparameters given)",
                                        "converged": True, "iterations": 0,
                                        "evaluations": 1, "message": ""}
        if self.free_sigma:
            self._start_sigma()
        return self._minimise()

    def _start_sigma(self) -> None:
        """Coarse start for sigma: scan a few decades, then MacKay's fixed point.

        ``sigma^2 = |r|^2 / (n - gamma)`` (``gamma``: effective number of parameters), so
        that the quasi-Newton steps start near the optimum of the steepest direction.
        """
        ev, h0 = self.ev, self.h0
        grid = np.log(np.geomspace(max(self.sig_floor, 1e-6), 10.0, 8))
        vals = []
        for g in grid:
            h = np.array(h0)
            h[-1] = g
            vals.append(ev.neg2(*self.unpack(h)))
        h0[-1] = grid[int(np.argmin(vals))]
        for _ in range(self.st.sigma_fixed_point_steps):
            ev.neg2_grad_functions(*self.unpack(np.array(h0)))
            if ev.last_fit is None:
                break
            rr, gamma = ev.last_fit
            s2 = rr / max(ev.n - gamma, 1.0)
            h0[-1] = float(np.clip(0.5 * np.log(max(s2, 1e-300)), *self.bounds[-1]))

    def _minimise(self) -> tuple[NDArray[np.float64], float, dict]:
        """L-BFGS-B on the preconditioned vector, stopped when the evidence is flat.

        Three iterations improving ``-2 log evidence`` by less than
        :attr:`EstimatorSettings.evidence_tol` change nothing a user sees (flat
        directions, e.g. a scale the data hardly inform, otherwise take dozens of tiny
        steps). When the quasi-Newton step stalls on a flat or kinked surface, the
        derivative-free simplex continues from the best point found.
        """
        tol, bounds = self.st.evidence_tol, self.bounds
        stop = _FlatStop(tol, 3)
        w = self._preconditioner()

        def fun_w(z):  # the search runs on h * w: curvatures of order one
            val, grad = self.objective(z / w)
            return val, grad / w

        res = minimize(fun_w, np.array(self.h0) * w, method="L-BFGS-B", jac=True,
                       bounds=[(lo * wi, hi * wi) for (lo, hi), wi in zip(bounds, w, strict=True)],
                       callback=stop,
                       options={"maxiter": 200, "ftol": 1e-10, "gtol": 1e-2})
        res.x = res.x / w
        if stop.flat():
            res.success = True
            res.message = (f"CONVERGENCE: -2 log evidence improved by less than {tol:g} "
                           "in 3 iterations")
        name = "L-BFGS-B"
        if not res.success:
            res2 = self._simplex(res.x)
            if res2.fun <= res.fun:
                res, name = res2, "L-BFGS-B, then Nelder-Mead"
        return res.x, float(res.fun), {"optimiser": name, "converged": bool(res.success),
                                       "iterations": int(res.nit),
                                       "evaluations": int(self.ev.evaluations),
                                       "message": str(res.message)}

    def _simplex(self, h0: NDArray[np.float64]):
        """Nelder-Mead from ``h0``, stopped when the evidence is flat.

        The simplex moves one vertex per iteration, so the flat rule of the quasi-Newton
        search (three iterations) is taken over ``2 n`` iterations (``n`` search
        dimensions): ``2 n`` iterations improving ``-2 log evidence`` by less than
        :attr:`EstimatorSettings.evidence_tol` end it. Without that rule the simplex ran
        to its tolerances in ``h`` (``xatol`` 5e-3, ``fatol`` 1e-3): 653 evaluations,
        17 s, on the seeds' step diagonals with one axis' lines, for an estimate 0.001 um
        from the one found after 189 (benchmarks/README.md, "Session 20: the simplex").
        """
        tol, window = self.st.evidence_tol, 2 * len(h0)
        stop = _FlatStop(tol, window)

        def value(h: NDArray[np.float64]) -> float:
            return self.objective(h)[0]

        res = minimize(value, h0, method="Nelder-Mead", bounds=self.bounds, callback=stop,
                       options={"xatol": 5e-3, "fatol": 1e-3, "maxiter": 600})
        if stop.flat():
            res.success = True
            res.message = (f"CONVERGENCE: -2 log evidence improved by less than {tol:g} "
                           f"in {window} simplex iterations")
        return res

    def _preconditioner(self) -> NDArray[np.float64]:
        """Diagonal scaling of the search vector for the quasi-Newton search.

        The curvature of ``-2 log evidence`` in the log of a scale is about twice the
        effective number of parameters that scale governs (``gamma``: the data-determined
        share of its functions, ``tr(Q^-1 dQ) - tr(H^-1 dQ)`` halved), plus the
        hyperprior's ``2 / spread^2``; the noise governs ``n - gamma`` readings. Without
        the scaling the first steps of L-BFGS-B, dominated by the noise (thousands of
        readings) and the curvature, went to the bounds and back.
        """
        ev = self.ev
        ev.neg2_grad_functions(*self.unpack(np.array(self.h0)))
        g = ev.last_gamma if ev.last_gamma is not None else np.ones(N_HYPER)
        c = []
        if self.free_scales:
            gs = np.append(g[:18], [g[gi] for gi, *_ in self.extra])
            c += list((self.M**2).T @ (2.0 * np.abs(gs)) + 2.0 / self.spread**2)
            c.append(2.0 * abs(g[18]) + 2.0 / self.hyper_spread**2)
            if self.na:
                ga = np.abs([g[AXIS_KAPPA + k] for k in self.axes])
                c += list((self.contrast**2).T @ (2.0 * ga) + 2.0 / self.axis_spread**2)
        if self.free_sigma:
            c.append(2.0 * abs(g[19]))
        return np.sqrt(np.maximum(np.array(c), 1.0))


class _FlatStop:
    """Optimiser callback: stop when the evidence is flat.

    ``window`` iterations improving the objective by less than ``tol``
    (:attr:`EstimatorSettings.evidence_tol`): the two evidence searches' one rule (3
    quasi-Newton iterations, ``2 n`` simplex iterations).
    """

    def __init__(self, tol: float, window: int) -> None:
        self.tol, self.window = tol, window
        self.history: list[float] = []

    def flat(self) -> bool:
        """Whether the last ``window`` iterations improved by less than ``tol``."""
        h, w = self.history, self.window
        return len(h) > w and h[-w - 1] - h[-1] < self.tol

    def __call__(self, intermediate_result) -> None:
        self.history.append(float(intermediate_result.fun))
        if self.flat():
            raise StopIteration


def _contrasts(n: int) -> NDArray[np.float64]:
    """Orthonormal basis of the vectors of ``n`` entries summing to zero, ``(n, n - 1)``."""
    if n < 2:
        return np.zeros((n, 0))
    q, _ = np.linalg.qr(np.hstack([np.ones((n, 1)), np.eye(n)[:, :n - 1]]))
    return q[:, 1:]


def _roll_presence(prior: PriorStructure, design: Design, fscales, H, cf, x, cov,
                   weigh: bool, st: EstimatorSettings):
    """The rolls' Bayes factor and the two-model average of the estimate.

    Parameters
    ----------
    prior : PriorStructure
        Prior blocks at the final hyperparameters.
    design : Design
        Observation system (its extra precision: rolls stated by the user are kept).
    fscales : ndarray, shape (18,)
        Function scales of the fit [um, urad].
    H, cf : ndarray, tuple
        Posterior precision and its Cholesky factor.
    x, cov : ndarray
        Estimate (without the design's prior mean) and covariance of the linear fit.
    weigh : bool
        Compute the Bayes factor and the average (False: the linear fit as it is).
    st : EstimatorSettings
        Its ``roll_mixture_absent`` and ``roll_mixture_covariance``.

    Returns
    -------
    (x, cov, solve, log_bf, p_roll)
        Estimate and covariance of the average (:func:`_roll_mixture`) or of the fit;
        ``solve`` maps ``A'y / sigma^2`` to the estimate with the same weights (Monte
        Carlo); the log Bayes factor (:func:`roll_log_bayes_factor`) and ``P(roll | y)``,
        None where not computed.
    """
    log_bf = roll_log_bayes_factor(prior, fscales, x, cov) if cov is not None and weigh \
        else None
    solve = lambda rhs: _polish(H, cf, rhs)  # noqa: E731
    p_roll = None
    if st.roll_mixture_absent > 0 and log_bf is not None:
        mixed = _roll_mixture(prior, fscales, x, cov, log_bf, st.roll_mixture_absent,
                              design.extra_precision, st.roll_mixture_covariance,
                              st.roll_covariance_absent)
        if mixed is not None:
            x, cov, shrink, p_roll = mixed
            if shrink is not None:
                solve = lambda rhs: shrink(_polish(H, cf, rhs))  # noqa: E731
    return x, cov, solve, log_bf, p_roll


def _fit_summary(ev: _Evidence, design: Design, x, cov_fit, sigma: float):
    """The estimate with the design's prior mean, and the residual statistics.

    Parameters
    ----------
    ev : _Evidence
        The evidence (``A'A``, number of readings and unknowns).
    design : Design
        Observation system.
    x : ndarray
        Estimate without the prior mean [um, urad].
    cov_fit : ndarray or None
        Covariance of the linear fit (its hat matrix gives the effective number of
        parameters ``tr(A'A C) / sigma^2``); None: all unknowns count.
    sigma : float
        Reading noise [um].

    Returns
    -------
    (x, dof, s_res)
        Estimate with the prior mean, residual degrees of freedom ``n - edf`` (at least
        1) and the RMS residual over them [um].
    """
    r = design.y - design.A @ x
    if design.prior_mean is not None and np.any(design.prior_mean):
        x = x + design.prior_mean
    if cov_fit is not None:
        edf = float(np.sum(ev.AtA * cov_fit.T) / sigma**2)
    else:
        edf = float(min(ev.N, ev.n))
    dof = max(ev.n - edf, 1.0)
    return x, dof, float(np.sqrt(r @ r / dof))


def _group_scales(fscales: NDArray[np.float64]) -> NDArray[np.float64]:
    """Geometric mean of the function scales of each group of :data:`GROUPS`."""
    out = np.zeros(len(GROUPS))
    n = np.zeros(len(GROUPS))
    for k in range(3):
        for c in range(6):
            g = function_group(k, c)
            out[g] += np.log(fscales[6 * k + c])
            n[g] += 1
    return np.exp(out / n)


def _final_solve(ev: _Evidence, design: Design, fscales, sigma: float, covariance: bool,
                 settings: EstimatorSettings | None = None):
    """Factor, estimate and (dense) posterior covariance at the final hyperparameters.

    Parameters
    ----------
    ev : _Evidence
        The evidence of the design.
    design : Design
        Observation system.
    fscales : ndarray, shape (18,)
        Function scales [um, urad].
    sigma : float
        Reading noise [um].
    covariance : bool
        Form the dense covariance on the Cholesky path.
    settings : EstimatorSettings, optional
        Its dense-solve limits (``dense_qr_limit``, ``dense_qr_entries``,
        ``dense_covariance_limit``); default ``EstimatorSettings()``.

    Returns
    -------
    (H, Q, cf, x, cov)
        Posterior precision, prior precision, Cholesky factor of ``H``, estimate (without
        the design's prior mean) and covariance (None when too large or not wanted).
    """
    st = settings if settings is not None else EstimatorSettings()
    H, Q, cf = _final_factor(ev, fscales, sigma)
    N = H.shape[0]
    if N <= st.dense_qr_limit and (ev.n + N) * N <= st.dense_qr_entries:
        x, cov = _dense_qr(design, sp.csc_matrix(Q), sigma)
    else:
        x = _polish(H, cf, ev.Aty / sigma**2, steps=4)
        cov = None
        if covariance and N <= st.dense_covariance_limit:
            cov = sla.cho_solve(cf, np.eye(N), check_finite=False)
    return H, Q, cf, x, cov


def _roll_log_likelihood(k: NDArray[np.float64], b2: NDArray[np.float64], rho2
                         ) -> NDArray[np.float64]:
    """``l(rho) = -1/2 sum log(1 + rho^2 k_i) + 1/2 sum rho^2 b_i^2 / (1 + rho^2 k_i)``.

    The log evidence, up to a constant, of the rolls' prior scaled by ``rho`` (``rho^2``
    a scalar or an array), from their whitened information (:func:`_roll_whitened`);
    ``l(0) = 0`` (no roll).
    """
    r2 = np.atleast_1d(np.asarray(rho2, dtype=float))[:, None]
    q = 1.0 + r2 * k[None, :]
    out = -0.5 * np.sum(np.log(q), axis=1) + 0.5 * np.sum(r2 * b2[None, :] / q, axis=1)
    return out if np.ndim(rho2) else out[0]


def _roll_whitened(prior: PriorStructure, fscales, x, cov,
                   functions: tuple[int, ...] = ROLL_FUNCTIONS):
    """The rolls' data information in coordinates whitened by their prior.

    With ``C = a^2 (L L')^-1`` a roll's prior covariance, ``u = L' x / a`` has unit prior
    covariance; ``S_u = V diag(s) V'`` is its posterior covariance.

    Returns ``(k, b2)``: the eigenvalues ``k_i = 1/s_i - 1`` of the data's precision and
    the squared projections ``b_i^2 = ((V' u)_i / s_i)^2`` (:func:`roll_log_bayes_factor`),
    over the free nodes of ``functions`` (default the three rolls) together; None when the
    design has none of them.
    """
    idx_all, W = [], []
    for b, (idx, *_rest, f) in enumerate(prior.blocks):
        if f not in functions or prior.has_trend(b) or prior.has_nugget(b):
            continue
        try:
            Lp = np.linalg.cholesky(prior.unit_block(b)[0])
        except np.linalg.LinAlgError:
            return None
        idx_all.append(idx)
        W.append(Lp.T / float(fscales[f]))
    if not idx_all:
        return None
    idx = np.concatenate(idx_all)
    T = sla.block_diag(*W)
    u = T @ x[idx]
    Su = T @ cov[np.ix_(idx, idx)] @ T.T
    sv, V = np.linalg.eigh((Su + Su.T) / 2)
    sv = np.clip(sv, 1e-12, 1.0)
    return 1.0 / sv - 1.0, (V.T @ u / sv) ** 2


def roll_log_bayes_factor(prior: PriorStructure, fscales, x, cov) -> float | None:
    """Log Bayes factor of the rolls at their prior scale over no roll at all.

    ``L = -1/2 sum log(1 + k_i) + 1/2 sum b_i^2 / (1 + k_i)`` with the rolls' data
    information in coordinates whitened by their prior (:func:`_roll_whitened`): the log of
    ``p(y | rolls as the prior says) / p(y | no roll)`` (Kass and Raftery 1995). Negative:
    the readings favour a machine without roll errors.

    Parameters
    ----------
    prior : PriorStructure
        Prior blocks.
    fscales : ndarray, shape (18,)
        Function scales of ``x`` and ``cov``.
    x, cov : ndarray
        Posterior mean (without the design's prior mean) and covariance.

    Returns
    -------
    float or None
        None when the design has no roll block (``roll='zero'``).
    """
    kb = _roll_whitened(prior, fscales, x, cov)
    if kb is None:
        return None
    k, b2 = kb
    return float(_roll_log_likelihood(k, b2, 1.0))


def _p_roll(log_bf: float, p_absent: float) -> float:
    """``P(roll | y)`` from the log Bayes factor and the prior probability of no roll."""
    if p_absent <= 0:
        return 1.0
    z = np.log(p_absent) - np.log1p(-p_absent) - log_bf
    return float(np.exp(-np.logaddexp(0.0, z)))


def covariance_roll_weight(covariance: str, log_bf: float, p_roll: float,
                           p_absent_cov: float) -> float:
    """Weight ``P'`` of the model with rolls in the two-model average's covariance.

    Parameters
    ----------
    covariance : str
        :attr:`EstimatorSettings.roll_mixture_covariance`.
    log_bf : float
        Log Bayes factor of the rolls (:func:`roll_log_bayes_factor`).
    p_roll : float
        ``P(roll | y)`` of the estimate's average [1].
    p_absent_cov : float
        :attr:`EstimatorSettings.roll_covariance_absent` [1].

    Returns
    -------
    float
        1 for ``'roll'``, ``p_roll`` for ``'mixture'``, ``P(roll | y)`` at the prior
        probability ``p_absent_cov`` of no roll for ``'cautious'`` [1].
    """
    if covariance == "roll":
        return 1.0
    if covariance == "mixture":
        return p_roll
    return _p_roll(log_bf, p_absent_cov)


def _roll_mixture(prior: PriorStructure, fscales, x, cov, log_bf: float, p_absent: float,
                  soft: NDArray[np.float64] | None = None, covariance: str = "roll",
                  p_absent_cov: float = 0.01):
    """Average of the fit with rolls and the fit without, weighted by the readings.

    The fit without roll is the fit with rolls conditioned on zero roll at every free node (the
    rolls' prior is independent of the other unknowns, so conditioning the posterior equals
    refitting with the rolls removed): ``x0 = x - K x_R``, ``C0 = C - K C_RR K'`` with ``K =
    C_:R C_RR^-1``. With ``P = P(roll | y)`` from the log Bayes factor ``log_bf`` and the prior
    probability ``p_absent`` of no roll, the mixture's mean is ``x_m = x - (1 - P) d``, ``d = K
    x_R`` (Hoeting et al. 1999, Bayesian model averaging). Its covariance (``covariance``) is
    the mean square error of ``x_m`` over the two models weighted ``P'``, ``1 - P'``: ``P' (C +
    (1 - P)^2 d d') + (1 - P') (C0 + P^2 d d')`` = ``C - (1 - P') K C_RR K' + (P' (1 - P)^2 +
    (1 - P') P^2) d d'``, with ``P'`` the weight of the rolls at the prior probability of no roll
    ``p_absent_cov`` (``'cautious'``), 1 (``'roll'``: ``C + (1 - P)^2 d d'``) or ``P``
    (``'mixture'``, the mixture's own: ``C - (1 - P) K C_RR K' + P (1 - P) d d'``).

    Parameters
    ----------
    prior : PriorStructure
        Prior blocks.
    fscales : ndarray, shape (18,)
        Function scales of ``x`` and ``cov`` [um, urad].
    x, cov : ndarray
        Posterior mean (without the design's prior mean) and covariance of the fit with
        rolls.
    log_bf : float
        :func:`roll_log_bayes_factor` of that fit.
    p_absent : float
        Prior probability of no roll.
    soft : ndarray, optional
        The design's extra precision of stated values: rolls stated by the user are left
        as they are.
    covariance : str
        ``'roll'``, ``'mixture'`` or ``'cautious'``
        (:attr:`EstimatorSettings.roll_mixture_covariance`).
    p_absent_cov : float
        Prior probability of no roll in ``P'`` of ``'cautious'``
        (:attr:`EstimatorSettings.roll_covariance_absent`).

    Returns
    -------
    (x_m, C_m, shrink, P) or None
        ``shrink`` maps any estimate of the fit with rolls to the mixture's (the weights
        held fixed), for the linear propagation of systematic errors and Monte Carlo.
        ``P`` is ``P(roll | y)``; when it is within 1e-9 of 1, ``x`` and ``cov`` as
        given and ``shrink`` None. None when the design has no roll block or the rolls
        are stated.
    """
    idx, D = [], []
    for b, blk in enumerate(prior.blocks):
        if blk[4] in ROLL_FUNCTIONS and not prior.has_trend(b) and not prior.has_nugget(b):
            idx.append(blk[0])
            D.append(np.linalg.inv(prior.unit_block(b)[0]) * float(fscales[blk[4]]) ** 2)
    if not idx:
        return None
    R = np.concatenate(idx)
    if soft is not None and np.any(soft[R]):  # the user stated the rolls to so much
        return None
    p_roll = _p_roll(log_bf, p_absent)
    q = 1.0 - p_roll
    if q < 1e-9:  # the readings settle it: the fit with rolls
        return x, cov, None, p_roll
    CRR = cov[np.ix_(R, R)]
    # C_RR^-1 in the rolls' prior scale (D): directions the readings pin to within 1e-12
    # of their prior variance are held at that floor (noise-free data)
    T = np.sqrt(np.diag(sla.block_diag(*D)))
    sv, V = np.linalg.eigh(CRR / np.outer(T, T))
    sv = np.maximum(sv, 1e-12 * max(float(sv.max()), 1e-300))
    K = (cov[:, R] / T) @ (V / sv) @ V.T / T  # C_:R C_RR^-1
    d = K @ x[R]
    xm = x - q * d
    qc = 1.0 - (pc := covariance_roll_weight(covariance, log_bf, p_roll, p_absent_cov))
    cm = cov + (pc * q * q + qc * p_roll * p_roll) * np.outer(d, d) - (  # no K C_RR K'
        qc * (K @ cov[R, :]) if qc else 0.0)  # to form for 'roll' (P' = 1)

    def shrink(v):
        return v - q * (K @ v[R])
    return xm, (cm + cm.T) / 2, shrink, p_roll


def _final_factor(ev: _Evidence, fscales, sigma: float):
    """``ev.factor`` with a diagonal jitter when the precision is numerically indefinite.

    Noise-free data drive the noise to its floor, where ``A'A / s^2`` is ~1e14 times the
    prior and its rounding can outweigh the prior in the directions the data do not see;
    a jitter of 1e-13 of the largest diagonal entry (grown tenfold until the factorisation
    succeeds) restores it without changing the estimate beyond that precision.
    """
    try:
        return ev.factor(fscales, sigma)
    except (np.linalg.LinAlgError, sla.LinAlgError):
        pass
    Q = ev.prior_dense(fscales)
    H = ev.AtA / sigma**2 + Q
    eps = 1e-13 * float(np.max(np.diag(H)))
    for _ in range(8):
        Hj = H + eps * np.eye(H.shape[0])
        try:
            return Hj, Q, sla.cho_factor(Hj, lower=True, check_finite=False)
        except (np.linalg.LinAlgError, sla.LinAlgError):
            eps *= 10.0
    raise np.linalg.LinAlgError("posterior precision not positive definite")


def _dense_qr(design: Design, Q, sigma: float):
    """Stable solve of the augmented least squares ``[A/sigma; R] x = [y/sigma; 0]``.

    ``R`` is the Cholesky factor of the prior precision. Unlike the normal equations this
    keeps full accuracy when the noise is tiny (noise-free data are then fitted to
    numerical precision). Returns the estimate and the posterior covariance.
    """
    A = design.A.toarray() / sigma
    Rp = np.linalg.cholesky(Q.toarray()).T
    n = Rp.shape[0]
    # the right-hand side as one more column: R of [M | rhs] holds Q^T rhs in its last
    # column, so the orthogonal factor is never formed (0.10 s in place of 0.26 s for the
    # seeds' set at 10 increments; the same estimate within 1e-12 um)
    M = np.vstack([np.column_stack([A, design.y / sigma]),
                   np.column_stack([Rp, np.zeros(n)])])
    R = sla.qr(M, mode="r", overwrite_a=True, check_finite=False)[0]
    Rm = R[:n, :n]
    x = sla.solve_triangular(Rm, R[:n, n], check_finite=False)
    Rinv = sla.solve_triangular(Rm, np.eye(n), check_finite=False)
    return x, Rinv @ Rinv.T


def _polish(H, cf, rhs, steps: int = 2):
    """Solve ``H x = rhs`` with the Cholesky factor and a few steps of iterative refinement."""
    x = sla.cho_solve(cf, rhs, check_finite=False)
    for _ in range(steps):
        x = x + sla.cho_solve(cf, rhs - H @ x, check_finite=False)
    return x


def solve_min_norm(design: Design, noise_um: float | None = None) -> Solution:
    """Minimum-norm least squares on the node values (no prior).

    Parameters
    ----------
    design : Design
        Observation system.
    noise_um : float, optional
        Stated repeatability [um] for the covariance; default the residual standard
        deviation.

    Returns
    -------
    Solution
        Covariance ``s^2 (A^T A)^+`` with ``s`` the residual standard deviation.
    """
    A = design.A.toarray() if sp.issparse(design.A) else design.A
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    tol = s.max() * max(A.shape) * np.finfo(float).eps * 10
    keep = s > tol
    x = Vt[keep].T @ ((U[:, keep].T @ design.y) / s[keep])
    r = design.y - A @ x
    if design.prior_mean is not None and np.any(design.prior_mean):
        x = x + design.prior_mean
    rank = int(keep.sum())
    dof = max(A.shape[0] - rank, 1)
    s_res = float(np.sqrt(r @ r / dof))
    sig = s_res if noise_um is None else float(noise_um)
    cov = (Vt[keep].T / s[keep] ** 2) @ Vt[keep] * sig**2
    return Solution(x, cov, sig, s_res, np.full(len(GROUPS), np.nan), float("nan"),
                    float(dof), "min-norm",
                    convergence={"optimiser": "SVD (no hyperparameters)", "converged": True,
                                 "iterations": 0, "evaluations": 0, "message": ""})
