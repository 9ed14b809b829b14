"""Drift check from repeated readings at the start point of a test.

In a bidirectional ISO 230-2 cycle every run returns to the first target; a linear test
often starts and ends there too. Readings at that one position taken at different times
should agree within the repeatability; a trend shows thermal drift of the machine or of
the laser set-up (ISO 230-2 asks for stable conditions during the test, and
ISO/TR 230-9 counts it in the measurement uncertainty).

References
----------
.. [1] ISO 230-2:2014, annex A (uncertainty contributions, drift).
.. [2] ISO 230-3:2020, Determination of thermal effects (environmental temperature
   variation error, drift test).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from volcal.errors import VolcalInputError

__all__ = ["DriftCheck", "drift_check"]


@dataclass
class DriftCheck:
    """Result of :func:`drift_check`.

    Attributes
    ----------
    n : int
        Number of readings at the start point.
    rate_um_per_h : float
        Least-squares slope of the start-point readings over time [um/h] (nan without time).
    span_um : float
        Largest minus smallest start-point reading [um].
    drift_um : float
        Last minus first start-point reading [um].
    limit_um : float
        Tolerance applied to ``span_um`` [um].
    ok : bool
        ``span_um <= limit_um``.
    """

    n: int
    rate_um_per_h: float
    span_um: float
    drift_um: float
    limit_um: float
    ok: bool


def drift_check(positions_mm: ArrayLike, deviation_um: ArrayLike,
                time_s: ArrayLike | None = None, limit_um: float = 1.0,
                tolerance_mm: float = 1e-3) -> DriftCheck:
    """Check drift from the readings taken at the first position.

    Parameters
    ----------
    positions_mm : array_like, shape (n, 3) or (n,)
        Commanded positions [mm], in the order of measurement.
    deviation_um : array_like, shape (n,)
        Deviations [um].
    time_s : array_like, shape (n,), optional
        Time of each reading [s]; without it the order of the rows is used for the
        first-to-last drift and the rate is nan.
    limit_um : float
        Largest acceptable span of the start-point readings [um].
    tolerance_mm : float
        Positions within this distance of the first one count as the start point [mm].

    Returns
    -------
    DriftCheck

    Raises
    ------
    VolcalInputError
        Fewer than two readings at the start point.
    """
    p = np.asarray(positions_mm, dtype=float)
    p = p.reshape(p.shape[0], -1)
    d = np.asarray(deviation_um, dtype=float).reshape(-1)
    at = np.linalg.norm(p - p[0], axis=1) <= tolerance_mm
    if at.sum() < 2:
        raise VolcalInputError("drift check: fewer than two readings at the start point")
    y = d[at]
    rate = float("nan")
    if time_s is not None:
        t = np.asarray(time_s, dtype=float).reshape(-1)[at]
        order = np.argsort(t, kind="stable")
        t, y = t[order], y[order]
        if np.ptp(t) > 0:
            rate = float(np.polyfit(t / 3600.0, y, 1)[0])
    span = float(np.ptp(y))
    return DriftCheck(int(at.sum()), rate, span, float(y[-1] - y[0]), float(limit_um),
                      span <= limit_um)
