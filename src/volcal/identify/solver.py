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
from volcal.identify.prior import PriorStructure

__all__ = ["Solution", "solve_bayes", "solve_min_norm"]

NUISANCE_PRECISION = {"offset": 1e-10, "tilt": 1e-8, "reversal": 1e-8, "drift": 1e-8,
                      "station_x": 1e-10, "station_y": 1e-10, "station_z": 1e-10}
DEFAULT_SCALES = np.array([10.0, 5.0, 15.0, 15.0])
"""Typical amplitude scales of machining centres: positioning [um], straightness [um],
roll [urad], tilts [urad]."""
HYPER_CENTRE = np.log([*DEFAULT_SCALES, 6.0])
"""Centre of the hyperprior: the amplitude scales above and the curvature scale; it
only matters for groups the data do not inform (there it holds the scale)."""
HYPER_SPREAD = np.log(30.0)
"""Spread of the log-normal hyperprior (one standard deviation, as a factor of 30): weak,
it only holds scales the data do not inform."""
SEPARATE_ROLL = False
"""Estimate the roll scale separately (shrunk towards the tilts by :data:`ROLL_TIE`).
Off: the prior has a roll group of its own (``GROUPS``) but its scale is the tilts'.
Measured on the seeds' full test set (exact simulation, 0.5 um noise, three chains): a
free roll scale went to 3.7 urad on one machine and 18.8 on another, and the 95 %
intervals covered 0.65 and 1.00 of the grid (rigid-body motion removed); a roll shrunk
towards the tilts by a factor 2 still gave 0.77 and 1.00; sharing the tilts' scale gives
0.94-0.98 on the same machines. Lines, diagonals and step diagonals see the rolls only
through a few lever arms, too little for the evidence to set their scale."""
ROLL_TIE = np.log(2.0)
"""Spread of the roll scale around the tilt scale when :data:`SEPARATE_ROLL` (a factor)."""
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
    convergence : dict or None
        Evidence optimiser record: ``optimiser``, ``iterations``, ``evaluations``,
        ``converged`` (bool), ``message``.
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


def _nuisance_precision(design: Design) -> NDArray[np.float64]:
    return np.array([NUISANCE_PRECISION[n.rsplit(":", 1)[1].rstrip("12")]
                     for n in design.nuisance_names])


