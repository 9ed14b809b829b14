"""Least-squares lines through many data sets at once, bit for bit as ``numpy.polyfit``.

The Monte Carlo uncertainty of a straightness (:mod:`volcal.standards.model_uncertainty`)
fits a least-squares line to each of a few hundred draws of one function at the same
positions. :func:`line_fits` gives the same coefficients as ``numpy.polyfit(s, d[:, j],
1)`` for every column ``j``, to the last bit, in one call: it sets up the same scaled
Vandermonde matrix and hands the stack of one-column problems to the same LAPACK driver
(``dgelsd``, through numpy's ``lstsq`` kernel) that ``polyfit`` calls once per column.
Solving all columns as one multi-column problem would be faster still but is not bit for
bit the same (the driver's sums run in another order). Where the stacked kernel is not
available, or a fit is rank deficient or fails (where ``polyfit`` warns or raises), each
column is fitted by ``numpy.polyfit`` itself.

References
----------
.. [1] numpy.polyfit (numpy 2.x): the scaled Vandermonde least-squares fit; numpy.linalg.lstsq.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["line_fits"]


def line_fits(s: ArrayLike, d: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Slope and intercept of the least-squares line through each column of ``d``.

    Parameters
    ----------
    s : array_like, shape (n,)
        Positions [mm] (the same for every column).
    d : array_like, shape (n, k)
        ``k`` data sets at ``s`` [um].

    Returns
    -------
    slope, intercept : ndarray, shape (k,)
        ``numpy.polyfit(s, d[:, j], 1)`` of every column ``j``, bit for bit.
    """
    s = np.asarray(s, dtype=float) + 0.0
    d = np.asarray(d, dtype=float) + 0.0
    coef = _stacked(s, d)
    if coef is None:
        coef = np.array([np.polyfit(s, d[:, j], 1) for j in range(d.shape[1])]
                        ).reshape(d.shape[1], 2)
    return coef[:, 0], coef[:, 1]


def _stacked(s: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """``polyfit``'s coefficients of every column by the stacked kernel; None if it cannot."""
    try:
        from numpy.linalg import _umath_linalg
    except ImportError:  # pragma: no cover - numpy's layout
        return None
    kernel = getattr(_umath_linalg, "lstsq", None)
    n, k = d.shape
    if kernel is None or k == 0 or n < 2:
        return None
    lhs = np.vander(s, 2)                          # as numpy.polyfit, order 2
    scale = np.sqrt((lhs * lhs).sum(axis=0))
    lhs /= scale
    rcond = len(s) * np.finfo(float).eps
    a = np.broadcast_to(lhs, (k, n, 2))
    b = np.ascontiguousarray(d.T)[:, :, None]      # k problems of one column each
    try:
        with np.errstate(invalid="raise", over="ignore", divide="ignore", under="ignore"):
            x, _, rank, _ = kernel(a, b, rcond, signature="ddd->ddid")
    except (FloatingPointError, TypeError, ValueError):
        return None
    if not np.all(rank == 2):
        return None
    return np.asarray(x[:, :, 0] / scale, dtype=float)
