"""Tabulated error functions of a 3-axis machine: 18 component errors and 3 squareness errors.

Each axis carries a table of node positions [mm] and the six component errors at those
nodes: the three translations EX, EY, EZ [um] and the three rotations EA, EB, EC [urad]
(ISO 230-1 names, the axis letter appended: EXX, EYX, ... ECZ). Between nodes the
functions are interpolated linearly; outside the nodes they are held constant.

The convention (see ``docs/conventions.md``): every component error is the error motion
of the tool relative to the workpiece caused by that axis alone, observed at the tool
point on the axis' reference line; rotations act on the Abbe lever arm from the
reference line to the tool point. Identified and generated machines are normalised so
that every function is zero at the start of its travel and the straightness functions
are also zero at the end (end-point reference line); the slopes then live in the
squareness errors.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.chain import Chain, parse_chain
from volcal.model.names import AXES, COMPONENT_NAMES, SQUARENESS_NAMES

__all__ = ["MachineErrors", "interp_weights"]


def interp_weights(nodes: NDArray[np.float64], q: NDArray[np.float64]):
    """Linear interpolation indices and weights on a node grid (constant outside).

    Parameters
    ----------
    nodes : ndarray, shape (n,)
        Strictly increasing node positions [mm].
    q : ndarray, shape (m,)
        Query positions [mm].

    Returns
    -------
    i0, i1 : ndarray of int, shape (m,)
        Left and right node of each query.
    w : ndarray, shape (m,)
        Weight of the right node; the value is ``(1 - w) f[i0] + w f[i1]``.
    """
    nodes = np.asarray(nodes, dtype=float)
    q = np.asarray(q, dtype=float)
    n = nodes.size
    if n == 1:
        z = np.zeros(q.shape, dtype=np.intp)
        return z, z, np.zeros(q.shape)
    i0 = np.searchsorted(nodes, q, side="right") - 1
    np.clip(i0, 0, n - 2, out=i0)
    i1 = i0 + 1
    lo = nodes[:-1].take(i0)
    w = (q - lo) / (nodes[1:] - nodes[:-1]).take(i0)
    np.clip(w, 0.0, 1.0, out=w)
    return i0, i1, w


@dataclass
class MachineErrors:
    """The 21 geometric errors of a 3-axis machine, tabulated per axis.

    Parameters
    ----------
    chain : str or Chain
        Kinematic chain code, read from workpiece to tool (``'XYFZ'``...).
    nodes : list of 3 arrays
        Node positions of X, Y and Z [mm], strictly increasing.
    values : list of 3 arrays, shape (n_k, 6)
        Component errors at the nodes: EX, EY, EZ [um], EA, EB, EC [urad].
    squareness : array, shape (3,)
        EC0Y, EB0Z, EA0Z [urad].
    reversal : array, shape (3,)
        Reversal (backlash) of each axis [um], used by the virtual machine for
        bidirectional runs: a target approached in the negative direction is offset by
        ``-reversal/2``, in the positive direction by ``+reversal/2``.
    name : str
        Machine name.
    """

    chain: Chain | str
    nodes: list[NDArray[np.float64]]
    values: list[NDArray[np.float64]]
    squareness: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    reversal: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    name: str = "machine"

    def __post_init__(self) -> None:
        if isinstance(self.chain, str):
            self.chain = parse_chain(self.chain)
        if len(self.nodes) != 3 or len(self.values) != 3:
            raise ValueError("nodes and values need one entry per axis (X, Y, Z)")
        self.nodes = [np.asarray(n, dtype=float).reshape(-1) for n in self.nodes]
        self.values = [np.asarray(v, dtype=float).reshape(-1, 6) for v in self.values]
        for k in range(3):
            if self.nodes[k].size != self.values[k].shape[0]:
                raise ValueError(f"axis {AXES[k]}: {self.nodes[k].size} nodes but "
                                 f"{self.values[k].shape[0]} rows of values")
            if self.nodes[k].size == 0:
                raise ValueError(f"axis {AXES[k]}: no nodes")
            if np.any(np.diff(self.nodes[k]) <= 0):
                raise ValueError(f"axis {AXES[k]}: node positions must increase strictly")
        self.squareness = np.asarray(self.squareness, dtype=float).reshape(3)
        self.reversal = np.asarray(self.reversal, dtype=float).reshape(3)

    @property
    def chain_obj(self) -> Chain:
        """The parsed chain."""
        assert isinstance(self.chain, Chain)
        return self.chain

    @classmethod
    def zero(cls, chain: str | Chain, travel: ArrayLike, name: str = "machine") -> MachineErrors:
        """Build a perfect machine: all 21 errors zero.

        Parameters
        ----------
        chain : str or Chain
            Chain code.
        travel : array_like, shape (3, 2)
            Travel limits of X, Y, Z [mm].
        name : str
            Machine name.
        """
        t = np.asarray(travel, dtype=float).reshape(3, 2)
        return cls(chain, [t[k].copy() for k in range(3)], [np.zeros((2, 6)) for _ in range(3)],
                   name=name)

    def component(self, axis: int, q: ArrayLike) -> NDArray[np.float64]:
        """Evaluate the six component errors of one axis at positions ``q``.

        Parameters
        ----------
        axis : int
            0, 1, 2 for X, Y, Z.
        q : array_like, shape (m,)
            Axis positions [mm].

        Returns
        -------
        ndarray, shape (m, 6)
            EX, EY, EZ [um] and EA, EB, EC [urad] of that axis.
        """
        cols = self.component_columns(axis, q)
        out = np.empty((cols[0].size, 6))
        for c in range(6):
            out[:, c] = cols[c]
        return out

    def component_columns(self, axis: int, q: ArrayLike) -> list[NDArray[np.float64]]:
        """Evaluate the six component errors of one axis as six contiguous arrays.

        Parameters
        ----------
        axis : int
            0, 1, 2 for X, Y, Z.
        q : array_like, shape (m,)
            Axis positions [mm].

        Returns
        -------
        list of 6 ndarray, shape (m,)
            EX, EY, EZ [um] and EA, EB, EC [urad] of that axis, interpolated linearly
            between the nodes and held constant outside (as :func:`interp_weights`).
        """
        q = np.asarray(q, dtype=float).reshape(-1)
        nodes, v = self.nodes[axis], self.values[axis]
        if nodes.size == 1:
            return [np.full(q.size, v[0, c]) for c in range(6)]
        i0, i1, w = interp_weights(nodes, q)
        vt = np.ascontiguousarray(v.T)
        omw = 1.0 - w
        # (1 - w) f0 + w f1 is exact at the nodes (w = 0 or 1)
        return [vt[c].take(i0) * omw + vt[c].take(i1) * w for c in range(6)]

    def function(self, name: str, q: ArrayLike) -> NDArray[np.float64]:
        """One named error at positions ``q``.

        Parameters
        ----------
        name : str
            ISO 230-1 name (``'EBX'``...) or a squareness name (``'EC0Y'``...).
        q : array_like
            Positions of the named axis [mm] (ignored for squareness).

        Returns
        -------
        ndarray
            Values [um] or [urad].
        """
        name = name.upper()
        if name in SQUARENESS_NAMES:
            return np.full(np.shape(q), self.squareness[SQUARENESS_NAMES.index(name)])
        if name not in COMPONENT_NAMES:
            raise KeyError(f"unknown error name {name!r}")
        idx = COMPONENT_NAMES.index(name)
        return self.component(idx // 6, q)[:, idx % 6]

    def scaled(self, factor: float) -> MachineErrors:
        """Return a copy with every error multiplied by ``factor``.

        Parameters
        ----------
        factor : float
            Scale applied to the component values, squareness and reversal (dimensionless).

        Returns
        -------
        MachineErrors
            A new model with the same chain and nodes.
        """
        return MachineErrors(self.chain, [n.copy() for n in self.nodes],
                             [v * factor for v in self.values], self.squareness * factor,
                             self.reversal * factor, self.name)

    def copy(self) -> MachineErrors:
        """Return a deep copy."""
        return self.scaled(1.0)

    @property
    def travel(self) -> NDArray[np.float64]:
        """Node range of each axis, shape (3, 2) [mm]."""
        return np.array([[n[0], n[-1]] for n in self.nodes])
