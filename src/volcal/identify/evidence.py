"""Negative twice the log evidence of the Bayesian estimator, with its exact gradient.

The marginal likelihood ("evidence") of the hyperparameters of
:func:`volcal.identify.solver.solve_bayes` (MacKay 1992; Rasmussen & Williams 2006,
ch. 5): for the linear Gaussian model ``y = A x + noise`` with the block-diagonal prior
precision ``Q`` of :mod:`volcal.identify.prior`, ``-2 log p(y) = |y - A x|^2 / s^2 +
x'Q x + log det H - log det Q + n log(2 pi s^2)`` at the posterior mean ``x``, ``H =
A'A / s^2 + Q``. Dense Cholesky of ``H`` (a few hundred to ~1500 unknowns); value and
gradient block by block.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray

from volcal.identify.design import Design
from volcal.identify.prior import (
    GROUPS,
    TILT_GROUP,
    PriorStructure,
    function_group,
    function_scales,
)

__all__ = ["NUISANCE_PRECISION", "N_HYPER"]

N_HYPER = 31
"""Entries of the gradient of :meth:`_Evidence.neg2_grad_functions`."""

AXIS_KAPPA = 27
"""Gradient index of the X axis' curvature factor (then Y, Z):
:attr:`volcal.identify.prior.PriorStructure.axis_kappa`."""

TILT_TREND = 30
"""Gradient index of the tilts' linear part
(:attr:`volcal.identify.prior.PriorStructure.tilt_trend_urad`)."""

NUISANCE_PRECISION = {"offset": 1e-10, "tilt": 1e-8, "reversal": 1e-8, "drift": 1e-8,
                      "station_x": 1e-10, "station_y": 1e-10, "station_z": 1e-10}
"""Prior precision of each kind of set-up nuisance [1/um^2 or 1/urad^2]: nearly flat
(the set-up tilts' is replaced by the evidence-chosen scale where they are visible)."""


def _nuisance_precision(design: Design) -> NDArray[np.float64]:
    return np.array([NUISANCE_PRECISION[n.rsplit(":", 1)[1].rstrip("12")]
                     for n in design.nuisance_names])


class _Evidence:
    """Negative twice the log evidence, on a dense posterior precision.

    The prior precision is block diagonal: one block per function (its scale ``a_f``), the
    squareness and the nuisances on the diagonal. Value and gradient are computed per
    block, so any grouping of the function scales (:func:`solve_bayes`) costs the same.
    """

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
        self.last_fit: tuple[float, float] | None = None
        self.last_gamma: NDArray[np.float64] | None = None
        diag = np.zeros(self.N)
        diag[prior.squareness] = 1.0 / squareness_std**2
        diag[prior.n_free:] = self.nprec
        if self.extra is not None:
            diag += self.extra
        in_block = np.zeros(self.N, dtype=bool)
        for idx, *_ in prior.blocks:
            in_block[idx] = True
        self._diag = diag  # squareness, nuisances and extra precision
        kinds = [n.rsplit(":", 1)[1] for n in design.nuisance_names]
        self._tilt = prior.n_free + np.array([j for j, k in enumerate(kinds)
                                              if k.startswith("tilt")], dtype=np.intp)
        self._tilt_extra = diag[self._tilt] - NUISANCE_PRECISION["tilt"]
        self.tilt_std = float(NUISANCE_PRECISION["tilt"] ** -0.5)
        self._outside = ~in_block  # unknowns on the diagonal only
        self._flat = [np.ravel_multi_index(np.ix_(idx, idx), (self.N, self.N)).ravel()
                      for idx, *_ in prior.blocks]
        self._kept: _Kept | None = None

    @property
    def has_tilts(self) -> bool:
        """True when the design has set-up tilts (step diagonals with a flat mirror)."""
        return self._tilt.size > 0

    def set_tilt_std(self, tau: float) -> None:
        """Prior standard deviation of every set-up tilt [urad] (beam and mirror)."""
        self.tilt_std = float(tau)
        self._diag[self._tilt] = self._tilt_extra + 1.0 / self.tilt_std**2

    def _block_precisions(self, fscales):
        """Per block: its prior precision and its diagonal extra precision.

        Blocks with the same :meth:`PriorStructure.block_key` (the straightness errors of
        one axis, its two tilts) share one precision array (to read, not to write).
        """
        done: dict[tuple, NDArray[np.float64]] = {}
        out = []
        for b, (idx, *_) in enumerate(self.prior.blocks):
            key = self.prior.block_key(b, fscales)
            if key not in done:
                done[key] = self.prior.block_precision(b, fscales)
            out.append((done[key], self._diag[idx]))
        return out

    def _block_derivatives(self, b: int, fscales, Qb):
        """:meth:`_block_derivatives_kappa` with the axis' curvature factor.

        ``kappa`` enters a block only through ``kappa * axis_kappa[k]``, so the block's
        derivative in the log of its axis' factor is its derivative in ``log kappa``.
        """
        out = self._block_derivatives_kappa(b, fscales, Qb)
        k = self.prior.blocks[b][4] // 6
        return out + [(AXIS_KAPPA + k, dQ) for j, dQ in out if j == 18]

    def _block_derivatives_kappa(self, b: int, fscales, Qb):
        """``[(gradient index, dQ_b / dlog hyperparameter)]`` of block ``b``.

        Without trend ``Q = P / a^2`` (``P = C / kappa^2 + W``, or its difference form,
        :meth:`PriorStructure.unit_block`): ``dQ/dlog a = -2 Q``, ``dQ/dlog kappa = -2 K``
        with ``K = C / (kappa^2 a^2)`` (difference form: ``T' C_full T / (kappa^2 a^2)``).
        With the trend ``Q = S^-1``, ``S = a^2 P^-1 + t^2 s s'``, ``w = Q s``:
        ``dQ/dlog a = -2 Q + 2 t^2 w w'``,
        ``dQ/dlog t = -2 t^2 w w'``, ``dQ/dlog kappa = -2 (I - t^2 w s') K (I - t^2 s w')``.
        With the short-wavelength part (:meth:`PriorStructure.has_nugget`) ``S = a^2 P^-1
        + t^2 s s' + n^2 N`` and every derivative is ``dQ = -Q (dS/dlog h) Q``:
        ``dS/dlog a = 2 a^2 P^-1``, ``dS/dlog t = 2 t^2 s s'``, ``dS/dlog n = 2 n^2 N``,
        ``dS/dlog kappa = 2 a^2 P^-1 K_1 P^-1`` (``K_1`` the unit curvature part).
        """
        _, _, _, g, f = self.prior.blocks[b]
        gk = 22 + g  # the group's curvature factor
        if self.prior.has_nugget(b):
            # covariance form: S = a^2 P^-1 + t^2 s s' + n^2 N, dQ = -Q dS Q
            Pinv, K0, v, Nn = self.prior.block_covariance_parts(b, fscales)
            a2, t2, n2 = fscales[f] ** 2, self.prior.trend_um**2, self.prior.nugget_um**2
            QP = Qb @ Pinv
            dk = -2.0 * a2 * QP @ K0 @ QP.T
            out = [(f, -2.0 * a2 * QP @ Qb), (18, dk), (gk, dk),
                   (26, -2.0 * n2 * Qb @ Nn @ Qb)]
            if t2 > 0 and np.any(v):
                w = Qb @ v
                out.append((21, -2.0 * t2 * np.outer(w, w)))
            return out
        K = self.prior.unit_block(b)[1] / fscales[f] ** 2
        if not self.prior.has_trend(b):
            return [(f, -2.0 * Qb), (18, -2.0 * K), (gk, -2.0 * K)]
        t2 = self.prior.block_trend(b) ** 2
        v = self.prior.coords[b]
        w = Qb @ v
        ww = np.outer(w, w)
        T = np.eye(v.size) - t2 * np.outer(w, v)
        dk = -2.0 * T @ K @ T.T
        it = TILT_TREND if g == TILT_GROUP else 21
        return [(f, -2.0 * Qb + 2.0 * t2 * ww), (it, -2.0 * t2 * ww), (18, dk), (gk, dk)]

    def _prior_blocks(self, scales, kappa=None):
        """Function scales (18) and per-block precisions at these hyperparameters."""
        kept = self._prior(scales, kappa)
        return kept.fs, kept.blocks

    def _prior(self, scales, kappa=None) -> _Kept:
        """The prior's parts at these hyperparameters, kept for the next evaluation.

        The scan of the noise (:meth:`_HyperSearch._start_sigma`) and the factorisation
        after a search or after the value at given hyperparameters evaluate the same
        prior again; its parts (and the posterior's factor, :meth:`_posterior`) are
        computed once, the same numbers.
        """
        if kappa is not None and kappa != self.prior.kappa:
            self.prior = self.prior.with_kappa(kappa)
        fs = function_scales(scales)
        key = (fs.tobytes(), self._diag.tobytes(), _hyper_key(self.prior))
        kept = self._kept
        if kept is not None and kept.key == key and kept.structure is self.prior.blocks:
            return kept
        blocks = self._block_precisions(fs)
        self._kept = _Kept(key, self.prior.blocks, fs.copy(), blocks, self._assemble(blocks))
        return self._kept

    def _posterior(self, kept: _Kept, sigma: float):
        """``H = A'A / sigma^2 + Q`` and its lower Cholesky factor, kept with the prior."""
        if kept.sigma != sigma or kept.factor is None:
            H = self.AtA / sigma**2
            H += kept.Q  # A'A / sigma^2 + Q without a second temporary
            kept.factor = sla.cho_factor(H, lower=True, check_finite=False)
            kept.H, kept.sigma = H, sigma
        return kept.H, kept.factor

    def _log_det_prior(self, kept: _Kept):
        """``log det Q`` block by block, and the blocks' Cholesky factors (kept)."""
        if kept.logdet is None:
            logdet_q = float(np.sum(np.log(self._diag[self._outside])))
            qinv = []
            done: dict[tuple, tuple] = {}  # one factor of blocks sharing their precision
            for Qb, ex in kept.blocks:
                key = (id(Qb), ex.tobytes())
                if key not in done:
                    done[key] = sla.cho_factor(Qb + np.diag(ex), lower=True, check_finite=False)
                cb = done[key]
                logdet_q += 2.0 * float(np.sum(np.log(np.diag(cb[0]))))
                qinv.append(cb)
            kept.logdet, kept.qinv = logdet_q, qinv
        return kept.logdet, kept.qinv

    def _assemble(self, blocks) -> NDArray[np.float64]:
        """Dense ``Q`` from the per-block precisions and the diagonal."""
        Q = np.zeros((self.N, self.N))
        for flat, (Qb, _) in zip(self._flat, blocks, strict=True):
            Q.flat[flat] += Qb.ravel()
        Q[np.diag_indices_from(Q)] += self._diag
        return Q

    def prior_dense(self, scales, kappa=None):
        """Dense prior precision ``Q`` for group (4) or function (18) scales (a copy)."""
        return self._prior(scales, kappa).Q.copy()

    def factor(self, scales, sigma, kappa=None):
        """``(H, Q, cho_factor(H))`` at these hyperparameters (arrays to read, not write)."""
        kept = self._prior(scales, kappa)
        H, cf = self._posterior(kept, sigma)
        return H, kept.Q, cf

    def _value(self, scales, sigma, kappa=None):
        """``neg2`` with the parts its gradient reuses.

        Returns ``(value, Q, cf, x, |r|^2, block Cholesky factors of Q, block precisions)``;
        the block precisions are computed once per evaluation.
        """
        kept = self._prior(scales, kappa)
        Q, blocks = kept.Q, kept.blocks
        cf = self._posterior(kept, sigma)[1]
        b = self.Aty / sigma**2
        x = sla.cho_solve(cf, b, check_finite=False)
        # the data term y'y/s^2 - b'H^-1 b as the minimum it is, |y - A x|^2/s^2 + x'Q x:
        # no cancellation of two huge numbers when the data are nearly reproduced (tiny
        # s), and stationary in x, so a solve error enters only to second order
        r = self.y - self.A @ x
        rr = float(r @ r)
        data = rr / sigma**2 + float(x @ (Q @ x))
        logdet_h = 2.0 * float(np.sum(np.log(np.diag(cf[0]))))
        # log det Q block by block (Q is block diagonal); the block factors serve the
        # gradient's tr(Q^-1 dQ) terms
        logdet_q, qinv = self._log_det_prior(kept)
        val = data + logdet_h - logdet_q + self.n * np.log(2 * np.pi * sigma**2)
        return float(val), Q, cf, x, rr, qinv, blocks

    def neg2(self, scales, sigma, kappa=None) -> float:
        self.evaluations += 1
        try:
            return self._value(scales, sigma, kappa)[0]
        except (np.linalg.LinAlgError, sla.LinAlgError):
            return 1e300

    def neg2_grad_functions(self, scales, sigma, kappa=None
                            ) -> tuple[float, NDArray[np.float64]]:
        """``neg2`` and its gradient in log of hyperparameters (function scales, kappa...).

        The 31 entries: the 18 function scales, kappa, sigma, the tilts' scale, the trend
        scale, the curvature factor of each group of :data:`GROUPS`, the short-wavelength
        (nugget) scale of the positioning errors, the curvature factor of each axis
        (:data:`AXIS_KAPPA`), then the scale of the tilts' linear part (:data:`TILT_TREND`).

        With ``D = |y - A x|^2 / s^2 + x'Q x`` at the posterior mean ``x`` (stationary, so
        only explicit dependences count), ``Q`` block diagonal (one block ``Q_f`` per
        function, then the diagonal of squareness and nuisances) and ``H = A'A / s^2 + Q``
        (Rasmussen & Williams 2006, eq. 5.9), a hyperparameter ``h`` of the prior adds

        * ``x' dQ x + tr(H^-1 dQ) - tr(Q^-1 dQ)`` for each block it enters
          (``dQ = dQ_f / dlog h``, :meth:`_block_derivatives`),
        * ``d/dlog sigma = -2 |r|^2 / s^2 - 2 tr(H^-1 A'A) / s^2 + 2 n``,
        * ``d/dlog tau = sum_t -2 (x_t^2 + (H^-1)_tt) / tau^2 + 2 / (tau^2 Q_tt)`` over the
          set-up tilts ``t`` (prior standard deviation ``tau``, :meth:`set_tilt_std`),

        where ``tr(H^-1 A'A) / s^2 = N - tr(H^-1 Q)``. Functions without free nodes have a
        zero gradient.
        """
        self.evaluations += 1
        try:
            val, Q, cf, x, rr, qinv, blocks = self._value(scales, sigma, kappa)
        except (np.linalg.LinAlgError, sla.LinAlgError):
            return 1e300, np.zeros(N_HYPER)
        fs = function_scales(scales)
        inv, lower = _inverse_lower(cf)  # H^-1: only its diagonal and diagonal blocks
        # the diagonal as a strided view, as of the whole inverse (a dot product's sum
        # depends on the stride); potri's diagonal is the whole inverse's
        hdiag = np.diag(inv)
        grad = np.zeros(N_HYPER)
        gamma = np.zeros(N_HYPER)  # effective number of parameters each hyperparameter governs
        tr_hq = float(hdiag @ self._diag)
        shared: dict[tuple, tuple] = {}
        for bi, ((idx, *_), cb, (Qb, _)) in enumerate(
                zip(self.prior.blocks, qinv, blocks, strict=True)):
            Hb = _symmetric(inv[np.ix_(idx, idx)]) if lower else inv[np.ix_(idx, idx)]
            xb = x[idx]
            tr_hq += float(np.sum(Hb * Qb))
            for j, dQ, t_q in self._block_terms(bi, fs, Qb, cb, shared):
                t_h = float(np.sum(Hb * dQ))
                grad[j] += float(xb @ (dQ @ xb)) + t_h - t_q
                gamma[j] += 0.5 * (t_h - t_q)
        grad[19] = -2.0 * rr / sigma**2 - 2.0 * (self.N - tr_hq) + 2.0 * self.n
        self.last_fit = (rr, self.N - tr_hq)  # |r|^2 and the effective number of parameters
        gamma[19] = self.n - (self.N - tr_hq)
        if self.has_tilts:  # dQ/dlog tau = -2 / tau^2 on the tilts' diagonal
            t = self._tilt
            w = 1.0 / self.tilt_std**2
            grad[20] = (-2.0 * w * float(x[t] @ x[t] + np.sum(hdiag[t]))
                        + 2.0 * float(np.sum(w / self._diag[t])))
            gamma[20] = float(np.sum(w / self._diag[t]) - w * np.sum(hdiag[t]))
        self.last_gamma = gamma
        return float(val), grad

    def _block_terms(self, b: int, fscales, Qb, cb, shared: dict) -> list:
        """``[(gradient index, dQ_b, tr(Q_b^-1 dQ_b))]`` of block ``b``.

        The derivatives of :meth:`_block_derivatives`. Blocks of one group sharing their
        precision and its factor (:meth:`_block_precisions`: an axis' two straightness
        errors, its two tilts) have the same ones but for the function's own index:
        computed once per evaluation (``shared``), the same numbers.
        """
        _, _, _, g, f = self.prior.blocks[b]
        key = (g, id(Qb), id(cb))
        if key not in shared:
            Qb_inv = sla.cho_solve(cb, np.eye(Qb.shape[0]), check_finite=False)
            shared[key] = (f, [(j, dQ, float(np.sum(Qb_inv * dQ)))
                               for j, dQ in self._block_derivatives(b, fscales, Qb)])
        f0, terms = shared[key]
        return [(f if j == f0 else j, dQ, t_q) for j, dQ, t_q in terms]

    def neg2_grad(self, scales, sigma, kappa=None) -> tuple[float, NDArray[np.float64]]:
        """``neg2`` and its gradient in ``log`` of (the four group scales, kappa, sigma).

        The group gradient is the sum of its functions' (:meth:`neg2_grad_functions`).
        """
        val, g = self.neg2_grad_functions(function_scales(scales), sigma, kappa)
        ng = len(GROUPS)
        out = np.zeros(ng + 2)
        for k in range(3):
            for c in range(6):
                out[function_group(k, c)] += g[6 * k + c]
        out[ng:] = g[18:20]
        return val, out


def _hyper_key(prior: PriorStructure) -> tuple:
    """The prior's hyperparameters besides the function scales (what its blocks depend on)."""
    return (prior.kappa, prior.trend_um, prior.trend_length, prior.tilt_trend_urad,
            prior.kappa_factor, prior.nugget_um, prior.group_kappa, prior.axis_kappa)


@dataclass(eq=False)
class _Kept:
    """The prior's parts at one set of hyperparameters (:meth:`_Evidence._prior`).

    ``key`` the hyperparameters (function scales, diagonal, :func:`_hyper_key`),
    ``structure`` the prior's blocks they were computed on, ``fs`` the function scales,
    ``blocks`` each block's precision and diagonal extra, ``Q`` the dense prior precision;
    filled when first needed: the posterior precision ``H`` and its factor at ``sigma``,
    ``log det Q`` and the blocks' factors.
    """

    key: tuple
    structure: list
    fs: NDArray[np.float64]
    blocks: list
    Q: NDArray[np.float64]
    sigma: float = float("nan")
    H: NDArray[np.float64] | None = None
    factor: tuple | None = None
    logdet: float | None = None
    qinv: list = field(default_factory=list)


def _inverse_from_cholesky(cf) -> NDArray[np.float64]:
    """``H^-1`` from the lower Cholesky factor of ``H``.

    LAPACK ``potri``: a third of the work of solving against the identity.
    """
    inv, lower = _inverse_lower(cf)
    return _symmetric(inv) if lower else inv


def _inverse_lower(cf) -> tuple[NDArray[np.float64], bool]:
    """``H^-1`` as LAPACK ``potri`` leaves it: its lower triangle (True).

    When ``potri`` fails, the whole inverse solved against the identity (False).
    """
    inv, info = sla.lapack.dpotri(cf[0], lower=True)
    if info != 0:
        return sla.cho_solve(cf, np.eye(cf[0].shape[0]), check_finite=False), False
    return inv, True


def _symmetric(low: NDArray[np.float64]) -> NDArray[np.float64]:
    """The symmetric matrix of a lower triangle (what lies above the diagonal ignored).

    A diagonal block ``H^-1[idx, idx]`` (``idx`` increasing) of the lower triangle of
    ``potri`` gives the block of the whole inverse, the same numbers.
    """
    low = np.tril(low)
    return low + np.tril(low, -1).T