class _Evidence:
    """Negative twice the log evidence, on a dense posterior precision."""

    def __init__(self, design: Design, prior: PriorStructure, squareness_std: float) -> None:
        self.A = design.A.tocsc()
        AtA = (self.A.T @ self.A).tocsc()
        self.AtA_sparse = AtA
        self.AtA = AtA.toarray()
        self.Aty = self.A.T @ design.y
        self.y = design.y
        self.yty = float(design.y @ design.y)
        self.n = design.y.size
        self.prior = prior
        self.sq_std = squareness_std
        self.nprec = _nuisance_precision(design)
        self.N = self.AtA.shape[0]
        ex = design.extra_precision
        self.extra = ex if ex is not None and np.any(ex) else None
        self.evaluations = 0

    def _parts(self):
        """Dense curvature and amplitude parts of each prior group (built once)."""
        if not hasattr(self, "_cw"):
            ng = len(DEFAULT_SCALES)
            C = np.zeros((ng, self.N, self.N))
            W = np.zeros((ng, self.N, self.N))
            for idx, Cb, Wb, g in self.prior.blocks:
                ix = np.ix_(idx, idx)
                C[g][ix] += Cb
                W[g][ix] += Wb
            diag = np.zeros(self.N)
            diag[self.prior.squareness] = 1.0 / self.sq_std**2
            diag[self.prior.n_free:] = self.nprec
            if self.extra is not None:
                diag += self.extra
            self._cw = (C, W, diag)
        return self._cw

    def prior_dense(self, scales, kappa=None):
        if kappa is not None and kappa != self.prior.kappa:
            self.prior = self.prior.with_kappa(kappa)
        C, W, diag = self._parts()
        k2 = self.prior.kappa**2
        Q = np.zeros((self.N, self.N))
        for g in range(C.shape[0]):
            if g < len(scales):
                Q += (C[g] / k2 + W[g]) / scales[g] ** 2
        Q[np.diag_indices_from(Q)] += diag
        return Q

    def logdet_prior(self, scales) -> float:
        """``log det Q`` from per-block determinants cached per curvature scale."""
        cache = self.__dict__.setdefault("_ld", {})
        key = float(self.prior.kappa)
        if key not in cache:
            k2 = key**2
            cache[key] = [(np.linalg.slogdet(Cb / k2 + Wb)[1], Cb.shape[0], g)
                          for _, Cb, Wb, g in self.prior.blocks]
        total = sum(ld - 2 * n * np.log(scales[g]) for ld, n, g in cache[key])
        return float(total - 2 * self.prior.squareness.size * np.log(self.sq_std)
                     + np.sum(np.log(self.nprec)))

    def factor(self, scales, sigma, kappa=None):
        Q = self.prior_dense(scales, kappa)
        H = self.AtA / sigma**2 + Q
        return H, Q, sla.cho_factor(H, lower=True, check_finite=False)

    def _value(self, scales, sigma, kappa=None):
        """``neg2`` with the parts its gradient reuses.

        Returns ``(value, Q, cf, cq, x, |r|^2)``, ``cq`` the Cholesky factor of ``Q`` when
        it is not block diagonal (else None).
        """
        H, Q, cf = self.factor(scales, sigma, kappa)
        b = self.Aty / sigma**2
        x = sla.cho_solve(cf, b, check_finite=False)
        # the data term y'y/s^2 - b'H^-1 b as the minimum it is, |y - A x|^2/s^2 + x'Q x:
        # no cancellation of two huge numbers when the data are nearly reproduced (tiny
        # s), and stationary in x, so a solve error enters only to second order
        r = self.y - self.A @ x
        rr = float(r @ r)
        data = rr / sigma**2 + float(x @ (Q @ x))
        logdet_h = 2.0 * float(np.sum(np.log(np.diag(cf[0]))))
        cq = None
        if self.extra is None:
            logdet_q = self.logdet_prior(scales)
        else:
            cq = sla.cho_factor(Q, lower=True, check_finite=False)
            logdet_q = 2.0 * float(np.sum(np.log(np.diag(cq[0]))))
        val = data + logdet_h - logdet_q + self.n * np.log(2 * np.pi * sigma**2)
        return float(val), Q, cf, cq, x, rr

    def neg2(self, scales, sigma, kappa=None) -> float:
        self.evaluations += 1
        try:
            return self._value(scales, sigma, kappa)[0]
        except (np.linalg.LinAlgError, sla.LinAlgError):
            return 1e300

    def neg2_grad(self, scales, sigma, kappa=None) -> tuple[float, NDArray[np.float64]]:
        """``neg2`` and its gradient in ``log`` of (the four scales, kappa, sigma).

        With ``D = |y - A x|^2 / s^2 + x'Q x`` at the posterior mean ``x`` (stationary, so
        only explicit dependences count), ``Q = sum_g (C_g / kappa^2 + W_g) / s_g^2 + diag``
        and ``H = A'A / s^2 + Q`` (Rasmussen & Williams 2006, eq. 5.9):

        * ``d/dlog s_g  = -2 x'Q_g x - 2 tr(H^-1 Q_g) + 2 n_g``,
        * ``d/dlog kappa = -2 x'K x - 2 tr(H^-1 K) + 2 tr(Q^-1 K)``, ``K = sum_g C_g /
          (kappa^2 s_g^2)``,
        * ``d/dlog sigma = -2 |r|^2 / s^2 - 2 tr(H^-1 A'A) / s^2 + 2 n``,

        where ``n_g`` is the number of parameters of group ``g`` (``log det Q`` holds
        ``-2 n_g log s_g``) and ``tr(H^-1 A'A) / s^2 = N - tr(H^-1 Q)``.
        """
        self.evaluations += 1
        ng = len(DEFAULT_SCALES)
        try:
            val, Q, cf, cq, x, rr = self._value(scales, sigma, kappa)
        except (np.linalg.LinAlgError, sla.LinAlgError):
            return 1e300, np.zeros(ng + 2)
        C, W, diag = self._parts()
        k2 = self.prior.kappa**2
        Hinv = _inverse_from_cholesky(cf)
        Qinv = None if cq is None else sla.cho_solve(cq, np.eye(self.N), check_finite=False)
        grad = np.zeros(ng + 2)
        tr_hq = 0.0
        for g in range(ng):
            Qg = (C[g] / k2 + W[g]) / scales[g] ** 2
            Kg = C[g] / (k2 * scales[g] ** 2)
            t_hq = float(np.sum(Hinv * Qg))
            tr_hq += t_hq
            if Qinv is None:
                t_qq = float(self._group_size(g))
                t_qk = float(self._kappa_trace(g))
            else:
                t_qq = float(np.sum(Qinv * Qg))
                t_qk = float(np.sum(Qinv * Kg))
            grad[g] = -2.0 * float(x @ (Qg @ x)) - 2.0 * t_hq + 2.0 * t_qq
            grad[ng] += -2.0 * float(x @ (Kg @ x)) - 2.0 * float(np.sum(Hinv * Kg)) + 2.0 * t_qk
        tr_hq += float(np.diag(Hinv) @ diag)
        grad[ng + 1] = -2.0 * rr / sigma**2 - 2.0 * (self.N - tr_hq) + 2.0 * self.n
        return float(val), grad

    def _group_size(self, g: int) -> int:
        return sum(Cb.shape[0] for _, Cb, _, gb in self.prior.blocks if gb == g)

    def _kappa_trace(self, g: int) -> float:
        """``tr(Q^-1 K)`` of group ``g`` from its blocks.

        ``Q`` is block diagonal when no extra precision is given:
        ``tr((C/k2 + W)^-1 C / k2)`` per block.
        """
        cache = self.__dict__.setdefault("_kt", {})
        key = (float(self.prior.kappa), g)
        if key not in cache:
            k2 = key[0] ** 2
            cache[key] = sum(float(np.trace(np.linalg.solve(Cb / k2 + Wb, Cb / k2)))
                             for _, Cb, Wb, gb in self.prior.blocks if gb == g)
        return cache[key]


