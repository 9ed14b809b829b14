"""Errors of a rotary axis: five location errors and six component errors over the angle.

A rotary axis ``A``, ``B`` or ``C`` turns about a line parallel to X, Y or Z through its
nominal pivot point (the machine configuration's rotation point). Its **location
errors** (ISO 230-1:2012 3.5, ``volcal.model.names.LOCATION_NAMES``) are constants:

* two positions of the axis average line across the axis [um] (for C: ``EX0C``,
  ``EY0C``, the line's intersection with the plane through the nominal pivot normal to Z,
  minus the pivot);
* two orientations of the line [urad] (for C: ``EA0C``, ``EB0C``: the actual direction is
  the nominal +Z turned by the rotation vector ``(EA0C, EB0C, 0)``, i.e. about
  ``(EB0C, -EA0C, 1)`` to first order: ``EB0C > 0`` leans the line towards +X as
  ``EB0Z`` does for the Z slide);
* the zero of the angle [urad] (``EC0C``: actual minus commanded angle at every angle).

Its **component errors** (ISO 230-7:2015; ``EXC``, ``EYC`` radial, ``EZC`` axial [um];
``EAC``, ``EBC`` tilt, ``ECC`` angular positioning [urad]) are functions of the angle,
tabulated on nodes [deg] and interpolated linearly; for a full-circle axis the table is
periodic (360 deg wraps to 0), for a limited axis it is held constant outside its nodes.
Every error is, as for the linear axes, the error motion of the tool relative to the
workpiece (``docs/fiveaxis.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.errorfunctions import interp_weights
from volcal.model.names import LOCATION_NAMES, ROTARY_AXIS_OF, ROTARY_COMPONENT_NAMES

__all__ = ["RotaryAxis", "periodic_weights"]


def periodic_weights(nodes: NDArray[np.float64], angle_deg: NDArray[np.float64]):
    """Linear interpolation indices and weights on a periodic (360 deg) node grid.

    Parameters
    ----------
    nodes : ndarray, shape (n,)
        Strictly increasing node angles in [0, 360) [deg].
    angle_deg : ndarray, shape (m,)
        Query angles [deg], any value (taken modulo 360).

    Returns
    -------
    i0, i1 : ndarray of int, shape (m,)
        Left and right node of each query (the right node of the last interval is node 0).
    w : ndarray, shape (m,)
        Weight of the right node.
    """
    nodes = np.asarray(nodes, dtype=float)
    a = np.mod(np.asarray(angle_deg, dtype=float), 360.0)
    n = nodes.size
    if n == 1:
        z = np.zeros(a.shape, dtype=np.intp)
        return z, z, np.zeros(a.shape)
    ext = np.concatenate([nodes, [nodes[0] + 360.0]])
    a = np.where(a < nodes[0], a + 360.0, a)
    i0 = np.clip(np.searchsorted(ext, a, side="right") - 1, 0, n - 1)
    w = (a - ext[i0]) / (ext[i0 + 1] - ext[i0])
    return i0, np.mod(i0 + 1, n), np.clip(w, 0.0, 1.0)


@dataclass
class RotaryAxis:
    """One rotary axis of a machine: nominal pivot, location errors, component errors.

    Parameters
    ----------
    letter : str
        ``'A'``, ``'B'`` or ``'C'``.
    pivot_mm : array_like, shape (3,)
        Nominal point of the axis line, in the coordinates of the body that carries the
        axis with every axis at zero (the machine coordinates of the workpiece at the zero
        pose) [mm]. Its component along the axis only fixes where ``EX0C``, ``EY0C`` are
        read and where the component errors act.
    location : dict of str to float, optional
        Location errors by ISO 230-1 name (``'EX0C'``: um, ``'EA0C'``: urad); missing
        ones are zero.
    nodes_deg : array_like, shape (n,), optional
        Node angles of the component errors [deg]; default one node (constant zero).
    values : array_like, shape (n, 6), optional
        Component errors at the nodes: EX, EY, EZ [um], EA, EB, EC [urad] of this axis.
    full_circle : bool
        True for an axis that turns full circles (the component table is periodic).
    """

    letter: str
    pivot_mm: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    location: dict[str, float] = field(default_factory=dict)
    nodes_deg: NDArray[np.float64] = field(default_factory=lambda: np.zeros(1))
    values: NDArray[np.float64] = field(default_factory=lambda: np.zeros((1, 6)))
    full_circle: bool = True

    def __post_init__(self) -> None:
        self.letter = self.letter.upper()
        if self.letter not in ROTARY_AXIS_OF:
            raise ValueError(f"rotary axis must be A, B or C, got {self.letter!r}")
        self.pivot_mm = np.asarray(self.pivot_mm, dtype=float).reshape(3)
        unknown = set(self.location) - set(LOCATION_NAMES[self.letter])
        if unknown:
            raise ValueError(f"axis {self.letter}: unknown location errors {sorted(unknown)}; "
                             f"expected {', '.join(LOCATION_NAMES[self.letter])}")
        self.location = {n: float(self.location.get(n, 0.0)) for n in LOCATION_NAMES[self.letter]}
        self.nodes_deg = np.asarray(self.nodes_deg, dtype=float).reshape(-1)
        self.values = np.asarray(self.values, dtype=float).reshape(-1, 6)
        if self.nodes_deg.size != self.values.shape[0] or self.nodes_deg.size == 0:
            raise ValueError(f"axis {self.letter}: {self.nodes_deg.size} nodes but "
                             f"{self.values.shape[0]} rows of component values")
        if np.any(np.diff(self.nodes_deg) <= 0):
            raise ValueError(f"axis {self.letter}: node angles must increase strictly")
        if self.full_circle and self.nodes_deg.size > 1 and (
                self.nodes_deg[0] < 0 or self.nodes_deg[-1] >= 360):
            raise ValueError(f"axis {self.letter}: a full-circle axis has nodes in [0, 360)")

    @property
    def index(self) -> int:
        """Index 0, 1, 2 of the linear axis the rotary axis is parallel to."""
        return "ABC".index(self.letter)

    @property
    def direction(self) -> NDArray[np.float64]:
        """Nominal unit direction of the axis (+X, +Y or +Z)."""
        e = np.zeros(3)
        e[self.index] = 1.0
        return e

    @property
    def location_names(self) -> tuple[str, ...]:
        """The five location error names, in the order of ``location_vector``."""
        return LOCATION_NAMES[self.letter]

    @property
    def component_names(self) -> tuple[str, ...]:
        """The six component error names (EXC ... ECC for C)."""
        return ROTARY_COMPONENT_NAMES[self.letter]

    def location_vector(self) -> NDArray[np.float64]:
        """The five location errors [um, um, urad, urad, urad] in ``location_names`` order."""
        return np.array([self.location[n] for n in self.location_names])

    def position_um(self) -> NDArray[np.float64]:
        """Position error of the axis line as a 3-vector (zero along the axis) [um]."""
        d = np.zeros(3)
        across = [a for a in range(3) if a != self.index]
        names = self.location_names
        d[across[0]], d[across[1]] = self.location[names[0]], self.location[names[1]]
        return d

    def orientation_urad(self) -> NDArray[np.float64]:
        """Orientation error as a rotation vector (zero about the axis itself) [urad]."""
        o = np.zeros(3)
        across = [a for a in range(3) if a != self.index]
        names = self.location_names
        o[across[0]], o[across[1]] = self.location[names[2]], self.location[names[3]]
        return o

    def zero_urad(self) -> float:
        """Zero error of the angle [urad]."""
        return self.location[self.location_names[4]]

    def weights(self, angle_deg: ArrayLike):
        """Interpolation nodes and weights of the component table at ``angle_deg``.

        Parameters
        ----------
        angle_deg : array_like, shape (m,)
            Commanded angles [deg].

        Returns
        -------
        i0, i1, w
            As :func:`volcal.model.errorfunctions.interp_weights` (periodic for a
            full-circle axis).
        """
        a = np.asarray(angle_deg, dtype=float).reshape(-1)
        if self.full_circle:
            return periodic_weights(self.nodes_deg, a)
        return interp_weights(self.nodes_deg, a)

    def component(self, angle_deg: ArrayLike) -> NDArray[np.float64]:
        """The six component errors at the commanded angles.

        Parameters
        ----------
        angle_deg : array_like, shape (m,)
            Commanded angles [deg].

        Returns
        -------
        ndarray, shape (m, 6)
            EX, EY, EZ [um], EA, EB, EC [urad] of this axis.
        """
        i0, i1, w = self.weights(angle_deg)
        return self.values[i0] * (1.0 - w)[:, None] + self.values[i1] * w[:, None]

    def copy(self, **location: float) -> RotaryAxis:
        """A copy, with some location errors replaced.

        Parameters
        ----------
        **location : float
            Location errors by name [um or urad].
        """
        loc = dict(self.location)
        loc.update(location)
        return RotaryAxis(self.letter, self.pivot_mm.copy(), loc, self.nodes_deg.copy(),
                          self.values.copy(), self.full_circle)
