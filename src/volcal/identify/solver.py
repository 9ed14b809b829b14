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
* ``prior='none'``: minimum-norm least squares on the node values (the floor any
  estimator must beat), uncertainty ``s^2 (A^T A)^+``.
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
    N_HYPER,
    NUISANCE_PRECISION,
    _Evidence,
    _inverse_from_cholesky,
    _nuisance_precision,
)
from volcal.identify.prior import (
    TREND_FUNCTIONS,
    PriorStructure,
    function_group,
    function_scales,
)

__all__ = ["Solution", "solve_bayes", "solve_min_norm"]

DEFAULT_SCALES = np.array([10.0, 5.0, 15.0, 15.0])
"""Typical amplitude scales of machining centres: positioning [um], straightness [um],
roll [urad], tilts [urad]."""
HYPER_CENTRE = np.log([DEFAULT_SCALES[0], 2.0, *DEFAULT_SCALES[2:], 6.0])
"""Centre of the hyperprior: the amplitude scales above and the curvature scale; it
only matters for groups the data do not inform (there it holds the scale). The
straightness centre is 2 um, not 5: with the difference form of the prior at the gauge
zeros (:data:`volcal.identify.prior.BOUNDARY`) a straightness with the end-point line
removed has about twice the prior variance in the middle of its travel than the
conditioned one, and an unseen straightness (Abbe lines alone) then covered 0.9995 of
the study's grid (2.5 um: 0.991; 2 um: 0.974, the issue-10 figure was 0.981)."""
HYPER_SPREAD = np.log(30.0)
"""Spread of the log-normal hyperprior (one standard deviation, as a factor of 30): weak,
it only holds scales the data do not inform."""
FREE_GROUPS: tuple[int, ...] = (0, 1, 3)
"""Groups of :data:`volcal.identify.prior.GROUPS` with a scale of their own; the roll
(group 2) takes the tilts' scale. Measured on the seeds' full test set (exact simulation,
0.5 um noise, three chains): a free roll scale went to 3.7 urad on one machine and 18.8
on another, and the 95 % intervals covered 0.65 and 1.00 of the grid (rigid-body motion
removed); a roll shrunk towards the tilts by a factor 2 still gave 0.77 and 1.00; sharing
the tilts' scale gives 0.94-0.98 on the same machines. Lines, diagonals and step
diagonals see the rolls only through a few lever arms, too little for the evidence to
set their scale."""
EVIDENCE_TOL = 0.05
"""The evidence optimiser stops when three iterations improve -2 log evidence by less than
this (a likelihood ratio of 1.03 between hyperparameters: nothing the estimate shows)."""
SIGMA_FIXED_POINT_STEPS = 2
"""MacKay fixed-point updates of the noise before the quasi-Newton search."""
TILT_CENTRE_URAD = 50.0
"""Centre of the hyperprior of the set-up tilts' scale [urad] (beam and flat mirror
aligned by eye and autoreflection). The tilts of a session's set-ups are independent
draws of one unknown scale, which the evidence estimates from the step diagonals; this
is what separates a positioning slope from a mirror tilt, weakly (Soons)."""
TILT_SPREAD = np.log(2.0)
"""Spread of the set-up tilts' hyperprior (a factor 2: 12-200 urad at 95 %). The data
hardly inform this scale (a positioning slope or an angular error explains the same
readings), and with the weak spread of the other scales the evidence drove it to 3-4 urad
on machines set up 20 urad off, which made the slopes look determined: coverage 0.80 and
1.6x the error of minimum-norm least squares on one machine of the study."""
TREND_CENTRE_UM = 20.0
"""Centre of the hyperprior of the positioning trend's scale [um at the end of travel]
(:data:`volcal.identify.prior.TREND_FUNCTIONS`): 1 m of steel scale 2 K off 20 C."""
ROLL_FACTOR = 1.5
"""The rolls' prior scale over the tilts' (applied after the evidence, which cannot see
the rolls). A roll the design hardly sees keeps its prior uncertainty, so that prior must
cover the rolls of real machines, not the tilts of this one: with the tilts' scale the
study's Abbe lines + body diagonals (8 machines, roll ECZ undetermined) covered 0.887 of
the grid (one machine: ECZ 19 urad RMS against a prior of 7.8); a factor exp(w^2) = 1.5,
the mean-square amplitude of a function whose scale varies by a factor exp(w) = 1.9 around
its group's, gives 0.927 there and 0.97-0.98 on the other designs. Multiplying every
function's scale by 1.3 instead over-covered the Abbe lines (0.998)."""
ROLL_SPREAD = 0.0
"""Spread of each roll's factor over the tilts' scale (one standard deviation, as a log
factor; one factor per roll), centred on :data:`ROLL_FACTOR`, estimated by the evidence
when > 0. 0 (default):
the fixed factor :data:`ROLL_FACTOR`. Machines without roll exist (issue 19, family ``b``
of benchmarks/families.py): there the rolls keep a prior of 1.5 times the tilts' scale
and the volumetric residual is a median 1.8x that of the best linear estimator knowing
the family (1.13x with ``roll='zero'``). Measured on 6 machines of that family: 1.10x
with a free roll scale, 1.17x with a spread of log 3; but on the study's designs
(tests/identify/test_study_designs.py) a free roll scale collapsed on one machine of the
full set (its 95 % intervals covered 0.38 of the grid), one factor shared by the three
rolls with a spread of log 3 (log 2) left the Abbe lines + body diagonals at a pooled
coverage of 0.85 (0.87) and the roll coverage below 0.90 (the unseen ECZ took the factor
of the rolls the design sees), and one factor per roll with a spread of log 3 still
0.884, roll coverage 0.865 and 0.887 on two designs: the readings hardly inform a roll's
scale, and what the evidence takes from it is then held too tightly. Kept as a switch;
a user who knows the machine has no roll says so (``roll='zero'``)."""
ROLL_MARGINAL_SPREAD = 0.0
"""Spread (one standard deviation of the log) of each roll's scale factor around the fixed
:data:`ROLL_FACTOR`, integrated out after the fit (:func:`_roll_marginal_factors`); 0
(default): off. The hyperprior is log-normal with ``E[rho^2] = 1``, so a roll the readings
do not inform keeps exactly the prior variance of :data:`ROLL_FACTOR`; where they do, the
roll's prior variance becomes ``E[rho^2 | y]``. Measured on benchmarks/families.py (full
set, 20 machines per family, 2026-11-24): with a spread of log 10 the family without roll
(b) came to a median 1.13x the limit (1.81 with the fixed factor) but the families with
roll lost their coverage (a 0.575, c 0.600, e 0.599, f 0.569 pooled, against 0.96); with
log 3 b was at about 1.3x (6 machines) and a, c still covered only 0.845 and 0.801. The
seeds' full set sees a roll in one or two directions of its 41 nodes (whitened data
precision 123 and 9 on one machine of family a, the others below 4): a scale estimated from
one or two such directions is a chi-square with one or two degrees of freedom, and any
hyperprior that lets it fall far enough for machines without roll shrinks the *unseen*
directions of machines with roll with it. The family without roll is then served by
``roll='zero'`` (1.10x) or by a level (direct optics, issue 16), not by the evidence."""
ROLL_ABSENT_PROBABILITY = 0.0
"""Prior probability that the machine has no roll errors at all (0: off). With ``p > 0``
the three rolls share one indicator: absent (scale 0) with probability ``p``, present
with probability ``1 - p`` at ``1 / sqrt(1 - p)`` times :data:`ROLL_FACTOR`'s scale (so
that a design that does not see the rolls keeps exactly today's prior variance); after the
fit the rolls' prior variance becomes its posterior mean given the readings
(:func:`_roll_presence_factors`). Measured on benchmarks/families.py and
benchmarks/study.py (2026-11-24, 20 machines per family, 8 of volcal's own): with
``p = 0.2`` and the "roll" hypothesis at today's scale (:data:`ROLL_PRESENT_FACTOR` 1) the
family without roll came to a median 1.19x the limit on the full set (1.81 off) and 1.07x
on the long machine (1.65), the others at a 1.02, c 1.20, e 1.18, f 1.20 (off: 1.02,
1.18, 1.18, 1.17) with pooled coverage 0.93-0.97; but on volcal's own machines, which all
have rolls, the rolls were judged absent often enough that the full set's coverage fell
from 0.981 to 0.915 (one machine 0.44), Abbe lines + body diagonals' from 0.930 to 0.892
and the step diagonals' roll coverage from 0.97 to 0.89 (tests/identify/
test_study_designs.py asks 0.90). With the "roll" hypothesis normalised (``1 / sqrt(1 -
p)``, p 0.5 / 0.2) the families with roll lost accuracy instead (c 1.36 / 1.24, f 1.31 /
1.22). Off: the seeds' designs inform the rolls too weakly to tell a machine without roll
from one with small rolls, which is the user's to state (``roll='zero'``)."""
ROLL_MIXTURE_ABSENT = 0.5
"""Prior probability of a machine without roll errors in the two-model average of the
estimate (:func:`_roll_mixture`; 0: off, the rolls always at their prior scale). The
estimate is the average of the fit with rolls and the same fit conditioned on no roll,
weighted by their posterior probabilities (the Bayes factor of
:func:`roll_log_bayes_factor`); its covariance is that of the fit with rolls plus the
shift (:data:`ROLL_MIXTURE_COVARIANCE`), so that a machine whose rolls the design does not
see keeps their full uncertainty. Equal prior odds (0.5): the readings decide. Measured on
benchmarks/families.py (seeds' full set, 20 machines per family, 2026-11-24, session 6):
the family without roll (b) went from a median 1.83x the limit to 1.14x (long machine
1.65 -> 1.06x); the families with roll moved by one machine each, whose rolls of 6-25 urad
(nearly linear) the readings did not see (log Bayes factor -3.5): c 1.16 -> 1.20, f 1.17
-> 1.21 (geometric means 1.156 -> 1.172, 1.147 -> 1.172), coverage unchanged (0.962);
b's coverage 0.981 -> 0.989. Prior odds 0.1 / 0.3: b 1.20 / 1.16, c and f unchanged. A
second model with small rolls (0.1-0.3 times the scale, :data:`ROLL_MIXTURE_RHO0`)
instead of none: b 1.15-1.30, f 1.12-1.21. With the smoother rolls that followed
(:data:`volcal.identify.prior.GROUP_KAPPA`): a 1.02, b 1.12, c 1.12, d 1.06, e 1.10, f
1.18, coverage 0.944-0.991 (benchmarks/README.md)."""
ROLL_MIXTURE_COVARIANCE = "roll"
"""Covariance of the two-model average: ``'roll'`` (default) that of the fit with rolls
plus the shift of the mean, ``C + (1 - P)^2 d d'`` (the mean square error of the average
if the machine has the rolls the prior allows); ``'mixture'`` the mixture's own, ``P C +
(1 - P) C0 + P (1 - P) d d'``. Measured (families, p 0.1-0.35): with the mixture's own
one machine of family f whose rolls the readings did not see (log Bayes factor -3.5)
covered 0.32 of the grid and f's pooled coverage fell from 0.963 to 0.923-0.930 (c 0.962
-> 0.939-0.956): the unseen directions of its rolls kept only ``P`` times their prior
variance."""
ROLL_MIXTURE_RHO0 = 0.0
"""Scale factor of the rolls in the second model of :data:`ROLL_MIXTURE_ABSENT` (0: no
roll)."""
ROLL_PRESENT_FACTOR: float | None = None
"""Scale factor of the "roll" hypothesis of :data:`ROLL_ABSENT_PROBABILITY` over the
current roll scale; None: ``1 / sqrt(1 - p)`` (a design that does not see the rolls keeps
today's prior variance)."""
KAPPA_FACTOR_SPREAD = 0.0
"""Spread of each group's curvature scale around the common one (0: one curvature scale
for all groups). Measured with a factor 3 on the study's designs (8 machines): pooled
coverage full 0.933, step 0.926, Abbe lines + body diagonals 0.875, long 0.922, against
0.975, 0.974, 0.887, 0.945 with one curvature scale; kept as an extension point."""
TREND_SPREAD = np.log(3.0)
"""Spread of the trend scale's hyperprior (a factor 3: 2-180 um at 95 %, compensated to
uncompensated machines). With step diagonals alone the trend competes with the set-up
tilts for the same readings and the evidence can collapse it: with a factor 30 one
machine of the study (20 machines) got a trend scale of 2.4 um for slopes of 8-10 um and
its 95 % intervals covered 0.57 of the grid; with a factor 3 the 20 machines cover 0.935
pooled (0.919 before), worst 0.68, and the other designs do not change."""
NUGGET = True
"""Estimate a short-wavelength ("nugget") part of the positioning errors' prior
(:attr:`volcal.identify.prior.PriorStructure.nugget_um`): independent at every point, what
a lead screw's cyclic error (period 5-20 mm, shorter than the node spacing) is to an
estimator on nodes. Its scale is chosen by the evidence with the others and enters the
predicted uncertainty between the nodes (:meth:`IdentificationResult.predict`)."""
NUGGET_CENTRE_UM = 0.2
"""Centre of the nugget scale's hyperprior [um RMS]: a ground screw's cyclic error."""
NUGGET_SPREAD = np.log(10.0)
"""Spread of the nugget scale's hyperprior (a factor 10)."""
PER_AXIS_SPREAD: dict[int, float] = {}
"""Groups whose scale may differ per axis, with the spread (one standard deviation, as a
log factor) of each axis' scale around the group's. Empty: measured on the study's step
diagonals (8 machines), a positioning scale per axis (spread a factor 3) gave a median
ratio to minimum-norm least squares of 1.11 and a pooled coverage of 0.79 against 0.97
and 0.87 with one scale (before the positioning trend of :data:`TREND_CENTRE_UM`), and
0.88 / 0.92 against 0.86 / 0.94 with it; kept as an extension point."""
DENSE_COVARIANCE_LIMIT = 6000
DENSE_QR_LIMIT = 2000
DENSE_QR_ENTRIES = 2_000_000  # 16 MB of float64 for the stacked matrix


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
        travel [um] (:attr:`volcal.identify.prior.PriorStructure.trend_um`; 0: none).
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
        ``P(roll | y)`` of the two-model average (:data:`ROLL_MIXTURE_ABSENT`); None when
        the average was not taken (off, no roll block, or rolls stated).
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
    nugget_um: float = 0.0
    roll_log_bayes_factor: float | None = None
    roll_probability: float | None = None


