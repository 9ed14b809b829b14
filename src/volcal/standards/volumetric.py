"""Volumetric indices of a machine model over its work zone (ISO 230-1:2012).

From an identified (or simulated) :class:`~volcal.model.errorfunctions.MachineErrors`, the
first-order volumetric error ``e(q)`` [um] (actual minus commanded tool point,
:func:`volcal.model.kinematics.volumetric_error`) is evaluated on an ``n x n x n`` grid
over ``errors.travel``. volcal reports:

* ``E_VX``, ``E_VY``, ``E_VZ``: the range (max - min) of each component of ``e`` over the
  grid (ISO 230-1:2012 "volumetric error" components, the definitions used in the
  issue);
* ``E_VXYZ``: the largest length of the error vector ``max |e(q)|`` over the grid. This
  depends on the reference: volcal's model is zero at the start of travel of every axis,
  so ``E_VXYZ`` is measured from the start corner. The reference-free figure
  ``E_VXYZ_range = max |e(q1) - e(q2)|`` (largest distance between two error vectors,
  the "vector range") is reported as well.

Caveat: the standard's text was not available while writing this module; the
definitions above are the ones stated in volcal's issue 4 and are applied exactly as
written here. The grid includes the travel limits; with ``n = 11`` the steps are a tenth
of each travel.

Seed 002's ELv from the model is :func:`elv_from_model` (ranges of EXX, EYY, EZZ).

References
----------
.. [1] ISO 230-1:2012, Test code for machine tools - Part 1: Geometric accuracy of machines
   operating under no-load or quasi-static conditions (volumetric performance).
.. [2] H. Schwenke et al., "Geometric error measurement and compensation of machines - An
   update", CIRP Annals 57 (2008) 660-675.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.model.kinematics import volumetric_error
from volcal.standards.iso230_6 import elv

__all__ = ["VolumetricIndices", "elv_from_model", "vector_range", "vector_range_pair",
           "vector_range_pairs", "vector_ranges", "volumetric_indices", "work_zone_grid"]


@dataclass
class VolumetricIndices:
    """Volumetric indices over the work zone [um].

    Attributes
    ----------
    E_VX, E_VY, E_VZ : float
        Range of each component of the volumetric error [um].
    E_VXYZ : float
        Largest length of the volumetric error vector (from the start corner) [um].
    E_VXYZ_range : float
        Largest distance between two volumetric error vectors [um].
    worst_point_mm : ndarray, shape (3,)
        Grid point of ``E_VXYZ`` [mm].
    n : int
        Grid points per axis.
    """

    E_VX: float
    E_VY: float
    E_VZ: float
    E_VXYZ: float
    E_VXYZ_range: float
    worst_point_mm: NDArray[np.float64]
    n: int
    uncertainty: Any = None

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-friendly dict.

        With an ``uncertainty`` (:class:`volcal.standards.model_uncertainty.
        ModelUncertainty`) the dict carries ``U_E_VX`` ... ``U_E_VXYZ_range`` [um],
        ``k_volumetric`` and the details under ``uncertainty``.
        """
        d = asdict(self)
        d.pop("uncertainty", None)
        d["worst_point_mm"] = [float(v) for v in self.worst_point_mm]
        if self.uncertainty is not None:
            d.update(self.uncertainty.volumetric_keys())
            d["uncertainty"] = self.uncertainty.to_dict()
        return d


def work_zone_grid(travel: ArrayLike, n: int = 11) -> NDArray[np.float64]:
    """``n`` x ``n`` x ``n`` points spanning the travel [mm], X varying slowest.

    Parameters
    ----------
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    n : int
        Points per axis (at least 2).

    Returns
    -------
    ndarray, shape (n**3, 3)

    Raises
    ------
    VolcalInputError
        ``n < 2``.
    """
    if n < 2:
        raise VolcalInputError("volumetric indices need n >= 2 grid points per axis",
                               column="n")
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    g = np.meshgrid(*[np.linspace(lo, hi, n) for lo, hi in t], indexing="ij")
    return np.stack([a.ravel() for a in g], axis=1)


