"""How much of the volumetric uncertainty lies between the readings.

The part between the readings (:mod:`volcal.identify.between`) is what readings at one
spacing cannot show; its share of the volumetric error's uncertainty tells a user whether
denser increments would pay: for the smoothness prior (a cubic smoothing spline's, an
integrated Wiener process) the conditional variance between two readings falls as the
cube of their spacing (Wahba 1990, ch. 1), so readings at half the spacing leave about an
eighth of it (benchmarks/README.md, lab notebook ``between_readings_factor``, has the
measurement). :func:`between_share` gives the largest standard uncertainty of the
volumetric error (noise part) over the volumetric indices' grid, :func:`share_grid`, with
and without the part: ``volcal identify`` prints it and the report's uncertainty section
states it, both from this function on this grid.

References
----------
Wahba, G. (1990). *Spline Models for Observational Data*. SIAM, ch. 1 (the spline as the
posterior mean of an integrated Wiener process).
JCGM 100:2008 (GUM), 5.1.2 (standard uncertainties of independent parts combined in
quadrature).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from volcal.identify.result import IdentificationResult

__all__ = ["BetweenShare", "between_share", "share_grid"]


@dataclass(frozen=True)
class BetweenShare:
    """The largest standard uncertainty of the volumetric error over a grid, by part.

    Attributes
    ----------
    u_um : float
        Largest standard uncertainty of a component (noise part, the part between the
        readings included; no systematic part) [um].
    u_without_um : float
        The same without the part between the readings [um].
    between_um : float
        Largest part between the readings at a point and component,
        ``sqrt(u^2 - u_without^2)`` [um].
    nodes : int
        Node values no reading touches (the part's columns).
    points : int
        Grid points.
    """

    u_um: float
    u_without_um: float
    between_um: float
    nodes: int
    points: int

    def describe(self) -> str:
        """One plain sentence."""
        n = round(self.points ** (1 / 3))
        return (f"largest standard uncertainty of the volumetric error (noise part) over the "
                f"volumetric indices' {n} x {n} x {n} grid of the travel: "
                f"{self.u_um:.3f} um, {self.u_without_um:.3f} um without the part between "
                f"the readings (up to {self.between_um:.3f} um of it, in quadrature, at the "
                f"{self.nodes} node values no reading touches; readings at half the spacing "
                "would leave about an eighth of its variance)")


def share_grid(result: IdentificationResult) -> NDArray[np.float64]:
    """The grid of :func:`between_share`: the volumetric indices' grid of the model's travel.

    Parameters
    ----------
    result : IdentificationResult

    Returns
    -------
    ndarray, shape (m, 3)
        :func:`volcal.standards.volumetric.work_zone_grid` of ``result.errors.travel`` with
        its default points per axis, the grid of the volumetric indices
        (:func:`volcal.standards.volumetric.volumetric_indices`) [mm].
    """
    from volcal.standards.volumetric import work_zone_grid

    return work_zone_grid(result.errors.travel)


def between_share(result: IdentificationResult,
                  q: NDArray[np.float64] | None = None) -> BetweenShare | None:
    """The volumetric uncertainty with and without the part between the readings.

    Parameters
    ----------
    result : IdentificationResult
        A model with uncertainty.
    q : ndarray, shape (m, 3), optional
        Points [mm]; default :func:`share_grid`.

    Returns
    -------
    BetweenShare or None
        None when the model has no such part (every node read, minimum norm, no
        uncertainty).
    """
    bf = result.between_factor
    if bf is None or bf.shape[1] == 0 or result.cov_factor is None:
        return None
    from volcal.model.kinematics import pose_jacobian

    q = share_grid(result) if q is None else np.asarray(q, dtype=float).reshape(-1, 3)
    # the rest without the part (the narrower factor), and the part's own variance at each
    # point, |J B|^2 (J the first-order Jacobian of the volumetric error, B the part's
    # factor): the parts are independent, u^2 = u_without^2 + |J B|^2
    bare = copy.copy(result)  # shallow: the arrays are shared
    bare.between_factor = None
    u0 = bare.predict(q, systematic=False)[1]
    Je, _ = pose_jacobian(result.errors.chain_obj.order, result.layout.nodes, q)
    G = Je[:, result.free] @ np.asarray(bf)
    part = np.sqrt(np.sum(np.asarray(G) ** 2, axis=1)).reshape(-1, 3)
    u = np.sqrt(u0**2 + part**2)
    return BetweenShare(float(u.max()), float(u0.max()), float(part.max()), int(bf.shape[1]),
                        int(q.shape[0]))