def solve_bayes(design: Design, prior: PriorStructure, scales: NDArray[np.float64] | None = None,
                noise_um: float | None = None, squareness_std: float = 100.0,
                covariance: bool = True, tilt_std: float | None = None,
                roll_presence: bool = True) -> Solution:
    """Bayesian least squares with evidence-optimised hyperparameters.

    Parameters
    ----------
    design : Design
        Observation system.
    prior : PriorStructure
        Smoothness prior blocks.
    scales : ndarray, shape (4,) or (18,), optional
        Fixed amplitude scales of the groups or of each function
        (:func:`volcal.identify.prior.function_scales`); default estimated.
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
        of :data:`ROLL_MIXTURE_ABSENT`). False for a solve that only chooses the
        hyperparameters, whose estimate is not kept.

    Returns
    -------
    Solution
    """
    ev = _Evidence(design, prior, squareness_std)
    free_scales = scales is None
    free_sigma = noise_um is None
    if scales is not None:
        f_fixed = function_scales(scales)
        s_groups = _group_scales(f_fixed)
    sig0 = 0.5 if noise_um is None else float(noise_um)
    y_scale = max(float(np.sqrt(ev.yty / max(ev.n, 1))), 1e-3)
    sig_floor = 1e-7 * y_scale
    k0 = prior.kappa
    M, centre, spread = _hyper_map()
    # scale-like hyperparameters beyond the 18 functions:
    # (gradient index, hyperprior centre, bounds, hyperprior spread)
    extra = []
    free_tilt = free_scales and tilt_std is None and ev.has_tilts
    if free_tilt:  # the set-up tilts' scale
        extra.append((20, np.log(TILT_CENTRE_URAD), (np.log(1e-1), np.log(1e5)), TILT_SPREAD))
    elif tilt_std is not None:
        ev.set_tilt_std(tilt_std)
    free_trend = free_scales and any(f in TREND_FUNCTIONS for *_, f in prior.blocks)
    if free_trend:  # the positioning trend's scale
        extra.append((21, np.log(TREND_CENTRE_UM), (np.log(1e-2), np.log(1e4)), TREND_SPREAD))
    if free_scales and NUGGET and any(f in TREND_FUNCTIONS for *_, f in prior.blocks):
        extra.append((26, np.log(NUGGET_CENTRE_UM), (np.log(1e-4), np.log(1e2)), NUGGET_SPREAD))
    if free_scales and KAPPA_FACTOR_SPREAD > 0:  # a curvature factor per group
        extra.extend((22 + g, 0.0, (-np.log(1e2), np.log(1e2)), KAPPA_FACTOR_SPREAD)
                     for g in FREE_GROUPS)
    m0 = M.shape[1]
    for j, (_, c, _, sd) in enumerate(extra):
        M = np.vstack([np.hstack([M, np.zeros((M.shape[0], 1))]),
                       np.eye(1, m0 + j + 1, m0 + j)])
        centre = np.append(centre, c)
        spread = np.append(spread, sd)
    ns = M.shape[1]

    def unpack(h):
        """Hyperparameter vector -> (function scales (18,), sigma, kappa); sets the tilts'."""
        i = 0
        fsc, sig, kap = (None, sig0, k0) if free_scales else (f_fixed, sig0, k0)
        if free_scales:
            logs = M @ h[:ns]
            fsc = np.exp(logs[:18])
            factor = np.ones(len(DEFAULT_SCALES))
            for j, (gi, *_) in enumerate(extra):
                if gi == 20:
                    ev.set_tilt_std(float(np.exp(logs[18 + j])))
                elif gi == 21:
                    ev.prior = ev.prior.with_trend(float(np.exp(logs[18 + j])))
                elif gi == 26:
                    ev.prior = ev.prior.with_nugget(float(np.exp(logs[18 + j])))
                else:
                    factor[gi - 22] = np.exp(logs[18 + j])
            if 2 not in FREE_GROUPS:
                factor[2] = factor[3]  # the roll takes the tilts' curvature too
            ev.prior = ev.prior.with_kappa_factor(factor)
            kap = float(np.exp(h[ns]))
            i = ns + 1
        if free_sigma:
            sig = float(np.exp(h[i]))
        return fsc, sig, kap

    h0 = []
    bounds = []
    if free_scales:
        h0 += list(centre) + [np.log(k0)]
        n_base = len(FREE_GROUPS)
        bounds += ([(np.log(1e-2), np.log(1e4))] * n_base
                   + [(-np.log(1e3), np.log(1e3))] * (ns - n_base - len(extra))
                   + [bd for _, _, bd, _ in extra]
                   + [(np.log(1.0), np.log(1e4))])
    if free_sigma:
        h0.append(np.log(sig0))
        bounds.append((np.log(sig_floor), np.log(1e3)))
    if h0:
        def fun(h):
            fsc, sig, kap = unpack(h)
            val, g20 = ev.neg2_grad_functions(fsc, sig, kap)
            grad = np.zeros(len(h))
            i = 0
            if free_scales:  # weak log-normal hyperprior: typical machines
                z = (np.append(h[:ns], np.log(kap)) - np.append(centre, HYPER_CENTRE[-1])) \
                    / np.append(spread, HYPER_SPREAD)
                val += float(z @ z)
                # a tied roll's curvature factor is the tilts' (gradient index 22 + group)
                g_scales = np.append(g20[:18], [
                    g20[gi] + (g20[24] if gi == 25 and 2 not in FREE_GROUPS else 0.0)
                    for gi, *_ in extra])
                grad[:ns] = M.T @ g_scales + 2.0 * z[:ns] / spread
                grad[ns] = g20[18] + 2.0 * z[ns] / HYPER_SPREAD
                i = ns + 1
            if free_sigma:
                grad[i] = g20[19]
            return val, grad
        # coarse start for sigma: scan a few decades, then MacKay's fixed point
        # sigma^2 = |r|^2 / (n - gamma) (gamma: effective number of parameters), so that the
        # quasi-Newton steps start near the optimum of the steepest direction
        if free_sigma:
            grid = np.log(np.geomspace(max(sig_floor, 1e-6), 10.0, 8))
            vals = []
            for g in grid:
                h = np.array(h0)
                h[-1] = g
                vals.append(ev.neg2(*unpack(h)))
            h0[-1] = grid[int(np.argmin(vals))]
            for _ in range(SIGMA_FIXED_POINT_STEPS):
                ev.neg2_grad_functions(*unpack(np.array(h0)))
                if ev.last_fit is None:
                    break
                rr, gamma = ev.last_fit
                s2 = rr / max(ev.n - gamma, 1.0)
                h0[-1] = float(np.clip(0.5 * np.log(max(s2, 1e-300)), *bounds[-1]))
        history: list[float] = []

        def flat() -> bool:
            # three iterations improving -2 log evidence by less than EVIDENCE_TOL change
            # nothing a user sees (flat directions, e.g. a scale the data hardly inform,
            # otherwise take dozens of tiny steps)
            return len(history) > 3 and history[-4] - history[-1] < EVIDENCE_TOL

        def stop_when_flat(intermediate_result):
            history.append(float(intermediate_result.fun))
            if flat():
                raise StopIteration

        w = _preconditioner(ev, free_scales, free_sigma, M, extra, spread, unpack, h0)

        def fun_w(z):  # the search runs on h * w: curvatures of order one
            val, grad = fun(z / w)
            return val, grad / w

        res = minimize(fun_w, np.array(h0) * w, method="L-BFGS-B", jac=True,
                       bounds=[(lo * wi, hi * wi) for (lo, hi), wi in zip(bounds, w, strict=True)],
                       callback=stop_when_flat,
                       options={"maxiter": 200, "ftol": 1e-10, "gtol": 1e-2})
        res.x = res.x / w
        if flat():
            res.success = True
            res.message = (f"CONVERGENCE: -2 log evidence improved by less than {EVIDENCE_TOL:g} "
                           "in 3 iterations")
        name = "L-BFGS-B"
        if not res.success:
            # the quasi-Newton step can stall on a flat or kinked evidence surface: fall
            # back to the derivative-free simplex from the best point found
            res2 = minimize(lambda h: fun(h)[0], res.x, method="Nelder-Mead", bounds=bounds,
                            options={"xatol": 5e-3, "fatol": 1e-3, "maxiter": 600})
            if res2.fun <= res.fun:
                res, name = res2, "L-BFGS-B, then Nelder-Mead"
        h_opt = res.x
        neg2 = float(res.fun)
        convergence = {"optimiser": name, "converged": bool(res.success),
                       "iterations": int(res.nit), "evaluations": int(ev.evaluations),
                       "message": str(res.message)}
    else:
        h_opt = np.array([])
        neg2 = ev.neg2(f_fixed, sig0)
        convergence = {"optimiser": "none (hyperparameters given)", "converged": True,
                       "iterations": 0, "evaluations": 1, "message": ""}
    f_opt, sigma, kappa = unpack(h_opt)  # also sets the tilts' scale
    if free_scales:
        f_opt = f_opt.copy()
        if not ROLL_SPREAD > 0:  # a fixed factor (with a spread, the evidence sets it)
            f_opt[[6 * k + 3 + k for k in range(3)]] *= ROLL_FACTOR  # EAX, EBY, ECZ
    scales_opt = _group_scales(f_opt) if free_scales else s_groups
    if kappa != ev.prior.kappa:
        ev.prior = ev.prior.with_kappa(kappa)
    H, Q, cf, x, cov = _final_solve(ev, design, f_opt, sigma, covariance)
    rho: dict[int, float] = {}
    if free_scales and cov is not None and not ROLL_SPREAD > 0:
        if ROLL_ABSENT_PROBABILITY > 0:
            rho = _roll_presence_factors(ev.prior, f_opt, x, cov, ROLL_ABSENT_PROBABILITY)
        elif ROLL_MARGINAL_SPREAD > 0:
            rho = _roll_marginal_factors(ev.prior, f_opt, x, cov, ROLL_MARGINAL_SPREAD)
    if rho:
        for f, r in rho.items():
            f_opt[f] *= r
        H, Q, cf, x, cov = _final_solve(ev, design, f_opt, sigma, covariance)
    roll_lbf = (roll_log_bayes_factor(ev.prior, f_opt, x, cov)
                if cov is not None and roll_presence else None)
    solve = lambda rhs: _polish(H, cf, rhs)  # noqa: E731
    p_roll = None
    cov_fit = cov  # the linear fit's: its hat matrix gives the effective parameters
    if ROLL_MIXTURE_ABSENT > 0 and roll_lbf is not None:
        mixed = _roll_mixture(ev.prior, f_opt, x, cov, roll_lbf, ROLL_MIXTURE_ABSENT,
                              ROLL_MIXTURE_RHO0, design.extra_precision)
        if mixed is not None:
            x, cov, shrink, p_roll = mixed
            if shrink is not None:
                solve = lambda rhs: shrink(_polish(H, cf, rhs))  # noqa: E731
    r = design.y - design.A @ x
    if design.prior_mean is not None and np.any(design.prior_mean):
        x = x + design.prior_mean
    if cov_fit is not None:
        edf = float(np.sum(ev.AtA * cov_fit.T) / sigma**2)
    else:
        edf = float(min(H.shape[0], ev.n))
    dof = max(ev.n - edf, 1.0)
    s_res = float(np.sqrt(r @ r / dof))
    return Solution(x, cov, sigma, s_res, scales_opt, -0.5 * neg2, dof, "bayes",
                    solve=solve, kappa=kappa,
                    convergence=convergence, function_scales=f_opt, ata=ev.AtA,
                    tilt_std_urad=ev.tilt_std if ev.has_tilts else None,
                    trend_um=ev.prior.trend_um, kappa_factor=ev.prior.kappa_factor,
                    nugget_um=ev.prior.nugget_um, roll_log_bayes_factor=roll_lbf,
                    roll_probability=p_roll)