def volumetric_indices(errors: Any, tool_offset: ArrayLike = (0.0, 0.0, 0.0),
                       n: int = 11) -> VolumetricIndices:
    """Volumetric indices E_VX, E_VY, E_VZ, E_VXYZ of a machine model.

    Parameters
    ----------
    errors : MachineErrors
        The machine's error functions.
    tool_offset : array_like, shape (3,)
        Tool point offset [mm].
    n : int
        Grid points per axis over ``errors.travel`` (``n**3`` points in all).

    Returns
    -------
    VolumetricIndices
    """
    q = work_zone_grid(errors.travel, int(n))
    e = volumetric_error(errors, q, np.asarray(tool_offset, dtype=float))
    length = np.linalg.norm(e, axis=1)
    k = int(np.argmax(length))
    vrange = vector_range(e)
    ptp = np.ptp(e, axis=0)
    return VolumetricIndices(float(ptp[0]), float(ptp[1]), float(ptp[2]), float(length[k]),
                             vrange, q[k], int(n))


def _hull_points(e: NDArray[np.float64]) -> NDArray[np.intp]:
    """Indices of the points that can attain the largest pairwise distance."""
    try:
        from scipy.spatial import ConvexHull, QhullError

        try:
            idx = np.asarray(ConvexHull(e).vertices, dtype=np.intp)
        except (QhullError, ValueError):
            idx = np.arange(e.shape[0])
    except ImportError:  # pragma: no cover - scipy is a dependency
        idx = np.arange(e.shape[0])
    if idx.size > 4000:
        pts = e[idx]
        idx = idx[np.argsort(-np.linalg.norm(pts - pts.mean(axis=0), axis=1))[:4000]]
    return idx


def _hull_pair(e: NDArray[np.float64]) -> tuple[int, int]:
    """The pair of :func:`vector_range_pair` by the convex hull: the definition.

    The largest of the distances between the hull's vertices (all points when the hull
    cannot be made: fewer than 4 points, all on a plane), each ``sqrt`` of the summed
    squared differences, the first largest in the order of the vertices' indices.
    """
    idx = _hull_points(e)
    pts = e[idx]
    if np.isfinite(pts).all() and pts.shape[0] > 2:
        # only the vertices that can reach the largest distance: a pair of length D has
        # d <= r_i + r_j <= r_i + R (r from the bounding box's centre), and D is at least
        # the longest distance from the vertex farthest out; the pair and its place in
        # the vertices' order are the same among them (a thin cloud's hull, e.g. the
        # field of one measured axis, has thousands of vertices, and all pairs took
        # seconds per draw of the model's uncertainty)
        dc = pts - (pts.min(axis=0) + pts.max(axis=0)) / 2
        r = np.sqrt((dc**2).sum(axis=1))
        low = np.sqrt(((dc - dc[np.argmax(r)]) ** 2).sum(axis=1)).max()
        keep = np.flatnonzero(r + r.max() >= low * (1.0 - 1e-9))
        idx, pts = idx[keep], pts[keep]
    d = np.sqrt(((pts[:, None, :] - pts[None, :, :]) ** 2).sum(axis=2))
    i, j = np.unravel_index(int(np.argmax(d)), d.shape)
    return int(idx[i]), int(idx[j])


#: A pair is taken without the hull when every other pair is shorter by more than this
#: fraction of its length (:func:`_clear_pairs`).
CLEAR_MARGIN = 1e-6

#: ... and the cloud is not flat or thin: the smallest eigenvalue of its scatter matrix at
#: least this fraction of the largest (its thickness at least 1e-3 of its length).
THIN_RATIO = 1e-6


