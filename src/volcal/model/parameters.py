"""Parameter vector of the tabulated model: node values of the 18 functions and 3 squareness."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.errorfunctions import MachineErrors

__all__ = ["ParameterLayout"]


@dataclass(frozen=True)
class ParameterLayout:
    """Where each node value lives in the flat parameter vector.

    Parameters
    ----------
    nodes : tuple of 3 arrays
        Node positions of X, Y, Z [mm].
    """

    nodes: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]

    @classmethod
    def of_nodes(cls, nodes: Sequence[ArrayLike]) -> ParameterLayout:
        """The layout of three axes' nodes, each made a float array.

        Parameters
        ----------
        nodes : sequence of 3 array_like
            Node positions of X, Y, Z [mm].
        """
        x, y, z = (np.asarray(n, dtype=np.float64) for n in nodes)
        return cls((x, y, z))

    @property
    def starts(self) -> NDArray[np.intp]:
        """Index of the first parameter of each axis, and of the squareness block."""
        return np.concatenate([[0], np.cumsum([len(n) * 6 for n in self.nodes])]).astype(np.intp)

    @property
    def size(self) -> int:
        """Number of parameters."""
        return int(self.starts[-1]) + 3

    def indices(self, axis: int, component: int) -> NDArray[np.intp]:
        """Parameter indices of one function (all its nodes).

        Parameters
        ----------
        axis : int
            0..2.
        component : int
            0..5 (EX, EY, EZ, EA, EB, EC).
        """
        return self.starts[axis] + np.arange(len(self.nodes[axis])) * 6 + component

    def squareness_indices(self) -> NDArray[np.intp]:
        """Return the indices of EC0Y, EB0Z, EA0Z."""
        return self.starts[3] + np.arange(3)

    def pack(self, errors: MachineErrors) -> NDArray[np.float64]:
        """Parameter vector of a machine sampled at this layout's nodes.

        Parameters
        ----------
        errors : MachineErrors
            Any machine; its functions are interpolated onto the nodes.
        """
        theta = np.empty(self.size)
        for k in range(3):
            theta[self.starts[k]:self.starts[k + 1]] = errors.component(k, self.nodes[k]).ravel()
        theta[self.squareness_indices()] = errors.squareness
        return theta

    def unpack(self, theta: NDArray[np.float64], chain, name: str = "machine") -> MachineErrors:
        """Machine from a parameter vector.

        Parameters
        ----------
        theta : ndarray, shape (size,)
            Parameters [um, urad].
        chain : str or Chain
            Chain code.
        name : str
            Machine name.
        """
        values = [theta[self.starts[k]:self.starts[k + 1]].reshape(-1, 6) for k in range(3)]
        return MachineErrors(chain, [n.copy() for n in self.nodes], [v.copy() for v in values],
                             theta[self.squareness_indices()].copy(), name=name)
