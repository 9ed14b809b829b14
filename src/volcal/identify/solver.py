"""Estimators over the assembled observation system.

* ``prior='smooth'`` (default): Bayesian least squares with the smoothness prior of
  :mod:`volcal.identify.prior`. The amplitude scales of the three function groups and the
  reading noise are chosen by maximising the marginal likelihood (type-II maximum
  likelihood, "evidence"; MacKay 1992, Rasmussen & Williams 2006 ch. 5). The posterior
  precision ``H = A^T A / sigma^2 + Q`` is sparse and factorised with SuperLU; the
  solution is polished by iterative refinement so that noise-free data are fitted to
  numerical precision.
* ``prior='none'``: minimum-norm least squares on the node values (the floor any
  estimator must beat), uncertainty ``s^2 (A^T A)^+``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray
from scipy.optimize import minimize

from volcal.identify.design import Design
from volcal.identify.prior import PriorStructure

__all__ = ["Solution", "solve_bayes", "solve_min_norm"]

NUISANCE_PRECISION = {"offset": 1e-10, "tilt": 1e-8, "reversal": 1e-8, "drift": 1e-8,
                      "station_x": 1e-10, "station_y": 1e-10, "station_z": 1e-10}
HYPER_CENTRE = np.log([10.0, 5.0, 15.0, 6.0])
"""Centre of the hyperprior: amplitude scales [um, um, urad] and curvature scale of
typical machining centres; it only matters for groups the data do not inform."""
HYPER_SPREAD = np.log(30.0)
DENSE_COVARIANCE_LIMIT = 6000
DENSE_QR_LIMIT = 2000
DENSE_QR_ENTRIES = 30_000_000  # 240 MB of float64 for the stacked matrix


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
    scales : ndarray, shape (3,)
        Prior amplitude scales (positioning [um], straightness [um], angular [urad]).
    kappa : float
        Curvature scale of the prior.
    log_evidence : float
        Log marginal likelihood at the optimum (nan for min-norm).
    dof : float
        Residual degrees of freedom ``n - trace(hat matrix)``.
    method : str
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


def _nuisance_precision(design: Design) -> NDArray[np.float64]:
    return np.array([NUISANCE_PRECISION[n.rsplit(":", 1)[1].rstrip("12")]
                     for n in design.nuisance_names])


class _Evidence:
    def __init__(self, design: Design, prior: PriorStructure, squareness_std: float) -> None:
        self.A = design.A.tocsc()
        self.AtA = (self.A.T @ self.A).tocsc()
        self.Aty = self.A.T @ design.y
        self.yty = float(design.y @ design.y)
        self.n = design.y.size
        self.prior = prior
        self.sq_std = squareness_std
        self.nprec = _nuisance_precision(design)
        self.N = self.AtA.shape[0]
        ex = design.extra_precision
        self.extra = ex if ex is not None and np.any(ex) else None

    def factor(self, scales, sigma, kappa=None):
        if kappa is not None and kappa != self.prior.kappa:
            self.prior = self.prior.with_kappa(kappa)
        Q = self.prior.precision(scales, self.sq_std, self.N, self.nprec)
        if self.extra is not None:
            Q = (Q + sp.diags(self.extra)).tocsc()
        H = (self.AtA / sigma**2 + Q).tocsc()
        lu = spla.splu(H, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
        return H, Q, lu

    def neg2(self, scales, sigma, kappa=None) -> float:
        try:
            H, Q, lu = self.factor(scales, sigma, kappa)
        except RuntimeError:
            return 1e300
        b = self.Aty / sigma**2
        x = lu.solve(b)
        logdet_h = float(np.sum(np.log(np.abs(lu.U.diagonal()))))
        if self.extra is None:
            logdet_q = self.prior.logdet(scales, self.sq_std, self.nprec)
        else:
            lq = spla.splu(Q.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                           options={"SymmetricMode": True})
            logdet_q = float(np.sum(np.log(np.abs(lq.U.diagonal()))))
        return (self.yty / sigma**2 - b @ x + logdet_h - logdet_q
                + self.n * np.log(2 * np.pi * sigma**2))


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
    s0 = np.array([10.0, 5.0, 15.0]) if scales is None else np.asarray(scales, dtype=float)
    sig0 = 0.5 if noise_um is None else float(noise_um)
    y_scale = max(float(np.sqrt(ev.yty / max(ev.n, 1))), 1e-3)
    sig_floor = 1e-7 * y_scale

    k0 = prior.kappa

    def unpack(h):
        i = 0
        sc, sig, kap = s0, sig0, k0
        if free_scales:
            sc = np.exp(h[:3])
            kap = float(np.exp(h[3]))
            i = 4
        if free_sigma:
            sig = float(np.exp(h[i]))
        return sc, sig, kap

    h0 = []
    bounds = []
    if free_scales:
        h0 += list(np.log(s0)) + [np.log(k0)]
        bounds += [(np.log(1e-2), np.log(1e4))] * 3 + [(np.log(1.0), np.log(1e4))]
    if free_sigma:
        h0.append(np.log(sig0))
        bounds.append((np.log(sig_floor), np.log(1e3)))
    if h0:
        def fun(h):
            sc, sig, kap = unpack(h)
            val = ev.neg2(sc, sig, kap)
            if free_scales:  # weak log-normal hyperprior: typical machines, factor 30
                z = (np.log(np.append(sc, kap)) - HYPER_CENTRE) / HYPER_SPREAD
                val += float(z @ z)
            return val
        # coarse start for sigma: scan a few decades
        if free_sigma:
            grid = np.log(np.geomspace(max(sig_floor, 1e-6), 10.0, 15))
            vals = []
            for g in grid:
                h = np.array(h0)
                h[-1] = g
                vals.append(fun(h))
            h0[-1] = grid[int(np.argmin(vals))]
        res = minimize(fun, np.array(h0), method="Nelder-Mead", bounds=bounds,
                       options={"xatol": 5e-3, "fatol": 1e-3, "maxiter": 600})
        h_opt = res.x
        neg2 = float(res.fun)
    else:
        h_opt = np.array([])
        neg2 = ev.neg2(s0, sig0)
    scales_opt, sigma, kappa = unpack(h_opt)
    if kappa != ev.prior.kappa:
        ev.prior = ev.prior.with_kappa(kappa)
    H, Q, lu = ev.factor(scales_opt, sigma)
    N = H.shape[0]
    if N <= DENSE_QR_LIMIT and (ev.n + N) * N <= DENSE_QR_ENTRIES:
        x, cov = _dense_qr(design, Q, sigma)
    else:
        x = _polish(H, lu, ev.Aty / sigma**2, steps=4)
        cov = None
        if covariance and N <= DENSE_COVARIANCE_LIMIT:
            c, low = sla.cho_factor(H.toarray(), lower=True)
            cov = sla.cho_solve((c, low), np.eye(N))
    r = design.y - design.A @ x
    if design.prior_mean is not None and np.any(design.prior_mean):
        x = x + design.prior_mean
    if cov is not None:
        edf = float(np.sum(ev.AtA.multiply(cov.T)) / sigma**2)
    else:
        edf = float(min(N, ev.n))
    dof = max(ev.n - edf, 1.0)
    s_res = float(np.sqrt(r @ r / dof))
    return Solution(x, cov, sigma, s_res, scales_opt, -0.5 * neg2, dof, "bayes",
                    solve=lambda rhs: _polish(H, lu, rhs), kappa=kappa)


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


def _polish(H, lu, rhs, steps: int = 2):
    """Solve ``H x = rhs`` with the LU factors and a few steps of iterative refinement."""
    x = lu.solve(rhs)
    for _ in range(steps):
        x = x + lu.solve(rhs - H @ x)
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
    return Solution(x, cov, sig, s_res, np.full(3, np.nan), float("nan"), float(dof), "min-norm")
