"""Smoothness prior of the error functions: a sparse Gaussian precision per function.

Geometric errors of machine guideways, scales and lead screws are smooth over the
travel. Each function ``f`` on its nodes gets the prior density

.. math:: -2 \\log p(f) = \\frac{1}{a_g^2} \\left[ \\frac{1}{\\kappa^2}\\int_0^1 f''(s)^2\\,ds
          + \\int_0^1 f(s)^2\\,ds \\right] + \\text{const},

with ``s`` the position normalised to the travel, ``a_g`` the amplitude scale of its group
(positioning, straightness, angular) and ``kappa`` the curvature scale. The curvature
term is the penalty of a cubic smoothing spline (Wahba, *Spline Models for Observational
Data*, SIAM 1990); the amplitude term makes the prior proper so that undetermined
combinations are reported with a finite, honest uncertainty. The precision is banded,
so the posterior stays sparse (Rue & Held, *Gaussian Markov Random Fields*, 2005).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from volcal.model.parameters import ParameterLayout

GROUPS: tuple[str, ...] = ("positioning", "straightness", "angular")

__all__ = ["GROUPS", "PriorStructure", "function_group", "unit_precision"]


def function_group(axis: int, component: int) -> int:
    """Group index of a component error: 0 positioning, 1 straightness, 2 angular."""
    if component >= 3:
        return 2
    return 0 if component == axis else 1


def unit_precision(nodes: NDArray[np.float64], kappa: float) -> NDArray[np.float64]:
    """Prior precision of one function on its nodes for unit amplitude scale.

    Parameters
    ----------
    nodes : ndarray, shape (n,)
        Node positions [mm].
    kappa : float
        Curvature scale (dimensionless, per normalised travel).

    Returns
    -------
    ndarray, shape (n, n)
        Banded precision (pentadiagonal).
    """
    x = np.asarray(nodes, dtype=float)
    n = x.size
    if n == 1:
        return np.ones((1, 1))
    s = (x - x[0]) / (x[-1] - x[0])
    h = np.diff(s)
    w = np.zeros(n)
    w[:-1] += h / 2
    w[1:] += h / 2
    Q = np.diag(w)
    if n >= 3:
        D = np.zeros((n - 2, n))
        for i in range(1, n - 1):
            hl, hr = h[i - 1], h[i]
            c = 2.0 / (hl + hr)
            D[i - 1, i - 1] = c / hl
            D[i - 1, i] = -c * (1 / hl + 1 / hr)
            D[i - 1, i + 1] = c / hr
        wd = (h[:-1] + h[1:]) / 2
        Q = Q + D.T @ (wd[:, None] * D) / kappa**2
    return Q


@dataclass
class PriorStructure:
    """Unit-scale prior blocks of the free parameters, grouped for fast rescaling.

    Attributes
    ----------
    blocks : list of (indices into the free vector, dense precision, group)
        One block per function (free nodes only: conditioning on the gauge zeros keeps the
        sub-matrix of the precision).
    squareness : ndarray of int
        Free-vector indices of the squareness parameters.
    logdet_unit : ndarray, shape (3,)
        Sum of log-determinants of the unit blocks per group.
    count : ndarray, shape (3,)
        Number of parameters per group.
    """

    blocks: list[tuple[NDArray[np.intp], NDArray[np.float64], int]]
    squareness: NDArray[np.intp]
    logdet_unit: NDArray[np.float64]
    count: NDArray[np.float64]
    n_free: int

    @classmethod
    def build(cls, layout: ParameterLayout, free: NDArray[np.intp], kappa: float = 40.0
              ) -> PriorStructure:
        """Prior blocks for the free parameters of a layout.

        Parameters
        ----------
        layout : ParameterLayout
            Full layout.
        free : ndarray of int
            Free parameter indices (into the layout).
        kappa : float
            Curvature scale.
        """
        pos_in_free = -np.ones(layout.size, dtype=np.intp)
        pos_in_free[free] = np.arange(free.size)
        blocks = []
        logdet = np.zeros(3)
        count = np.zeros(3)
        for k in range(3):
            Qu = unit_precision(layout.nodes[k], kappa)
            for c in range(6):
                idx = layout.indices(k, c)
                sel = pos_in_free[idx] >= 0
                if not np.any(sel):
                    continue
                Qf = Qu[np.ix_(sel, sel)]
                g = function_group(k, c)
                blocks.append((pos_in_free[idx][sel], Qf, g))
                logdet[g] += np.linalg.slogdet(Qf)[1]
                count[g] += sel.sum()
        sq = pos_in_free[layout.squareness_indices()]
        return cls(blocks, sq[sq >= 0], logdet, count, int(free.size))

    def precision(self, scales: NDArray[np.float64], squareness_std: float,
                  n_total: int, nuisance_precision: NDArray[np.float64]) -> sp.csc_matrix:
        """Sparse prior precision of all unknowns (free parameters then nuisances).

        Parameters
        ----------
        scales : ndarray, shape (3,)
            Amplitude scales of the groups [um, um, urad].
        squareness_std : float
            Prior standard deviation of the squareness errors [urad].
        n_total : int
            Number of unknowns (free + nuisance).
        nuisance_precision : ndarray
            Precision of each nuisance parameter (weak).
        """
        rows, cols, vals = [], [], []
        for idx, Qf, g in self.blocks:
            r, c = np.nonzero(Qf)
            rows.append(idx[r])
            cols.append(idx[c])
            vals.append(Qf[r, c] / scales[g] ** 2)
        rows.append(self.squareness)
        cols.append(self.squareness)
        vals.append(np.full(self.squareness.size, 1.0 / squareness_std**2))
        nu = np.arange(self.n_free, n_total)
        rows.append(nu)
        cols.append(nu)
        vals.append(nuisance_precision)
        return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(n_total, n_total))

    def logdet(self, scales: NDArray[np.float64], squareness_std: float,
               nuisance_precision: NDArray[np.float64]) -> float:
        """Log-determinant of :meth:`precision` (for the evidence)."""
        return float(np.sum(self.logdet_unit - 2 * self.count * np.log(scales))
                     - 2 * self.squareness.size * np.log(squareness_std)
                     + np.sum(np.log(nuisance_precision)))