def _hyper_map() -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Log function scales as a linear map of the free scale hyperparameters.

    Returns
    -------
    M : ndarray, shape (18, m)
        ``log a_f = (M h)_f``: ``h`` holds the log scales of :data:`FREE_GROUPS` (the roll
        takes the tilts'), then one log factor per axis of each group of
        :data:`PER_AXIS_SPREAD`.
    centre, spread : ndarray, shape (m,)
        Log-normal hyperprior of each hyperparameter (centre, one standard deviation).
    """
    groups = list(FREE_GROUPS)
    per_axis = sorted(PER_AXIS_SPREAD)
    roll_col = ROLL_SPREAD > 0 and 2 not in groups
    n_roll = 3 if roll_col else 0  # one factor per roll: an unseen roll keeps its prior
    m = len(groups) + 3 * len(per_axis) + n_roll
    M = np.zeros((18, m))
    for k in range(3):
        for c in range(6):
            g = function_group(k, c)
            base = g if g in groups else 3  # roll -> tilt
            M[6 * k + c, groups.index(base)] = 1.0
            if g in PER_AXIS_SPREAD:
                M[6 * k + c, len(groups) + 3 * per_axis.index(g) + k] = 1.0
            if g == 2 and roll_col:  # the roll's factor over the tilts
                M[6 * k + c, m - 3 + k] = 1.0
    centre = np.concatenate([HYPER_CENTRE[groups], np.zeros(3 * len(per_axis)),
                             [np.log(ROLL_FACTOR)] * n_roll])
    spread = np.concatenate([np.full(len(groups), HYPER_SPREAD),
                             np.repeat([PER_AXIS_SPREAD[g] for g in per_axis], 3),
                             [ROLL_SPREAD] * n_roll])
    return M, centre, spread


def _group_scales(fscales: NDArray[np.float64]) -> NDArray[np.float64]:
    """Geometric mean of the function scales of each group of :data:`GROUPS`."""
    out = np.zeros(len(DEFAULT_SCALES))
    n = np.zeros(len(DEFAULT_SCALES))
    for k in range(3):
        for c in range(6):
            g = function_group(k, c)
            out[g] += np.log(fscales[6 * k + c])
            n[g] += 1
    return np.exp(out / n)


def _preconditioner(ev: _Evidence, free_scales: bool, free_sigma: bool, M, extra, spread,
                    unpack, h0) -> NDArray[np.float64]:
    """Diagonal scaling of the hyperparameters for the quasi-Newton search.

    The curvature of ``-2 log evidence`` in the log of a scale is about twice the effective
    number of parameters that scale governs (``gamma``: the data-determined share of its
    functions, ``tr(Q^-1 dQ) - tr(H^-1 dQ)`` halved), plus the hyperprior's ``2 / spread^2``;
    the noise governs ``n - gamma`` readings. Without the scaling the first steps of
    L-BFGS-B, dominated by the noise (thousands of readings) and the curvature, went to the
    bounds and back (52-66 evaluations on the seeds' set).
    """
    ev.neg2_grad_functions(*unpack(np.array(h0)))
    g = ev.last_gamma if ev.last_gamma is not None else np.ones(N_HYPER)
    c = []
    if free_scales:
        gs = np.append(g[:18], [g[gi] for gi, *_ in extra])
        c += list((M**2).T @ (2.0 * np.abs(gs)) + 2.0 / spread**2)
        c.append(2.0 * abs(g[18]) + 2.0 / HYPER_SPREAD**2)
    if free_sigma:
        c.append(2.0 * abs(g[19]))
    return np.sqrt(np.maximum(np.array(c), 1.0))


def _final_solve(ev: _Evidence, design: Design, fscales, sigma: float, covariance: bool):
    """Factor, estimate and (dense) posterior covariance at the final hyperparameters.

    Returns
    -------
    (H, Q, cf, x, cov)
        Posterior precision, prior precision, Cholesky factor of ``H``, estimate (without
        the design's prior mean) and covariance (None when too large or not wanted).
    """
    H, Q, cf = _final_factor(ev, fscales, sigma)
    N = H.shape[0]
    if N <= DENSE_QR_LIMIT and (ev.n + N) * N <= DENSE_QR_ENTRIES:
        x, cov = _dense_qr(design, sp.csc_matrix(Q), sigma)
    else:
        x = _polish(H, cf, ev.Aty / sigma**2, steps=4)
        cov = None
        if covariance and N <= DENSE_COVARIANCE_LIMIT:
            cov = sla.cho_solve(cf, np.eye(N), check_finite=False)
    return H, Q, cf, x, cov


ROLL_FUNCTIONS: tuple[int, ...] = (3, 10, 17)
"""Function indices ``6 * axis + component`` of the rolls EAX, EBY, ECZ."""


def _roll_marginal_factors(prior: PriorStructure, fscales, x, cov, spread: float,
                           tol: float = 0.02) -> dict[int, float]:
    """Each roll's prior scale factor, integrated over its hyperprior given the readings.

    For a roll block with prior covariance ``C = a^2 P^-1`` and posterior mean ``m`` and
    covariance ``S`` (all other unknowns integrated out), the readings' information on the
    roll is Gaussian; in coordinates whitened by ``C`` with ``S_u = V diag(s) V'`` the
    log evidence of the prior ``rho^2 C`` is, up to a constant,

    ``l(rho) = -1/2 sum log(1 + rho^2 k_i) + 1/2 sum rho^2 b_i^2 / (1 + rho^2 k_i)``,

    ``k_i = 1/s_i - 1`` (the data's precision), ``b_i = (V' L^-1 m)_i / s_i``. With the
    hyperprior ``log rho ~ N(-w^2, w^2)`` (``E[rho^2] = 1``) the returned factor is
    ``sqrt(E[rho^2 | y])`` on a grid of 61 points over +-4 w (MacKay 1992; Gelman et al.,
    *Bayesian Data Analysis*, 3rd ed., 5.3: integrating a hierarchical scale out rather
    than maximising over it).

    Parameters
    ----------
    prior : PriorStructure
        Prior blocks (the rolls carry no trend or nugget).
    fscales : ndarray, shape (18,)
        Function scales used for ``x`` and ``cov`` [um, urad].
    x, cov : ndarray
        Posterior mean (without the design's prior mean) and covariance.
    spread : float
        ``w``, the hyperprior's spread (log factor).
    tol : float
        Factors within this relative distance of 1 are left out.

    Returns
    -------
    dict of int to float
        Function index -> factor ``rho`` (only rolls estimated here).
    """
    out: dict[int, float] = {}
    t = np.linspace(-4.0, 4.0, 61)
    rho2 = np.exp(2.0 * (-spread**2 + spread * t))
    for f in ROLL_FUNCTIONS:
        kb = _roll_whitened(prior, fscales, x, cov, (f,))
        if kb is None:
            continue
        lp = _roll_log_likelihood(*kb, rho2) - 0.5 * t**2  # + the hyperprior
        w = np.exp(lp - lp.max())
        r = float(np.sqrt(np.sum(w * rho2) / np.sum(w)))
        if abs(r - 1.0) > tol:
            out[f] = r
    return out


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
    the squared projections ``b_i^2 = ((V' u)_i / s_i)^2`` (:func:`_roll_marginal_factors`),
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
    return None if kb is None else float(_roll_log_likelihood(*kb, 1.0))


def _roll_presence_factors(prior: PriorStructure, fscales, x, cov, p_absent: float,
                           tol: float = 0.02) -> dict[int, float]:
    """The rolls' prior scale factor averaged over "no roll" and "roll" given the readings.

    Two hypotheses for the machine: no roll errors (scale 0, prior probability ``p``), or
    rolls at ``rho_s = 1 / sqrt(1 - p)`` times the current scale. With the three rolls'
    data information in whitened coordinates (:func:`_roll_whitened`) the log Bayes factor
    of "roll" over "no roll" is ``L = -1/2 sum log(1 + rho_s^2 k_i) + 1/2 sum rho_s^2 b_i^2
    / (1 + rho_s^2 k_i)`` and the returned factor ``sqrt(P(roll | y)) rho_s`` (the
    posterior mean of the variance; ``E[rho^2] = 1`` a priori). References: Mitchell and
    Beauchamp (1988), spike-and-slab priors; Hoeting et al. (1999), Bayesian model
    averaging.

    Returns
    -------
    dict of int to float
        Roll function index -> factor (empty when within ``tol`` of 1 or no roll block).
    """
    kb = _roll_whitened(prior, fscales, x, cov)
    if kb is None:
        return {}
    r2 = 1.0 / (1.0 - p_absent) if ROLL_PRESENT_FACTOR is None else ROLL_PRESENT_FACTOR**2
    L = float(_roll_log_likelihood(*kb, r2))
    # P(roll | y) = (1 - p) e^L / ((1 - p) e^L + p), written to avoid overflow
    z = np.log(p_absent) - np.log1p(-p_absent) - L
    p_roll = float(np.exp(-np.logaddexp(0.0, z)))
    r = float(np.sqrt(p_roll * r2))
    if abs(r - 1.0) <= tol:
        return {}
    return {f: r for f in ROLL_FUNCTIONS
            if any(blk[4] == f for blk in prior.blocks)}


def _roll_mixture(prior: PriorStructure, fscales, x, cov, log_bf: float, p_absent: float,
                  rho0: float = 0.0, soft: NDArray[np.float64] | None = None):
    """Average of the fit with rolls and the fit without, weighted by the readings.

    The fit without roll is the fit with rolls conditioned on zero roll at every free
    node (the rolls' prior is independent of the other unknowns, so conditioning the
    posterior equals refitting with the rolls removed): ``x0 = x - K x_R``, ``C0 = C -
    K C_RR K'`` with ``K = C_:R C_RR^-1``. With ``rho0 > 0`` the second model has rolls
    at ``rho0`` times the scale: the extra prior precision ``(1/rho0^2 - 1) Q_R`` is a
    pseudo-reading ``x_R = 0`` and ``K = C_:R (C_RR + D)^-1``, ``D = rho0^2 / (1 -
    rho0^2) Q_R^-1``. With ``P = P(roll | y)`` from the log Bayes factor ``log_bf`` and
    the prior probability ``p_absent`` of no roll, the mixture's mean is ``x_m = x - (1 -
    P) d``, ``d = K x_R`` (Hoeting et al. 1999, Bayesian model averaging); its covariance
    (:data:`ROLL_MIXTURE_COVARIANCE`) ``C + (1 - P)^2 d d'`` (default) or the mixture's
    own ``C - (1 - P) K C_RR K' + P (1 - P) d d'``.

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
    rho0 : float
        Roll scale factor of the second model (0: no roll).
    soft : ndarray, optional
        The design's extra precision of stated values: rolls stated by the user are left
        as they are.

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
    if rho0 > 0:
        kb = _roll_whitened(prior, fscales, x, cov)
        log_bf = log_bf - float(_roll_log_likelihood(*kb, rho0**2))
    z = np.log(p_absent) - np.log1p(-p_absent) - log_bf
    p_roll = float(np.exp(-np.logaddexp(0.0, z)))
    q = 1.0 - p_roll
    if q < 1e-9:  # the readings settle it: the fit with rolls
        return x, cov, None, p_roll
    CRR = cov[np.ix_(R, R)]
    if rho0 > 0:
        CRR = CRR + sla.block_diag(*D) * rho0**2 / (1.0 - rho0**2)
    # C_RR^-1 in the rolls' prior scale (D): directions the readings pin to within 1e-12
    # of their prior variance are held at that floor (noise-free data)
    T = np.sqrt(np.diag(sla.block_diag(*D)))
    sv, V = np.linalg.eigh(CRR / np.outer(T, T))
    sv = np.maximum(sv, 1e-12 * max(float(sv.max()), 1e-300))
    K = (cov[:, R] / T) @ (V / sv) @ V.T / T  # C_:R C_RR^-1
    d = K @ x[R]
    xm = x - q * d
    if ROLL_MIXTURE_COVARIANCE == "roll":
        cm = cov + q * q * np.outer(d, d)
    else:
        cm = cov - q * (K @ cov[R, :]) + p_roll * q * np.outer(d, d)

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
    M = np.vstack([A, Rp])
    rhs = np.concatenate([design.y / sigma, np.zeros(Rp.shape[0])])
    Qm, Rm = np.linalg.qr(M, mode="reduced")
    x = sla.solve_triangular(Rm, Qm.T @ rhs)
    Rinv = sla.solve_triangular(Rm, np.eye(Rm.shape[0]))
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
    return Solution(x, cov, sig, s_res, np.full(len(DEFAULT_SCALES), np.nan), float("nan"),
                    float(dof), "min-norm",
                    convergence={"optimiser": "SVD (no hyperparameters)", "converged": True,
                                 "iterations": 0, "evaluations": 0, "message": ""})