def _inverse_from_cholesky(cf) -> NDArray[np.float64]:
    """``H^-1`` from the lower Cholesky factor of ``H``.

    LAPACK ``potri``: a third of the work of solving against the identity.
    """
    inv, info = sla.lapack.dpotri(cf[0], lower=True)
    if info != 0:
        return sla.cho_solve(cf, np.eye(cf[0].shape[0]), check_finite=False)
    inv = np.tril(inv)
    return inv + np.tril(inv, -1).T


def solve_bayes(design: Design, prior: PriorStructure, scales: NDArray[np.float64] | None = None,
                noise_um: float | None = None, squareness_std: float = 100.0,
                covariance: bool = True) -> Solution:
    """Bayesian least squares with evidence-optimised hyperparameters.

    Parameters
    ----------
    design : Design
        Observation system.
    prior : PriorStructure
        Smoothness prior blocks.
    scales : ndarray, shape (3,), optional
        Fixed amplitude scales; default estimated.
    noise_um : float, optional
        Stated reading repeatability [um]; default estimated.
    squareness_std : float
        Prior standard deviation of the squareness errors [urad].
    covariance : bool
        Compute the dense posterior covariance (when not too large).

    Returns
    -------
    Solution
    """
    ev = _Evidence(design, prior, squareness_std)
    free_scales = scales is None
    free_sigma = noise_um is None
    s0 = DEFAULT_SCALES.copy() if scales is None else np.asarray(scales, dtype=float)
    if s0.shape != (len(DEFAULT_SCALES),):
        raise ValueError(f"scales: expected {len(DEFAULT_SCALES)} amplitude scales "
                         "(positioning, straightness, roll, tilts)")
    sig0 = 0.5 if noise_um is None else float(noise_um)
    y_scale = max(float(np.sqrt(ev.yty / max(ev.n, 1))), 1e-3)
    sig_floor = 1e-7 * y_scale

    k0 = prior.kappa

    # free scale parameters: positioning, straightness, tilt (and roll when separate)
    free_groups = [0, 1, 3, 2] if SEPARATE_ROLL else [0, 1, 3]
    ns = len(free_groups)

    def unpack(h):
        i = 0
        sc, sig, kap = s0, sig0, k0
        if free_scales:
            sc = np.empty(len(DEFAULT_SCALES))
            sc[free_groups] = np.exp(h[:ns])
            if not SEPARATE_ROLL:
                sc[2] = sc[3]  # the roll takes the tilts' scale
            kap = float(np.exp(h[ns]))
            i = ns + 1
        if free_sigma:
            sig = float(np.exp(h[i]))
        return sc, sig, kap

    h0 = []
    bounds = []
    if free_scales:
        h0 += list(np.log(s0[free_groups])) + [np.log(k0)]
        bounds += [(np.log(1e-2), np.log(1e4))] * ns + [(np.log(1.0), np.log(1e4))]
    if free_sigma:
        h0.append(np.log(sig0))
        bounds.append((np.log(sig_floor), np.log(1e3)))
    if h0:
        ng = len(DEFAULT_SCALES)

        def fun(h):
            sc, sig, kap = unpack(h)
            val, g6 = ev.neg2_grad(sc, sig, kap)
            grad = np.zeros(len(h))
            i = 0
            if free_scales:  # weak log-normal hyperprior: typical machines, factor 30
                gs = g6[:ng].copy()
                z = (np.log(np.append(sc, kap)) - HYPER_CENTRE) / HYPER_SPREAD
                dz = 2.0 * z / HYPER_SPREAD
                if SEPARATE_ROLL:
                    z[2] = (np.log(sc[2]) - np.log(sc[3])) / ROLL_TIE  # shrunk to the tilts
                    dz[2] = 2.0 * z[2] / ROLL_TIE
                    dz[3] -= dz[2]
                else:
                    gs[3] += gs[2]  # the roll takes the tilts' scale
                    z[2] = dz[2] = 0.0
                val += float(z @ z)
                gs += dz[:ng]
                grad[:ns] = gs[free_groups]
                grad[ns] = g6[ng] + dz[ng]
                i = ns + 1
            if free_sigma:
                grad[i] = g6[ng + 1]
            return val, grad
        # coarse start for sigma: scan a few decades
        if free_sigma:
            grid = np.log(np.geomspace(max(sig_floor, 1e-6), 10.0, 8))
            vals = []
            for g in grid:
                h = np.array(h0)
                h[-1] = g
                vals.append(ev.neg2(*unpack(h)))
            h0[-1] = grid[int(np.argmin(vals))]
        res = minimize(fun, np.array(h0), method="L-BFGS-B", jac=True, bounds=bounds,
                       options={"maxiter": 200, "ftol": 1e-10, "gtol": 1e-2})
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
        neg2 = ev.neg2(s0, sig0)
        convergence = {"optimiser": "none (hyperparameters given)", "converged": True,
                       "iterations": 0, "evaluations": 1, "message": ""}
    scales_opt, sigma, kappa = unpack(h_opt)
    if kappa != ev.prior.kappa:
        ev.prior = ev.prior.with_kappa(kappa)
    H, Q, cf = ev.factor(scales_opt, sigma)
    N = H.shape[0]
    if N <= DENSE_QR_LIMIT and (ev.n + N) * N <= DENSE_QR_ENTRIES:
        x, cov = _dense_qr(design, sp.csc_matrix(Q), sigma)
    else:
        x = _polish(H, cf, ev.Aty / sigma**2, steps=4)
        cov = None
        if covariance and N <= DENSE_COVARIANCE_LIMIT:
            cov = sla.cho_solve(cf, np.eye(N), check_finite=False)
    r = design.y - design.A @ x
    if design.prior_mean is not None and np.any(design.prior_mean):
        x = x + design.prior_mean
    if cov is not None:
        edf = float(np.sum(ev.AtA * cov.T) / sigma**2)
    else:
        edf = float(min(N, ev.n))
    dof = max(ev.n - edf, 1.0)
    s_res = float(np.sqrt(r @ r / dof))
    return Solution(x, cov, sigma, s_res, scales_opt, -0.5 * neg2, dof, "bayes",
                    solve=lambda rhs: _polish(H, cf, rhs), kappa=kappa,
                    convergence=convergence)


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
