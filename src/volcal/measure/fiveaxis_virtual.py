"""A virtual 5-axis machine with hidden location errors, and a probe-on-sphere pose grid.

Used by the tests and the study (``benchmarks/README.md``): location errors drawn
uniformly within ``+-pivot_um`` (positions of the axis lines) and ``+-tilt_urad``
(orientations and zeros of the angles), as the issue's study asks (pivot up to 2 mm,
tilts up to 200 urad).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.chain import parse_machine_chain
from volcal.model.errorfunctions import MachineErrors
from volcal.model.fiveaxis import FiveAxisMachine, location_parameter_names
from volcal.model.names import info
from volcal.model.rotary import RotaryAxis

__all__ = ["nominal_machine", "pose_grid", "random_location"]

FULL_CIRCLE_DEFAULT = {"A": False, "B": False, "C": True}
"""A and B are tilting axes (limited), C turns full circles, unless told otherwise."""

RANGE_DEFAULT = {"A": (-90.0, 90.0), "B": (-90.0, 90.0), "C": (0.0, 360.0)}
"""Default ranges [deg]."""


def nominal_machine(chain: str, pivots_mm: Mapping[str, ArrayLike],
                    full_circle: Mapping[str, bool] | None = None,
                    linear: MachineErrors | None = None, name: str = "machine"
                    ) -> FiveAxisMachine:
    """A machine as configured: nominal pivots, no location errors.

    Parameters
    ----------
    chain : str
        Chain code (``'CAFXYZ'``).
    pivots_mm : mapping of str to array_like
        Nominal pivot of each rotary axis [mm].
    full_circle : mapping of str to bool, optional
        Which axes turn full circles (default: C only).
    linear : MachineErrors, optional
        The linear axes' errors.
    name : str
        Machine name.
    """
    c = parse_machine_chain(chain)
    fc = {**FULL_CIRCLE_DEFAULT, **(full_circle or {})}
    rot = {r: RotaryAxis(r, np.asarray(pivots_mm[r], dtype=float), full_circle=fc[r])
           for r in c.rotary}
    return FiveAxisMachine(c, rot, linear, name)


def random_location(chain: str, rng: np.random.Generator, pivot_um: float = 2000.0,
                    tilt_urad: float = 200.0) -> dict[str, float]:
    """Random location errors: uniform within +-pivot_um and +-tilt_urad.

    Parameters
    ----------
    chain : str
        Chain code.
    rng : numpy.random.Generator
        Random source.
    pivot_um : float
        Bound of the positions [um].
    tilt_urad : float
        Bound of the orientations and zeros [urad].

    Returns
    -------
    dict of str to float
        Location errors by name.
    """
    return {n: float(rng.uniform(-1, 1) * (pivot_um if info(n).unit == "um" else tilt_urad))
            for n in location_parameter_names(chain)}


def pose_grid(chain: str, ranges: Mapping[str, tuple[float, float]] | None = None,
              counts: Mapping[str, int] | None = None) -> dict[str, NDArray[np.float64]]:
    """A full factorial grid of rotary poses for probe-on-sphere readings.

    Parameters
    ----------
    chain : str
        Chain code.
    ranges : mapping of str to (float, float), optional
        Range of each axis [deg]; a range of 360 deg or more is a full circle, sampled
        without its end (0 and 360 are one pose).
    counts : mapping of str to int, optional
        Angles per axis (default 6 for C, 5 for A and B).

    Returns
    -------
    dict of str to ndarray
        Angles per axis, one entry per pose [deg].
    """
    c = parse_machine_chain(chain)
    rng_ = {**RANGE_DEFAULT, **(ranges or {})}
    cnt = {"A": 5, "B": 5, "C": 6, **(counts or {})}
    grids = []
    for r in c.rotary:
        lo, hi = rng_[r]
        full = hi - lo >= 360.0
        grids.append(np.linspace(lo, hi, cnt[r], endpoint=not full))
    poses = list(itertools.product(*grids))
    return {r: np.array([p[i] for p in poses]) for i, r in enumerate(c.rotary)}
