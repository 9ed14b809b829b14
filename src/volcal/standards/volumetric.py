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
           "volumetric_indices", "work_zone_grid"]


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


def vector_range_pair(e: ArrayLike) -> tuple[int, int]:
    """The two points of the largest distance between two error vectors.

    Parameters
    ----------
    e : array_like, shape (m, 3)
        Error vectors [um].

    Returns
    -------
    tuple of int
        Their indices (it is attained between vertices of the convex hull).
    """
    e = np.asarray(e, dtype=float)
    idx = _hull_points(e)
    pts = e[idx]
    d = np.sqrt(((pts[:, None, :] - pts[None, :, :]) ** 2).sum(axis=2))
    i, j = np.unravel_index(int(np.argmax(d)), d.shape)
    return int(idx[i]), int(idx[j])


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
