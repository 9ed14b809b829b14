"""Nominal geometry of multilateration readings (tracking interferometer).

A multilateration measurement stores the tracker's reading, the change of the distance
from the station pivot to the cat's-eye reflector since the first pose (``length_mm``).
Inside volcal it is carried, like every other reading, as a *deviation* [um]: the reading
minus the nominal change of distance, computed from the nominal tool points (commanded
position + tool offset) and the station as the user set it up (``station_mm``). The two
are converted here, without any machine model, so that the session layer stays free of
the measurement layer. See ``docs/formats.md``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["DEFAULT_STATION_U_MM", "deviation_from_length", "length_from_deviation",
           "nominal_distances"]

DEFAULT_STATION_U_MM = 5.0
"""Default standard uncertainty of a station position set up by hand [mm]."""


def nominal_distances(positions: ArrayLike, tool_offset: ArrayLike, station_mm: ArrayLike
                      ) -> NDArray[np.float64]:
    """Distance from the station pivot to each nominal tool point [mm].

    Parameters
    ----------
    positions : array_like, shape (n, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,)
        Reflector centre relative to the tool reference point [mm].
    station_mm : array_like, shape (3,)
        Station pivot in the frame of the nominal tool points [mm].

    Returns
    -------
    ndarray, shape (n,)
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3) + np.asarray(tool_offset, float)
    return np.linalg.norm(p - np.asarray(station_mm, dtype=float), axis=1)


def deviation_from_length(length_mm: ArrayLike, positions: ArrayLike, tool_offset: ArrayLike,
                          station_mm: ArrayLike) -> NDArray[np.float64]:
    """Deviation [um] of each reading from the nominal change of distance.

    Parameters
    ----------
    length_mm : array_like, shape (n,)
        Tracker reading: change of the pivot-to-reflector distance [mm].
    positions : array_like, shape (n, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,)
        Tool offset [mm].
    station_mm : array_like, shape (3,)
        Nominal station pivot [mm].

    Returns
    -------
    ndarray, shape (n,)
        ``(L_i - L_0) - (d_i - d_0)`` with ``d`` the nominal distances, in [um].
    """
    L = np.asarray(length_mm, dtype=float)
    d = nominal_distances(positions, tool_offset, station_mm)
    return ((L - L[0]) - (d - d[0])) * 1e3


def length_from_deviation(deviation_um: ArrayLike, positions: ArrayLike, tool_offset: ArrayLike,
                          station_mm: ArrayLike) -> NDArray[np.float64]:
    """Tracker reading [mm] from the deviation (inverse of :func:`deviation_from_length`).

    Parameters
    ----------
    deviation_um : array_like, shape (n,)
        Deviation from the nominal change of distance [um].
    positions : array_like, shape (n, 3)
        Commanded positions [mm].
    tool_offset : array_like, shape (3,)
        Tool offset [mm].
    station_mm : array_like, shape (3,)
        Nominal station pivot [mm].

    Returns
    -------
    ndarray, shape (n,)
        Change of distance since the first pose [mm] (0 in the first row when the first
        deviation is 0).
    """
    dev = np.asarray(deviation_um, dtype=float)
    d = nominal_distances(positions, tool_offset, station_mm)
    return (d - d[0]) + dev * 1e-3
