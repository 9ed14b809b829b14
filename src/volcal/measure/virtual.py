"""Virtual machines: random but realistic smooth error sets, reproducible from a seed.

The default ranges describe a machining centre of about 1 m travel: positioning
5-20 um, straightness 3-10 um, angular errors 5-30 urad (peak to valley over the
travel), squareness up to 50 urad. Every function is zero at the start of its travel and
the straightness functions also at the end (the conventions of ``docs/conventions.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.errorfunctions import MachineErrors

__all__ = ["ErrorRanges", "random_machine", "smooth_profile"]


@dataclass(frozen=True)
class ErrorRanges:
    """Peak-to-valley ranges of the random error functions.

    Attributes
    ----------
    positioning_um, straightness_um, angular_urad : tuple of float
        (min, max) of the peak-to-valley value drawn per function.
    squareness_urad : float
        Squareness errors are drawn uniformly in [-value, value].
    reversal_um : tuple of float
        (min, max) of the reversal of each axis [um].
    """

    positioning_um: tuple[float, float] = (5.0, 20.0)
    straightness_um: tuple[float, float] = (3.0, 10.0)
    angular_urad: tuple[float, float] = (5.0, 30.0)
    squareness_urad: float = 50.0
    reversal_um: tuple[float, float] = (0.0, 0.0)


def smooth_profile(rng: np.random.Generator, s: NDArray[np.float64], modes: int = 4,
                   slope: float = 0.0) -> NDArray[np.float64]:
    """A smooth random profile on ``s`` in [0, 1], zero at ``s = 0``, unit peak to valley.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    s : ndarray
        Normalised positions in [0, 1].
    modes : int
        Number of sine modes (amplitudes decay as 1/j).
    slope : float
        Weight of a linear trend (a lead-screw or scale error) added before normalising.
    """
    f = slope * rng.normal() * s
    for j in range(1, modes + 1):
        f = f + rng.normal() / j * np.sin(j * np.pi * s / 1.5 + rng.uniform(0, 2 * np.pi))
    f = f - f[0]
    ptp = np.ptp(f)
    return f / ptp if ptp > 0 else f


def random_machine(travel: ArrayLike, chain: str = "XYFZ", seed: int | None = 0,
                   n_nodes: int = 41, ranges: ErrorRanges | None = None,
                   name: str = "virtual machine") -> MachineErrors:
    """Draw a random smooth machine.

    Parameters
    ----------
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    chain : str
        Chain code.
    seed : int, optional
        Seed of the random generator (reproducible machines).
    n_nodes : int
        Nodes per axis of the tabulated functions.
    ranges : ErrorRanges, optional
        Peak-to-valley ranges.
    name : str
        Machine name.

    Returns
    -------
    MachineErrors
    """
    rng = np.random.default_rng(seed)
    r = ranges or ErrorRanges()
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    nodes, values = [], []
    s = np.linspace(0.0, 1.0, n_nodes)
    for k in range(3):
        nodes.append(np.linspace(t[k, 0], t[k, 1], n_nodes))
        v = np.zeros((n_nodes, 6))
        for c in range(6):
            if c == k:  # positioning: trend + waves
                v[:, c] = smooth_profile(rng, s, slope=3.0) * rng.uniform(*r.positioning_um)
            elif c < 3:  # straightness: bow relative to the end-point line
                f = smooth_profile(rng, s, modes=3)
                f = f - s * f[-1]
                ptp = np.ptp(f)
                v[:, c] = (f / ptp if ptp > 0 else f) * rng.uniform(*r.straightness_um)
            else:
                v[:, c] = smooth_profile(rng, s, modes=3, slope=1.0) * rng.uniform(*r.angular_urad)
            if rng.random() < 0.5:
                v[:, c] = -v[:, c]
        values.append(v)
    sq = rng.uniform(-r.squareness_urad, r.squareness_urad, 3)
    rev = rng.uniform(*r.reversal_um, 3)
    return MachineErrors(chain, nodes, values, sq, rev, name=name)
