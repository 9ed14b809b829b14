"""Straightness of a line and squareness of two lines (ISO 230-1:2012).

A straightness measurement gives the lateral deviation ``d(s)`` [um] of a moving point at
positions ``s`` [mm] along its axis. The straightness deviation is the range of the
residuals about a reference straight line:

* ``'least_squares'``: the least-squares line (ISO 230-1 preferred reference);
* ``'end_point'``: the line through the first and the last reading.

The slope of the reference line [urad] is the angle of the line in the measuring plane
and is what a squareness evaluation needs.

Squareness from two lines measured in one frame (a square artefact or an optical square,
its own error removed): line 1 along axis ``u`` with lateral deviations in direction ``v``
gives slope ``m1 = dv/du``; line 2 along axis ``v`` with lateral deviations in direction
``u`` gives ``m2 = du/dv``. The actual axis directions are ``(1, m1)`` and ``(m2, 1)``; the
angle between them is ``90 deg - (m1 + m2)``, so the squareness error (positive when the
angle between the positive axis directions exceeds 90 deg, the volcal convention for
EC0Y, EB0Z, EA0Z) is ``-(m1 + m2)``.

References
----------
.. [1] ISO 230-1:2012, Test code for machine tools - Part 1: Geometric accuracy of machines
   operating under no-load or quasi-static conditions (straightness, squareness).
.. [2] Hewlett-Packard, Model 5528A Laser Measurement System User's Guide, Section 21
   "Straightness and Squareness Considerations" (1987): a worked example of the
   end-point and least-squares fits and of the squareness of two lines; volcal
   reproduces its numbers (``tests/standards/test_iso230_1_published.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError

__all__ = ["StraightnessResult", "squareness_from_lines", "squareness_from_slopes",
           "straightness"]

REFERENCES = ("least_squares", "end_point")


@dataclass
class StraightnessResult:
    """Straightness of one line.

    Attributes
    ----------
    straightness_um : float
        Range of the residuals about the reference line [um].
    slope_urad : float
        Slope of the reference line [urad].
    intercept_um : float
        Reference line value at ``s = 0`` [um].
    residuals_um : ndarray
        Deviations minus the reference line [um].
    reference : str
        ``'least_squares'`` or ``'end_point'``.
    """

    straightness_um: float
    slope_urad: float
    intercept_um: float
    residuals_um: NDArray[np.float64]
    reference: str


def straightness(position_mm: ArrayLike, deviation_um: ArrayLike,
                 reference: str = "least_squares") -> StraightnessResult:
    """Straightness deviation of a line about a reference straight line.

    Parameters
    ----------
    position_mm : array_like, shape (n,)
        Position along the axis [mm].
    deviation_um : array_like, shape (n,)
        Lateral deviation [um].
    reference : str
        ``'least_squares'`` (default) or ``'end_point'``.

    Returns
    -------
    StraightnessResult
    """
    s = np.asarray(position_mm, dtype=float).reshape(-1)
    d = np.asarray(deviation_um, dtype=float).reshape(-1)
    if s.size != d.size or s.size < 2:
        raise VolcalInputError("straightness needs at least two (position, deviation) pairs")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(d))):
        raise VolcalInputError("straightness: positions and deviations must be finite")
    if np.ptp(s) <= 0:
        raise VolcalInputError("straightness: all readings at one position")
    if reference == "least_squares":
        slope, icpt = np.polyfit(s, d, 1)
    elif reference == "end_point":
        i0, i1 = int(np.argmin(s)), int(np.argmax(s))
        slope = (d[i1] - d[i0]) / (s[i1] - s[i0])
        icpt = d[i0] - slope * s[i0]
    else:
        raise VolcalInputError(f"unknown reference {reference!r}: expected one of "
                               f"{', '.join(REFERENCES)}", column="reference")
    res = d - (icpt + slope * s)
    return StraightnessResult(float(np.ptp(res)), float(slope * 1e3), float(icpt), res,
                              reference)


def squareness_from_slopes(slope1_urad: float, slope2_urad: float) -> float:
    """Squareness error from the slopes of two lines measured in one frame.

    Parameters
    ----------
    slope1_urad : float
        Slope ``dv/du`` of the line along the first axis ``u`` [urad].
    slope2_urad : float
        Slope ``du/dv`` of the line along the second axis ``v`` [urad].

    Returns
    -------
    float
        Squareness error [urad], positive when the angle between ``+u`` and ``+v`` exceeds
        90 degrees.
    """
    return -(float(slope1_urad) + float(slope2_urad))


def squareness_from_lines(pos1_mm: ArrayLike, dev1_um: ArrayLike, pos2_mm: ArrayLike,
                          dev2_um: ArrayLike) -> float:
    """Squareness error from two straightness lines (least-squares slopes).

    Parameters
    ----------
    pos1_mm, dev1_um : array_like
        Line along the first axis: positions [mm], deviations toward the second axis [um].
    pos2_mm, dev2_um : array_like
        Line along the second axis: positions [mm], deviations toward the first axis [um].

    Returns
    -------
    float
        Squareness error [urad] (see :func:`squareness_from_slopes`).
    """
    return squareness_from_slopes(straightness(pos1_mm, dev1_um).slope_urad,
                                  straightness(pos2_mm, dev2_um).slope_urad)