def _clear_pairs(ef: NDArray[np.float64]) -> NDArray[np.intp]:
    """The pair of the largest distance of each cloud where it is clear, without a hull.

    Parameters
    ----------
    ef : ndarray, shape (m, 3, k)
        ``k`` clouds of ``m`` error vectors [um], the clouds last (as the Monte Carlo
        draws of a field come: every step below runs along the clouds at once).

    Returns
    -------
    ndarray of int, shape (k, 2)
        ``(i, j)``, ``i < j``, of the one pair longer than every other by more than
        :data:`CLEAR_MARGIN` of its length; ``(-1, -1)`` where no pair is that clear, the
        cloud is flat or thin (:data:`THIN_RATIO`), not finite, or ``m`` is outside
        ``4 ... 4000``.

    Notes
    -----
    The search: every point lies within ``r_i + R`` of point ``i`` (``r_i`` its distance
    from the centre of the cloud's bounding box, ``R`` the largest ``r``), and the point
    farthest from the one farthest from the centre gives a pair of length ``L <= D``, the
    largest distance. A pair within the margin of ``D`` has both points with ``r + R >=
    L`` and one of them with ``r >= L / 2``: the distances from the few points of the
    second kind to those of the first (about a fortieth of all pairs on the default
    session's draws) are computed, and the largest taken when no other pair comes within
    the margin.

    Why that pair is the hull's (:func:`_hull_pair`): every other point lies within ``D2
    < D (1 - margin)`` of either end of the pair, so each end is outside the hull of all
    other points by at least ``D - D2``; both are vertices of the hull, the pair is the
    longest between vertices and, unique, it is the hull's choice, in the order ``i < j``
    (the hull's vertices come in increasing order and the first largest entry of a
    symmetric distance matrix lies above its diagonal). Qhull decides by its rounding
    where that is not so: a point doubled a hair away (it keeps one of the two as its
    vertex, which one is its choice) or a cloud nearly flat (it merges facets and drops
    vertices; such clouds also let a point lie close to the hull's facets far from the
    hull). The margin and the thickness test leave those to the hull; without either,
    some of them get another point (tests/standards/test_vector_range_fast.py).
    """
    m, _, k = ef.shape
    out = np.full((k, 2), -1, dtype=np.intp)
    if not 4 <= m <= 4000 or k == 0:
        return out
    finite = np.asarray(np.isfinite(ef).all(axis=(0, 1)))
    if not finite.all():  # left to the hull, as they were
        ef = np.where(finite, ef, 0.0)
    dc = ef - (ef.min(axis=0) + ef.max(axis=0)) / 2    # from the box's centre, (m, 3, k)
    r2 = np.einsum("mik,mik->mk", dc, dc)
    r = np.sqrt(r2)
    a = dc[np.argmax(r2, axis=0), :, np.arange(k)]      # the point farthest from the centre
    # |x - a|^2 = |x|^2 - 2 a.x + |a|^2: the longest distance from a, a pair's length
    far2 = r2 - 2 * np.einsum("mik,ki->mk", dc, a) + np.einsum("ki,ki->k", a, a)
    low = np.sqrt(np.maximum(far2.max(axis=0), 0.0))
    slack = low * (1 - 4 * CLEAR_MARGIN)
    keep = (r + r.max(axis=0) >= slack).T   # (k, m): can reach the largest distance
    outer = (r >= slack / 2).T              # of two such points, one is this far out
    # the scatter matrix about the mean, from the one about the box's centre
    mean = dc.mean(axis=0).T
    scatter = np.einsum("mik,mjk->kij", dc, dc) - m * mean[:, :, None] * mean[:, None, :]
    lam = np.linalg.eigvalsh(scatter)
    ok = finite & (lam[:, 0] >= THIN_RATIO * lam[:, 2]) & (lam[:, 2] > 0)
    # the outer points (rows) against all that can reach (columns), cloud by cloud; a pair
    # of two outer points comes twice, (i, j) and (j, i), with the same float
    kt, km = np.nonzero(keep)
    ot, om = np.nonzero(outer)
    kxyz = np.ascontiguousarray(dc[km, :, kt].T)        # their coordinates, (3, n) each
    oxyz = np.ascontiguousarray(dc[om, :, ot].T)
    kend, oend = np.cumsum(keep.sum(axis=1)), np.cumsum(outer.sum(axis=1))
    for t in np.flatnonzero(ok):
        k0, o0 = (kend[t - 1], oend[t - 1]) if t else (0, 0)
        cols, rows = km[k0:kend[t]], om[o0:oend[t]]
        diff = oxyz[:, o0:oend[t], None] - kxyz[:, None, k0:kend[t]]
        d2 = np.einsum("iab,iab->ab", diff, diff)
        flat = int(np.argmax(d2))
        top = d2.flat[flat]
        i, j = divmod(flat, d2.shape[1])
        once = 2 if outer[t, cols[j]] else 1
        if top > 0 and np.count_nonzero(d2 >= top * (1 - 2 * CLEAR_MARGIN)) == once:
            out[t] = sorted((int(rows[i]), int(cols[j])))
    return out


