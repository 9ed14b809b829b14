"""Smoothness prior of the error functions: a sparse Gaussian precision per function.

Geometric errors of machine guideways, scales and lead screws are smooth over the
travel. Each function ``f`` on its nodes gets the prior density

.. math:: -2 \\log p(f) = \\frac{1}{a_g^2} \\left[ \\frac{1}{\\kappa^2}\\int_0^1 f''(s)^2\\,ds
          + \\int_0^1 f(s)^2\\,ds \\right] + \\text{const},

with ``s`` the position normalised to the travel, ``a_g`` the amplitude scale of its group
(positioning, straightness, roll, tilt: separate, so that an undetermined roll cannot
borrow the amplitude the well-determined tilts need) and ``kappa`` the curvature scale.
The curvature term is the penalty of a cubic smoothing spline (Wahba, *Spline Models for
Observational Data*, SIAM 1990); the amplitude term makes the prior proper so that undetermined
combinations are reported with a finite, honest uncertainty. The precision is banded,
so the posterior stays sparse (Rue & Held, *Gaussian Markov Random Fields*, 2005).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from volcal.model.parameters import ParameterLayout

GROUPS: tuple[str, ...] = ("positioning", "straightness", "roll", "tilt")
"""Prior amplitude groups: positioning [um], straightness [um], roll [urad] (EAX, EBY,
ECZ), the other angular errors (tilts: pitch and yaw) [urad]."""

__all__ = ["GROUPS", "PriorStructure", "function_group", "unit_parts", "unit_precision"]


def function_group(axis: int, component: int) -> int:
    """Group index of a component error: 0 positioning, 1 straightness, 2 roll, 3 tilt.

    Parameters
    ----------
    axis : int
        Axis the error belongs to (0, 1, 2 = X, Y, Z).
    component : int
        Component index in ``EX, EY, EZ, EA, EB, EC`` order (0..5).

    Returns
    -------
    int
        0 for the positioning error (``component == axis``), 1 for a straightness error,
        2 for the roll (rotation about the moving axis itself: EAX, EBY, ECZ), 3 for the
        two tilts.
    """
    if component >= 3:
        return 2 if component - 3 == axis else 3
    return 0 if component == axis else 1


def unit_parts(nodes: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Curvature and amplitude parts of the prior precision of one function on its nodes.

    Parameters
    ----------
    nodes : ndarray, shape (n,)
        Node positions [mm].

    Returns
    -------
    C : ndarray, shape (n, n)
        Discretised ``int f''(s)^2 ds`` (pentadiagonal), ``s`` normalised to [0, 1].
    W : ndarray, shape (n, n)
        Discretised ``int f(s)^2 ds`` (trapezoid weights, diagonal).
    """
    x = np.asarray(nodes, dtype=float)
    n = x.size
    if n == 1:
        return np.zeros((1, 1)), np.ones((1, 1))
    s = (x - x[0]) / (x[-1] - x[0])
    h = np.diff(s)
    w = np.zeros(n)
    w[:-1] += h / 2
    w[1:] += h / 2
    C = np.zeros((n, n))
    if n >= 3:
        D = np.zeros((n - 2, n))
        for i in range(1, n - 1):
            hl, hr = h[i - 1], h[i]
            c = 2.0 / (hl + hr)
            D[i - 1, i - 1] = c / hl
            D[i - 1, i] = -c * (1 / hl + 1 / hr)
            D[i - 1, i + 1] = c / hr
        wd = (h[:-1] + h[1:]) / 2
        C = D.T @ (wd[:, None] * D)
    return C, np.diag(w)


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
    C, W = unit_parts(nodes)
    return C / kappa**2 + W


@dataclass
class PriorStructure:
    """Prior blocks of the free parameters, grouped for fast rescaling.

    Attributes
    ----------
    blocks : list of (indices into the free vector, curvature part, amplitude part, group)
        One block per function (free nodes only: conditioning on the gauge zeros keeps the
        sub-matrix of the precision).
    squareness : ndarray of int
        Free-vector indices of the squareness parameters.
    kappa : float
        Curvature scale; the block precision is ``(C / kappa^2 + W) / a_g^2``.
    """

    blocks: list[tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], int]]
    squareness: NDArray[np.intp]
    n_free: int
    kappa: float = 40.0

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
            Curvature scale (may be re-estimated, see :meth:`with_kappa`).
        """
        pos_in_free = -np.ones(layout.size, dtype=np.intp)
        pos_in_free[free] = np.arange(free.size)
        blocks = []
        for k in range(3):
            C, W = unit_parts(layout.nodes[k])
            for c in range(6):
                idx = layout.indices(k, c)
                sel = pos_in_free[idx] >= 0
                if not np.any(sel):
                    continue
                blocks.append((pos_in_free[idx][sel], C[np.ix_(sel, sel)], W[np.ix_(sel, sel)],
                               function_group(k, c)))
        sq = pos_in_free[layout.squareness_indices()]
        return cls(blocks, sq[sq >= 0], int(free.size), kappa)

    def with_kappa(self, kappa: float) -> PriorStructure:
        """The same prior with another curvature scale.

        Parameters
        ----------
        kappa : float
            New curvature scale (dimensionless: positions are normalised to [0, 1]).

        Returns
        -------
        PriorStructure
            A copy sharing the blocks, with ``kappa`` replaced.
        """
        return PriorStructure(self.blocks, self.squareness, self.n_free, float(kappa))

    def precision(self, scales: NDArray[np.float64], squareness_std: float,
                  n_total: int, nuisance_precision: NDArray[np.float64]) -> sp.csc_matrix:
        """Sparse prior precision of all unknowns (free parameters then nuisances).

        Parameters
        ----------
        scales : ndarray, shape (4,)
            Amplitude scales of the groups [um, um, urad, urad] (:data:`GROUPS`).
        squareness_std : float
            Prior standard deviation of the squareness errors [urad].
        n_total : int
            Number of unknowns (free + nuisance).
        nuisance_precision : ndarray
            Precision of each nuisance parameter (weak).
        """
        rows, cols, vals = [], [], []
        k2 = self.kappa**2
        for idx, C, W, g in self.blocks:
            Qf = (C / k2 + W) / scales[g] ** 2
            r, c = np.nonzero(Qf)
            rows.append(idx[r])
            cols.append(idx[c])
            vals.append(Qf[r, c])
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
        """Log-determinant of :meth:`precision` (for the evidence).

        Parameters
        ----------
        scales : ndarray, shape (4,)
            Amplitude scales of the groups [um, um, urad, urad] (:data:`GROUPS`).
        squareness_std : float
            Prior standard deviation of the squareness errors [urad].
        nuisance_precision : ndarray
            Precision of each nuisance parameter (weak), all > 0.

        Returns
        -------
        float
            ``log det`` of the prior precision of all unknowns.
        """
        k2 = self.kappa**2
        total = 0.0
        for _, C, W, g in self.blocks:
            total += np.linalg.slogdet(C / k2 + W)[1] - 2 * C.shape[0] * np.log(scales[g])
        return float(total - 2 * self.squareness.size * np.log(squareness_std)
                     + np.sum(np.log(nuisance_precision)))
