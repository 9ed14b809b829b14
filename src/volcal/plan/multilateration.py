"""Plan a multilateration session: tracker stations, a serpentine grid, tool offsets.

Default layout (Schwenke et al., CIRP Annals 54/1, 2005): 4 tracker stations near the
corners of the table at different heights (not coplanar, so that no direction of the work
zone is seen edge-on by every station), a serpentine grid of 9 x 7 x 6 points through the
work zone, measured from every station with 2 tool offsets, one of them off the spindle
axis so that the roll of the axes moves the reflector. One measurement per station and
tool offset.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.session.format import Measurement

__all__ = ["DEFAULT_GRID", "DEFAULT_TOOL_OFFSETS", "default_stations", "multilateration_tests",
           "serpentine_grid"]

DEFAULT_GRID = (9, 7, 6)
"""Grid points along X, Y, Z."""

DEFAULT_TOOL_OFFSETS = ((0.0, 0.0, 0.0), (100.0, 100.0, 0.0))
"""Reflector positions relative to the tool reference point [mm]: at it (on the spindle
axis), and 141 mm off the axis at the same height (the roll of every axis then moves the
reflector). Two offsets cannot show the tilt of the tool-carrying axis about their
difference; with the first reflector at the tool reference point that tilt does not change
the volumetric error there (it only matters for tools off the line of the two reflectors),
so the default keeps the error at the tool reference point fully determined. A third
offset out of the line determines everything (``volcal advise`` compares)."""

STATION_DEPTHS_MM = (60.0, 180.0, 100.0, 260.0, 140.0, 220.0, 80.0, 200.0)
"""How far below the lowest tool point the stations stand, in turn [mm]."""


def serpentine_grid(travel: ArrayLike, grid: Sequence[int] = DEFAULT_GRID,
                    margin: float = 0.0) -> NDArray[np.float64]:
    """Grid of commanded positions visited as a serpentine (shortest moves between points).

    Parameters
    ----------
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    grid : sequence of 3 int
        Points along X, Y, Z (each >= 2).
    margin : float
        Fraction of each travel kept free at both ends.

    Returns
    -------
    ndarray, shape (nx * ny * nz, 3)
        Positions [mm]: X fastest, reversing direction every row; Y reversing every layer.
    """
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    g = [int(v) for v in grid]
    if len(g) != 3 or min(g) < 2 or np.prod(g) > 100_000:
        raise VolcalInputError(f"--grid {grid}: expected 3 counts >= 2 (at most 100000 points)")
    if not 0 <= margin < 0.5:
        raise VolcalInputError(f"grid margin {margin}: expected a fraction in [0, 0.5)")
    ax = [np.linspace(t[k, 0] + margin * np.ptp(t[k]), t[k, 1] - margin * np.ptp(t[k]), g[k])
          for k in range(3)]
    pts = []
    for iz, z in enumerate(ax[2]):
        ys = ax[1] if iz % 2 == 0 else ax[1][::-1]
        for iy, y in enumerate(ys):
            xs = ax[0] if (iy + iz * len(ys)) % 2 == 0 else ax[0][::-1]
            for x in xs:
                pts.append((x, y, z))
    return np.array(pts)


def default_stations(travel: ArrayLike, tool_offsets: Sequence[ArrayLike] = DEFAULT_TOOL_OFFSETS,
                     n: int = 4) -> NDArray[np.float64]:
    """Station pivots on the table near its corners, at different heights, not coplanar.

    Parameters
    ----------
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    tool_offsets : sequence of array_like
        Tool offsets of the session [mm] (the stations stand below the lowest tool point).
    n : int
        Number of stations (3 to 8): the 4 corners first, then the mid-sides.

    Returns
    -------
    ndarray, shape (n, 3)
        Pivots in the frame of the nominal tool points [mm].
    """
    if not 3 <= n <= 8:
        raise VolcalInputError(f"--stations {n}: expected 3 to 8 default stations")
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    off = np.asarray(tool_offsets, dtype=float).reshape(-1, 3)
    inset = 0.1 * np.ptp(t[:2], axis=1)
    lo, hi = t[:2, 0] + inset, t[:2, 1] - inset
    mid = (lo + hi) / 2
    xy = [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1]),
          (mid[0], lo[1]), (hi[0], mid[1]), (mid[0], hi[1]), (lo[0], mid[1])]
    z0 = t[2, 0] + off[:, 2].min()
    cx, cy = off[:, 0].mean(), off[:, 1].mean()
    return np.array([(xy[i][0] + cx, xy[i][1] + cy, z0 - STATION_DEPTHS_MM[i]) for i in range(n)])


def multilateration_tests(travel: ArrayLike, grid: Sequence[int] = DEFAULT_GRID,
                          stations: ArrayLike | None = None,
                          tool_offsets: Sequence[ArrayLike] = DEFAULT_TOOL_OFFSETS,
                          station_u_mm: float | None = None, n_stations: int = 4
                          ) -> list[Measurement]:
    """The planned multilateration measurements: one per station and tool offset.

    Parameters
    ----------
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    grid : sequence of 3 int
        Grid points along X, Y, Z.
    stations : array_like, shape (k, 3), optional
        Station pivots [mm]; default :func:`default_stations`.
    tool_offsets : sequence of array_like
        Reflector positions on the tool [mm].
    station_u_mm : float, optional
        Standard uncertainty of the station set-up written to the session [mm]; default
        none written (the reader's default applies).
    n_stations : int
        Number of default stations when ``stations`` is not given.

    Returns
    -------
    list of Measurement
        Ids ``trk-s<station>-t<offset>``, kind ``multilateration``, target ``cat_eye``.
    """
    offs = [np.asarray(o, dtype=float).reshape(3) for o in tool_offsets]
    if not offs:
        raise VolcalInputError("multilateration needs at least one tool offset")
    if stations is None:
        st = default_stations(travel, offs, n_stations)
    else:
        st = np.asarray(stations, dtype=float).reshape(-1, 3)
    if st.shape[0] < 3:
        raise VolcalInputError(f"multilateration needs at least 3 stations, got {st.shape[0]}")
    q = serpentine_grid(travel, grid)
    out = []
    for j, o in enumerate(offs, start=1):
        for i, s in enumerate(st, start=1):
            d = np.linalg.norm(q + o - s, axis=1)
            if d.min() < 50.0:
                raise VolcalInputError(f"station {i} at {list(s)} mm is within 50 mm of the "
                                       "grid: place the tracker outside the path")
            meta: dict[str, Any] = {"station_mm": [round(float(v), 3) for v in s],
                    "notes": f"tracker at station {i}, reflector at tool offset "
                             f"{', '.join(f'{v:g}' for v in o)} mm; dwell at every point"}
            if station_u_mm is not None:
                meta["station_u_mm"] = float(station_u_mm)
            n0 = (q[0] + o - s) / d[0]
            out.append(Measurement(f"trk-s{i}-t{j}", "multilateration", "cat_eye", q.copy(),
                                   None, n0, o, f"trk-s{i}-t{j}.csv", {}, meta))
    return out