def vector_range_pairs(e: ArrayLike, draws_last: bool = False) -> NDArray[np.intp]:
    """The pair of :func:`vector_range_pair` of each of many clouds of error vectors.

    Parameters
    ----------
    e : array_like, shape (k, m, 3), or (m, 3, k) with ``draws_last``
        ``k`` sets of ``m`` error vectors [um] (e.g. the Monte Carlo draws of one field
        over one grid).
    draws_last : bool
        ``e[:, :, t]`` is set ``t`` (the layout of draws made as columns, and the faster).

    Returns
    -------
    ndarray of int, shape (k, 2)
        For each set, the pair :func:`vector_range_pair` gives, the same indices in the
        same order: found without the convex hull where one pair is clearly the longest
        (:func:`_clear_pairs`), by the hull otherwise (ties, flat or thin clouds).
    """
    ef = _draws_last(e, draws_last)
    out = _clear_pairs(ef)
    for t in np.flatnonzero(out[:, 0] < 0):
        out[t] = _hull_pair(np.ascontiguousarray(ef[:, :, t]))
    return out


def _draws_last(e: ArrayLike, already: bool) -> NDArray[np.float64]:
    """Error vectors as an array of shape (m, 3, k) (a view); refuse other shapes."""
    e = np.asarray(e, dtype=float)
    if e.ndim != 3 or e.shape[1 if already else 2] != 3 or e.shape[0 if already else 1] == 0:
        raise VolcalInputError("vector range: error vectors of shape (k, m, 3), m >= 1",
                               column="e")
    return e if already else e.transpose(1, 2, 0)


def vector_range_pair(e: ArrayLike) -> tuple[int, int]:
    """The two points of the largest distance between two error vectors.

    Parameters
    ----------
    e : array_like, shape (m, 3)
        Error vectors [um].

    Returns
    -------
    tuple of int
        Their indices (it is attained between vertices of the convex hull; the first
        such pair in the order of the vertices' indices, ``i <= j``).
    """
    e = np.asarray(e, dtype=float)
    i, j = vector_range_pairs(e.reshape(1, -1, 3))[0]
    return int(i), int(j)


def vector_range(e: ArrayLike) -> float:
    """Largest distance between two error vectors, ``max |e(q1) - e(q2)|`` [um].

    Parameters
    ----------
    e : array_like, shape (m, 3)
        Error vectors [um].

    Returns
    -------
    float
    """
    e = np.asarray(e, dtype=float)
    i, j = vector_range_pair(e)
    return float(np.linalg.norm(e[i] - e[j]))


def vector_ranges(e: ArrayLike, draws_last: bool = False) -> NDArray[np.float64]:
    """:func:`vector_range` of each of many clouds of error vectors [um].

    Parameters
    ----------
    e : array_like, shape (k, m, 3), or (m, 3, k) with ``draws_last``
        ``k`` sets of ``m`` error vectors [um].
    draws_last : bool
        ``e[:, :, t]`` is set ``t``.

    Returns
    -------
    ndarray, shape (k,)
        The same numbers as :func:`vector_range` of each set.
    """
    ef = _draws_last(e, draws_last)
    pairs = vector_range_pairs(ef, draws_last=True)
    # the difference of the two vectors, contiguous, as vector_range takes its norm
    return np.array([float(np.linalg.norm(np.ascontiguousarray(ef[i, :, t] - ef[j, :, t])))
                     for t, (i, j) in enumerate(pairs)])


def elv_from_model(errors: Any, n: int = 101) -> dict[str, float]:
    """Seed 002's ELv from a model: RSS of the ranges of EXX, EYY and EZZ.

    Parameters
    ----------
    errors : MachineErrors
        The machine's error functions.
    n : int
        Sample points along each axis.

    Returns
    -------
    dict
        ``ELx``, ``ELy``, ``ELz`` and ``ELv`` [um].
    """
    out: dict[str, float] = {}
    for i, (name, key) in enumerate((("EXX", "ELx"), ("EYY", "ELy"), ("EZZ", "ELz"))):
        lo, hi = errors.travel[i]
        out[key] = float(np.ptp(errors.function(name, np.linspace(lo, hi, n))))
    out["ELv"] = elv(out["ELx"], out["ELy"], out["ELz"])
    return out
