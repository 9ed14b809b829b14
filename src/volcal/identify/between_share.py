"""How much of the volumetric uncertainty lies between the readings.

The part between the readings (:mod:`volcal.identify.between`) is what readings at one
spacing cannot show; its share of the volumetric error's uncertainty tells a user whether
denser increments would pay: for the smoothness prior (a cubic smoothing spline's, an
integrated Wiener process) the conditional variance between two readings falls as the
cube of their spacing (Wahba 1990, ch. 1), so readings at half the spacing leave about an
eighth of it (benchmarks/README.md, lab notebook ``between_readings_factor``, has the
measurement). :func:`between_share` gives the largest standard uncertainty of the
volumetric error (noise part) over the volumetric indices' grid, :func:`share_grid`, with
and without the part, and the part's own largest value over that grid with the midpoints
between its points, :func:`part_grid` (the indices' points are often the readings
themselves, 10 increments of a travel, where the part is zero): ``volcal identify``
prints it and the report's uncertainty section states it, both from this function.
Before measuring, :func:`forecast_between` gives the part a plan would leave on a typical
machine (``volcal advise``).

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

from volcal.identify.design import read_functions

if TYPE_CHECKING:
    from volcal.identify.design import Design
    from volcal.identify.result import IdentificationResult
    from volcal.identify.settings import EstimatorSettings
    from volcal.model.parameters import ParameterLayout

__all__ = ["BetweenForecast", "BetweenShare", "between_share", "forecast_between",
           "part_grid", "share_grid"]

SHARE_POINTS = 11
"""Points per axis of :func:`share_grid`: the volumetric indices' grid
(:func:`volcal.standards.volumetric.work_zone_grid`'s default) [1]."""


@dataclass(frozen=True)
class BetweenShare:
    """The largest standard uncertainty of the volumetric error over a grid, by part.

    Attributes
    ----------
    u_um : float
        Largest standard uncertainty of a component over :func:`share_grid` (noise part,
        the part between the readings included; no systematic part) [um].
    u_without_um : float
        The same without the part between the readings [um].
    between_um : float
        Largest part between the readings at a point and component of :func:`part_grid`
        (the grid with its midpoints; in quadrature with the rest) [um].
    nodes : int
        Node values no reading touches, of the functions the readings move
        (:func:`volcal.identify.design.read_functions`; the part's columns).
    points : int
        Points of the uncertainties' grid (:func:`share_grid`, or the points given).
    part_points : int
        Points of the part's grid (:func:`part_grid`, or the points given).
    """

    u_um: float
    u_without_um: float
    between_um: float
    nodes: int
    points: int
    part_points: int

    def describe(self) -> str:
        """One plain sentence."""
        n = round(self.points ** (1 / 3))
        m = round(self.part_points ** (1 / 3))
        grid = (f"the volumetric indices' {n} x {n} x {n} grid of the travel"
                if n**3 == self.points else f"{self.points} points")
        where = ("there" if self.part_points == self.points
                 else f"over that grid with its midpoints ({m} x {m} x {m})")
        return (f"largest standard uncertainty of the volumetric error (noise part) over "
                f"{grid}: {self.u_um:.3f} um, {self.u_without_um:.3f} um without the part "
                f"between the readings; the part itself up to {self.between_um:.3f} um (in "
                f"quadrature) {where}, at the {self.nodes} node values no reading touches "
                "of the functions the readings move; "
                "readings at half the spacing would leave about a third of it (an eighth of "
                "its variance)")


@dataclass(frozen=True)
class BetweenForecast:
    """Before measuring: the part between the readings a plan would leave on a typical machine.

    Attributes
    ----------
    between_um : float
        Largest standard uncertainty of a volumetric error component from the part between
        the readings alone over :func:`part_grid`, with the prior of a typical machining
        centre (the hyperprior's centres: :attr:`EstimatorSettings.typical_scales`,
        ``kappa_centre``) [um].
    nodes : int
        Node values of the identification's grid no planned reading touches, of the
        functions the planned readings move
        (:func:`volcal.identify.design.read_functions`).
    points : int
        Points of :func:`part_grid`.
    """

    between_um: float
    nodes: int
    points: int

    def describe(self) -> str:
        """One plain sentence."""
        n = round(self.points ** (1 / 3))
        return (f"Between the readings: on a typical machine (the prior scales above) the "
                f"planned increments leave up to {self.between_um:.2f} um (standard "
                f"uncertainty) of the volumetric error between the readings, over the "
                f"volumetric indices' grid with its midpoints ({n} x {n} x {n}; "
                f"{self.nodes} node values no planned reading touches of the functions the "
                "readings move); readings at half the "
                "spacing would leave about a third of it. The measured data set the "
                "machine's own roughness, and volcal identify states the part it found.")

    def to_dict(self) -> dict[str, float | int]:
        """JSON-ready: ``between_um``, ``nodes``, ``points``."""
        return {"between_um": self.between_um, "nodes": self.nodes, "points": self.points}


def share_grid(result: IdentificationResult) -> NDArray[np.float64]:
    """The grid of :func:`between_share`'s uncertainties: the volumetric indices' grid.

    Parameters
    ----------
    result : IdentificationResult

    Returns
    -------
    ndarray, shape (m, 3)
        :func:`volcal.standards.volumetric.work_zone_grid` of ``result.errors.travel`` with
        :data:`SHARE_POINTS` per axis, the grid of the volumetric indices
        (:func:`volcal.standards.volumetric.volumetric_indices`) [mm].
    """
    from volcal.standards.volumetric import work_zone_grid

    return work_zone_grid(result.errors.travel, SHARE_POINTS)


def part_grid(travel: NDArray[np.float64]) -> NDArray[np.float64]:
    """The grid of the part's largest value: :func:`share_grid` with its midpoints.

    Parameters
    ----------
    travel : ndarray, shape (3, 2)
        Axis travels [mm].

    Returns
    -------
    ndarray, shape (m, 3)
        ``2 SHARE_POINTS - 1`` points per axis [mm]: the indices' points are readings at 10
        increments of a travel, where the part is zero; their midpoints are nodes between
        the readings.
    """
    from volcal.standards.volumetric import work_zone_grid

    return work_zone_grid(np.asarray(travel, dtype=float), 2 * SHARE_POINTS - 1)


def _part(order, layout: ParameterLayout, cols: NDArray[np.intp], var: NDArray[np.float64],
          q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sqrt(sum_j J_pj^2 var_j)`` at each point and component (independent parts) [um].

    ``order``: the chain's axis order; ``cols``: parameters of ``layout`` carrying the
    variances ``var`` [um^2 or urad^2]; ``J`` the first-order Jacobian of the volumetric
    error at ``q`` [mm].
    """
    from volcal.model.kinematics import pose_jacobian

    Je, _ = pose_jacobian(order, layout.nodes, q)
    J = Je[:, cols].tocsr()
    return np.sqrt(np.asarray(J.multiply(J) @ var)).reshape(-1, 3)


def between_share(result: IdentificationResult,
                  q: NDArray[np.float64] | None = None) -> BetweenShare | None:
    """The volumetric uncertainty with and without the part between the readings.

    Parameters
    ----------
    result : IdentificationResult
        A model with uncertainty.
    q : ndarray, shape (m, 3), optional
        Points [mm] for all three figures; default :func:`share_grid` for the
        uncertainties and :func:`part_grid` for the part.

    Returns
    -------
    BetweenShare or None
        None when the model has no such part (every node read, or unread only in
        functions no reading moves; minimum norm; no uncertainty).
    """
    bf = result.between_factor
    if bf is None or bf.shape[1] == 0 or result.cov_factor is None:
        return None
    bf = np.asarray(bf)
    var = np.sum(bf**2, axis=1)
    free, untouched = np.asarray(result.free), var > 0
    # a model written before session 18 has the part at the functions no reading moves too
    keep = untouched & read_functions(result.layout, free, untouched)
    if not keep.any():  # only functions no reading moves: nothing between readings
        return None
    given = q is not None
    q = np.asarray(q, dtype=float).reshape(-1, 3) if given else share_grid(result)
    # the rest without the part (the narrower factor: the columns of the functions no
    # reading moves stay) and the part's own variance at each point, |J B|^2 (J the
    # first-order Jacobian of the volumetric error, B the part's factor, one node per
    # column): the parts are independent, u^2 = u_without^2 + |J B|^2
    bare = copy.copy(result)  # shallow: the arrays are shared
    rest = ~keep[np.abs(bf).argmax(axis=0)]  # each column: one node's row
    bare.between_factor = bf[:, rest] if rest.any() else None
    u0 = bare.predict(q, systematic=False)[1]
    cols, var = free[keep], var[keep]
    order, layout = result.errors.chain_obj.order, result.layout
    if given:
        part = here = _part(order, layout, cols, var, q)
    else:  # one Jacobian: the indices' grid is the part grid's even-indexed points
        part = _part(order, layout, cols, var, part_grid(result.errors.travel))
        n = 2 * SHARE_POINTS - 1
        here = part.reshape(n, n, n, 3)[::2, ::2, ::2].reshape(-1, 3)
    u = np.sqrt(u0**2 + here**2)
    return BetweenShare(float(u.max()), float(u0.max()), float(part.max()), int(keep.sum()),
                        int(q.shape[0]), int(part.shape[0]))


def forecast_between(design: Design, settings: EstimatorSettings,
                     travel: NDArray[np.float64]) -> BetweenForecast | None:
    """The part between the readings of a planned design, with a typical machine's prior.

    The same variance as an identification adds (:func:`volcal.identify.between.
    between_readings_variance`: ``between_readings_factor`` times the prior's
    conditional variance at each node no reading touches), with the prior at the
    hyperprior's centres in place of the one the readings would fit, propagated to the
    volumetric error on :func:`part_grid`.

    Parameters
    ----------
    design : Design
        The identification's design of the planned session (its fine node grid).
    settings : EstimatorSettings
        ``typical_scales``, ``kappa_centre``, ``between_readings_factor``.
    travel : ndarray, shape (3, 2)
        Axis travels [mm].

    Returns
    -------
    BetweenForecast or None
        None when the part is off (factor 0) or every node of the functions the
        readings move is read.
    """
    from volcal.identify.between import between_readings_variance
    from volcal.identify.identifiability import _reference_prior
    from volcal.identify.prior import function_scales

    var = between_readings_variance(design, _reference_prior(design, settings),
                                    function_scales(np.asarray(settings.typical_scales,
                                                               dtype=float)),
                                    float(settings.between_readings_factor))
    # var > 0: the untouched nodes of the functions the readings move (the variance's rule)
    keep = var > 0
    if not keep.any():
        return None
    free = np.asarray(design.free)
    from volcal.model.chain import parse_chain

    q = part_grid(travel)
    part = _part(parse_chain(design.chain).order, design.layout, free[keep], var[keep], q)
    return BetweenForecast(float(part.max()), int(keep.sum()), int(q.shape[0]))
