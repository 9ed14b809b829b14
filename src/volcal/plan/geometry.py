"""Commanded poses of every test of the seeds.

* linear displacement along one axis at a chosen Abbe offset, bidirectional runs as in
  ISO 230-2:2014, 5.3 (each run moves up through all targets, then down);
* the 4 body diagonals ``ppp, npp, pnp, ppn`` and the face diagonals ``pp, np`` of each
  plane (ASME B5.54, ISO 230-6:2002; seed 000 sections 3 and 5);
* sequential step diagonals (Wang's "vector" test, seed 000 section 4; Soons section 4-5),
  body or face, with any axis order, ``N`` increments: each increment moves the axes one
  after the other and a reading is taken after every single-axis move.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.model.names import AXES

BODY_DIAGONALS: tuple[str, ...] = ("ppp", "npp", "pnp", "ppn")
"""Body diagonal codes: the sign of the travel direction of X, Y, Z (seed 000, Fig. 1)."""

FACE_PLANES: tuple[str, ...] = ("xy", "yz", "xz")
FACE_DIAGONALS: tuple[str, ...] = ("pp", "np")


@dataclass
class TestGeometry:
    """Commanded poses of one test.

    Attributes
    ----------
    positions : ndarray, shape (n, 3)
        Commanded positions [mm], in reading order.
    beam_direction : ndarray, shape (3,)
        Nominal beam direction (unit vector, machine axes).
    run : ndarray of int, shape (n,), optional
        Run number (1-based) of each reading.
    direction : ndarray of str, shape (n,), optional
        Approach direction ``'+'`` or ``'-'`` of each reading (linear tests).
    meta : dict
        Axis, axis order, diagonal code, Abbe offset...
    """

    positions: NDArray[np.float64]
    beam_direction: NDArray[np.float64]
    run: NDArray[np.int64] | None = None
    direction: NDArray[np.str_] | None = None
    meta: dict = field(default_factory=dict)


def _travel(travel: ArrayLike) -> NDArray[np.float64]:
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    if np.any(t[:, 1] <= t[:, 0]):
        raise VolcalInputError("every travel needs max > min [mm]")
    return t


def _axis_index(axis: int | str) -> int:
    if isinstance(axis, str):
        if axis.upper() not in AXES:
            raise VolcalInputError(f"unknown axis {axis!r}: expected X, Y or Z")
        return AXES.index(axis.upper())
    return int(axis)


def iso_targets(lo: float, hi: float, steps: int, seed: int = 0) -> NDArray[np.float64]:
    """Target positions with unequal spacing, as ISO 230-2:2014 (5.2) recommends.

    The interior targets are moved from the uniform grid by a reproducible random amount of
    at most a quarter of the interval, so that periodic errors (lead screw, scale) are
    sampled at different phases; the end targets stay at the ends of travel.

    Parameters
    ----------
    lo, hi : float
        Ends of travel [mm].
    steps : int
        Number of intervals.
    seed : int
        Seed of the offsets.

    Returns
    -------
    ndarray, shape (steps + 1,)
        Target positions [mm], rounded to 0.001 mm.
    """
    t = np.linspace(lo, hi, steps + 1)
    if steps >= 2:
        p = (hi - lo) / steps
        r = np.random.default_rng(seed).uniform(-0.25, 0.25, steps - 1) * p
        t[1:-1] += r
    return np.round(t, 3)


def linear_test(axis: int | str, travel: ArrayLike, steps: int, at_mm: ArrayLike,
                runs: int = 1, bidirectional: bool = False,
                targets_mm: ArrayLike | None = None) -> TestGeometry:
    """Linear displacement test along one axis at a given Abbe offset.

    Parameters
    ----------
    axis : int or str
        Measured axis.
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    steps : int
        Number of increments; ``steps + 1`` targets from the start to the end of travel.
    at_mm : array_like, shape (3,)
        Position of the line: the coordinates of the two other axes are taken from it [mm].
    runs : int
        Number of runs.
    bidirectional : bool
        Each run goes up through the targets and then back down (ISO 230-2 cycle).
    targets_mm : array_like, optional
        Target positions [mm] (e.g. :func:`iso_targets`); default ``steps + 1`` equally
        spaced targets over the travel.

    Returns
    -------
    TestGeometry
    """
    k = _axis_index(axis)
    t = _travel(travel)
    if steps < 1:
        raise VolcalInputError("a linear test needs at least 1 increment")
    targets = (np.linspace(t[k, 0], t[k, 1], steps + 1) if targets_mm is None
               else np.asarray(targets_mm, dtype=float).reshape(-1))
    base = np.asarray(at_mm, dtype=float).reshape(3).copy()
    seq, run, dirn = [], [], []
    for r in range(1, runs + 1):
        seq.append(targets)
        run += [r] * targets.size
        dirn += ["+"] * targets.size
        if bidirectional:
            seq.append(targets[::-1])
            run += [r] * targets.size
            dirn += ["-"] * targets.size
    s = np.concatenate(seq)
    pos = np.tile(base, (s.size, 1))
    pos[:, k] = s
    n = np.zeros(3)
    n[k] = 1.0
    return TestGeometry(pos, n, np.array(run), np.array(dirn),
                        {"axis": AXES[k], "line_mm": base.tolist()})


def _corners(code: str, t: NDArray[np.float64]):
    if len(code) != 3 or any(c not in "pn" for c in code):
        raise VolcalInputError(f"unknown diagonal {code!r}: expected one of {BODY_DIAGONALS}")
    start = np.where([c == "p" for c in code], t[:, 0], t[:, 1])
    end = np.where([c == "p" for c in code], t[:, 1], t[:, 0])
    return start, end


def _face_corners(plane: str, code: str, t: NDArray[np.float64], at_mm: float | None):
    plane = plane.lower()
    if plane not in FACE_PLANES:
        raise VolcalInputError(f"unknown plane {plane!r}: expected one of {FACE_PLANES}")
    if code not in FACE_DIAGONALS:
        raise VolcalInputError(f"unknown face diagonal {code!r}: expected one of {FACE_DIAGONALS}")
    ax = [AXES.index(c.upper()) for c in plane]
    const = ({0, 1, 2} - set(ax)).pop()
    start = np.empty(3)
    end = np.empty(3)
    signs = {ax[0]: code[0], ax[1]: code[1]}
    for k, s in signs.items():
        start[k], end[k] = (t[k, 0], t[k, 1]) if s == "p" else (t[k, 1], t[k, 0])
    start[const] = end[const] = t[const, 0] if at_mm is None else at_mm
    return start, end, ax


def diagonal_test(code: str, travel: ArrayLike, steps: int, plane: str | None = None,
                  at_mm: float | None = None) -> TestGeometry:
    """Body or face diagonal displacement test (ISO 230-6), retroreflector on the tool.

    Parameters
    ----------
    code : str
        Body diagonal ``'ppp'``, ``'npp'``, ``'pnp'``, ``'ppn'``; with ``plane`` a face
        diagonal ``'pp'`` or ``'np'``.
    travel : array_like, shape (3, 2)
        Travel limits (the diagonal runs between corners of this box) [mm].
    steps : int
        Number of increments.
    plane : str, optional
        ``'xy'``, ``'yz'`` or ``'xz'`` for a face diagonal.
    at_mm : float, optional
        Position of the constant axis of a face diagonal [mm]; default its travel start.

    Returns
    -------
    TestGeometry
    """
    t = _travel(travel)
    if steps < 1:
        raise VolcalInputError("a diagonal test needs at least 1 increment")
    if plane is None:
        start, end = _corners(code, t)
        meta = {"diagonal": code}
    else:
        start, end, _ = _face_corners(plane, code, t, at_mm)
        meta = {"diagonal": code, "plane": plane.lower()}
    s = np.linspace(0.0, 1.0, steps + 1)[:, None]
    pos = start[None, :] + s * (end - start)[None, :]
    n = (end - start) / np.linalg.norm(end - start)
    return TestGeometry(pos, n, np.ones(steps + 1, dtype=int), None, meta)


def step_diagonal_test(code: str, travel: ArrayLike, steps: int, order: str = "xyz",
                       plane: str | None = None, at_mm: float | None = None) -> TestGeometry:
    """Sequential step diagonal ("vector") test: single-axis moves, a reading after each.

    Parameters
    ----------
    code : str
        Diagonal code as in :func:`diagonal_test`.
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    steps : int
        Number of diagonal increments ``N``; the test has ``1 + 3N`` readings (``1 + 2N``
        for a face diagonal).
    order : str
        Axis order of each increment, e.g. ``'xyz'`` or ``'yxz'`` (``'xy'`` for a face).
    plane : str, optional
        Face plane for a face step diagonal.
    at_mm : float, optional
        Position of the constant axis of a face step diagonal [mm].

    Returns
    -------
    TestGeometry
    """
    t = _travel(travel)
    if steps < 1:
        raise VolcalInputError("a step diagonal needs at least 1 increment")
    if plane is None:
        start, end = _corners(code, t)
        moving = [0, 1, 2]
        meta = {"diagonal": code}
    else:
        start, end, moving = _face_corners(plane, code, t, at_mm)
        meta = {"diagonal": code, "plane": plane.lower()}
    o = order.lower()
    axes = [_axis_index(c) for c in o] if all(c in "xyz" for c in o) else None
    if axes is None or sorted(axes) != sorted(moving):
        raise VolcalInputError(f"axis order {order!r} must be a permutation of "
                               f"{''.join(AXES[k].lower() for k in moving)}")
    inc = (end - start) / steps
    rows = [start.copy()]
    p = start.copy()
    for _ in range(steps):
        for k in axes:
            p = p.copy()
            p[k] += inc[k]
            rows.append(p)
    pos = np.array(rows)
    # remove rounding drift: the end of every increment is exactly on the diagonal
    n = (end - start) / np.linalg.norm(end - start)
    meta["axis_order"] = o
    return TestGeometry(pos, n, np.ones(len(rows), dtype=int), None, meta)
