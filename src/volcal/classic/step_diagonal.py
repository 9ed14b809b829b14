r"""Wang's sequential step diagonal ("vector") solution under the small-angle assumption.

Each increment of a step diagonal moves one axis ``k`` from ``q`` to ``q'`` and reads the
change of the distance to a flat mirror along the nominal beam ``n``. If the angular
errors and the mirror misalignment are negligible, the first-order reading model
(:func:`volcal.measure.readings.reading_first_order`) reduces to

.. math::

    dd = n \cdot [F_k(q') - F_k(q)],

where ``F_k`` is the translation of the tool caused by axis ``k`` *including* the
squareness slope: ``F_X = (EXX, EYX, EZX)``, ``F_Y = (EXY - EC0Y*y, EYY, EZY)``,
``F_Z = (EXZ + EB0Z*z, EYZ - EA0Z*z, EZZ)`` (um, with urad * mm * 1e-3). Every grid
cell of axis ``k`` is crossed once by each step diagonal; with the four body diagonals
``ppp, npp, pnp, ppn`` that gives four equations (one per diagonal, Wang's 12 data sets
over the three axes) for the three increments of ``F_k`` in that cell. With ``dd_s`` the
increment of diagonal ``s`` in the cell, ``s_c`` the travel sign of axis ``c`` in that
diagonal and ``n_c = |n_c|`` the direction cosines, ``dd_s = s_k sum_c s_c n_c dF_{k,c}``
and the sign patterns are orthogonal, so (least squares = closed form)::

    dF_{k,c} = sum_s s_k s_c dd_s / (4 n_c),  e.g. for k = X:
    dEXX = (ppp + npp + pnp + ppn) / (4 n_x)
    dEYX = (ppp - npp - pnp + ppn) / (4 n_y)
    dEZX = (ppp - npp + pnp - ppn) / (4 n_z)

The fourth, orthogonal combination ``-ppp + npp + pnp + ppn`` of the oriented
increments ``s_k dd_s`` has no systematic part (a consistency check, cf. Soons eq. 38).
Face step diagonals (``pp`` and ``np`` in one plane) give two equations per axis and cell
for the two in-plane components: four equations, four unknowns per step (Wang section 5).

The cumulated increments are the functions ``F``; the linear trend of each straightness
is then split off: a trend shared by a pair of axes is a rigid rotation of the work zone
(invisible to relative readings, removed with X as the reference direction and the
XY-plane as the reference plane) and the rest is squareness:

.. math::

    EC0Y = -(m_{XY} + m_{YX}),\quad EB0Z = m_{XZ} + m_{ZX},\quad EA0Z = -(m_{YZ} + m_{ZY})

with ``m_{AB}`` the end-point slope of the A-component of ``F_B`` [um/mm = 1000 urad].
The result follows ``docs/conventions.md``: every function zero at the travel start,
straightness also zero at the end.

Assumptions (the method is exact when they hold, see the tests and ``docs/classic.md``):
angular errors zero (they enter through the Abbe offsets and the flat mirror's lateral
offset, Soons eq. 4); mirror and beam aligned (a residual tilt biases the *slope* of the
positioning errors, Soons eq. 19-20); all step diagonals share the same targets.

References
----------
.. [1] Wang, C. and Liotto, G., "A theoretical analysis of 4 body diagonal displacement
   measurement and sequential step diagonal measurement", Proc. Lamdamap 2003, sections
   4-5 (eq. 5-16 and 19-22).
.. [2] Wang, C., "Laser vector measurement technique for the determination and
   compensation of volumetric positioning errors. Part I: Basic theory", Rev. Sci.
   Instrum. 71(10), 2000, 3933-3937.
.. [3] Soons, J.A., "Analysis of the step-diagonal test", Proc. Lamdamap 2005.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES, SQUARENESS_NAMES, component_name
from volcal.session.format import Measurement, Session

__all__ = ["StepDiagonalResult", "Increment", "solve_step_diagonals", "step_increments",
           "step_diagonal_session"]

_POS_TOL_MM = 1e-6
_MILLI = 1e3  # urad per (um/mm)


@dataclass(frozen=True)
class Increment:
    """One single-axis move of a step diagonal and the change of the reading.

    Attributes
    ----------
    axis : int
        Moving axis 0..2.
    start_mm, end_mm : float
        Position of the moving axis before and after the move [mm].
    beam : ndarray, shape (3,)
        Nominal beam direction (unit vector).
    dd_um : float
        Change of the deviation during the move [um].
    source : str
        File of the measurement.
    row : int
        1-based CSV row of the reading after the move (header = row 1).
    """

    axis: int
    start_mm: float
    end_mm: float
    beam: NDArray[np.float64]
    dd_um: float
    source: str
    row: int


@dataclass
class StepDiagonalResult:
    """Result of :func:`solve_step_diagonals`.

    Attributes
    ----------
    errors : MachineErrors
        Positioning, straightness [um] and squareness [urad]; angular errors zero.
    determined : dict of str to bool
        For each of the 9 translation functions (EXX ... EZZ) and the 3 squareness errors:
        whether the data determine it. Undetermined values are set to zero.
    rigid_rotation_urad : ndarray, shape (3,)
        Rotation of the work zone about X, Y, Z removed from the raw functions [urad] (a
        rigid motion no relative reading can fix; non-zero with set-up tilts).
    residual_rms_um : float
        RMS of the residuals of the per-cell systems [um] (zero for 4 consistent
        diagonals; always zero for the exactly determined face version).
    n_increments : int
        Number of single-axis increments used.
    raw : list of ndarray
        Cumulated translation functions ``F_k`` per axis before the split, shape
        (n_k, 3) [um].
    """

    errors: MachineErrors
    determined: dict[str, bool]
    rigid_rotation_urad: NDArray[np.float64]
    residual_rms_um: float
    n_increments: int
    raw: list[NDArray[np.float64]] = field(default_factory=list)


def step_increments(meas: Measurement) -> list[Increment]:
    """Split a step-diagonal measurement into its single-axis increments.

    Parameters
    ----------
    meas : Measurement
        A measurement whose consecutive readings differ in one axis only.

    Returns
    -------
    list of Increment

    Raises
    ------
    VolcalInputError
        If the deviations are missing or two consecutive readings differ in more than
        one axis (naming the file and row).
    """
    if meas.deviation is None:
        raise VolcalInputError("step diagonal has no deviations (measure or simulate first)",
                               meas.file, None, "deviation_um")
    q = meas.positions
    dev = meas.deviation
    run = meas.run
    out = []
    for r in range(1, meas.n):
        if run is not None and run[r] != run[r - 1]:
            continue
        d = q[r] - q[r - 1]
        moving = np.flatnonzero(np.abs(d) > _POS_TOL_MM)
        if moving.size == 0:
            continue
        if moving.size > 1:
            cols = ", ".join(f"{AXES[k].lower()}_mm" for k in moving)
            raise VolcalInputError(
                f"a step diagonal moves one axis at a time, but this reading moves {cols} "
                "together", meas.file, r + 2, f"{AXES[moving[0]].lower()}_mm")
        k = int(moving[0])
        out.append(Increment(k, float(q[r - 1, k]), float(q[r, k]), meas.beam_direction.copy(),
                             float(dev[r] - dev[r - 1]), meas.file, r + 2))
    return out


def _grid(values: list[float]) -> NDArray[np.float64]:
    v = np.sort(np.asarray(values, dtype=float))
    keep = np.concatenate([[True], np.diff(v) > _POS_TOL_MM])
    return v[keep]


def _index(grid: NDArray[np.float64], v: float) -> int:
    i = int(np.argmin(np.abs(grid - v)))
    return i


def _slope(f: NDArray[np.float64], q: NDArray[np.float64]) -> float:
    return float((f[-1] - f[0]) / (q[-1] - q[0])) if q.size > 1 else 0.0


def solve_step_diagonals(measurements: Sequence[Measurement], chain: str,
                         travel: ArrayLike | None = None, name: str = "step diagonal",
                         ) -> StepDiagonalResult:
    """Positioning, straightness and squareness from sequential step diagonals.

    Parameters
    ----------
    measurements : sequence of Measurement
        Step diagonals (body: ``ppp, npp, pnp, ppn``, Wang's 12 data sets; or face step
        diagonals ``pp, np`` per plane) sharing their targets; flat mirror or
        retroreflector on the tool.
    chain : str
        Chain code of the machine (kept in the result; the small-angle solution does not
        depend on it).
    travel : array_like, shape (3, 2), optional
        Travel limits [mm], used for the nodes of an axis no increment moves.
    name : str
        Name of the resulting machine.

    Returns
    -------
    StepDiagonalResult

    Raises
    ------
    VolcalInputError
        If a measurement moves several axes at once, the diagonals do not share their
        targets, or a grid cell is seen by too few diagonals to separate its components.

    Notes
    -----
    Wang's eq. 5-16 carry lever arms ``f, g`` of the angular errors that do not follow
    from the kinematic model; under the method's own assumption (angular errors zero)
    they vanish, and so does every chain dependence. See ``docs/classic.md``.
    """
    incs: list[Increment] = []
    for m in measurements:
        incs.extend(step_increments(m))
    if not incs:
        raise VolcalInputError("no step-diagonal increments found")
    t = None if travel is None else np.asarray(travel, dtype=float).reshape(3, 2)
    nodes: list[NDArray[np.float64]] = []
    raw: list[NDArray[np.float64]] = []
    observed = np.zeros((3, 3), dtype=bool)  # [axis k, component c]
    sq_res = 0.0
    n_res = 0
    for k in range(3):
        ik = [i for i in incs if i.axis == k]
        if not ik:
            if t is None:
                raise VolcalInputError(f"no increment moves {AXES[k]} and no travel given")
            nodes.append(t[k].copy())
            raw.append(np.zeros((2, 3)))
            continue
        grid = _grid([v for i in ik for v in (i.start_mm, i.end_mm)])
        cells: list[list[tuple[NDArray[np.float64], float]]] = [[] for _ in range(grid.size - 1)]
        for inc in ik:
            a, b = _index(grid, inc.start_mm), _index(grid, inc.end_mm)
            if abs(a - b) != 1:
                raise VolcalInputError(
                    f"this {AXES[k]} increment ({inc.start_mm:g} -> {inc.end_mm:g} mm) spans "
                    f"{abs(a - b)} cells of the targets shared by all step diagonals; the "
                    "diagonals must use the same targets", inc.source, inc.row,
                    f"{AXES[k].lower()}_mm")
            sign = 1.0 if b > a else -1.0
            cells[min(a, b)].append((inc.beam, sign * inc.dd_um))
        obs = np.zeros(3, dtype=bool)
        for c in cells:
            for nvec, _ in c:
                obs |= np.abs(nvec) > 1e-12
        observed[k] = obs
        cols = np.flatnonzero(obs)
        dF = np.zeros((grid.size - 1, 3))
        for j, c in enumerate(cells):
            A = np.array([nvec[cols] for nvec, _ in c])
            y = np.array([v for _, v in c])
            if A.shape[0] < cols.size or np.linalg.matrix_rank(A) < cols.size:
                raise VolcalInputError(
                    f"the {AXES[k]} cell {grid[j]:g}..{grid[j + 1]:g} mm is seen by "
                    f"{A.shape[0]} increment(s) that cannot separate the "
                    f"{cols.size} components {', '.join(component_name(k, int(i)) for i in cols)}"
                    "; measure all 4 body step diagonals (or both face step diagonals of "
                    "each plane) over the same targets")
            sol, *_ = np.linalg.lstsq(A, y, rcond=None)
            dF[j, cols] = sol
            r = y - A @ sol
            sq_res += float(r @ r)
            n_res += r.size
        F = np.vstack([np.zeros(3), np.cumsum(dF, axis=0)])
        nodes.append(grid)
        raw.append(F)
    values, sq, rot, det = _split(nodes, raw, observed)
    machine = MachineErrors(chain, nodes, values, sq, name=name)
    return StepDiagonalResult(machine, det, rot, float(np.sqrt(sq_res / max(n_res, 1))),
                              len(incs), raw)


def _split(nodes, raw, observed):
    """Split the raw functions into straightness (zero at both ends) and squareness."""
    s = np.zeros((3, 3))  # s[c, k]: end-point slope of component c of F_k [um/mm]
    for k in range(3):
        for c in range(3):
            if c != k:
                s[c, k] = _slope(raw[k][:, c], nodes[k])
    values = []
    for k in range(3):
        v = np.zeros((nodes[k].size, 6))
        for c in range(3):
            f = raw[k][:, c] - raw[k][0, c]
            if c != k:
                f = f - s[c, k] * (nodes[k] - nodes[k][0])
            v[:, c] = f
        values.append(v)
    rot = np.array([s[2, 1], -s[2, 0], s[1, 0]]) * _MILLI  # about X (gamma), Y, Z (alpha)
    sq = np.array([-(s[0, 1] + s[1, 0]), s[0, 2] + s[2, 0], -(s[1, 2] + s[2, 1])]) * _MILLI
    det: dict[str, bool] = {}
    for k in range(3):
        for c in range(3):
            det[component_name(k, c)] = bool(observed[k, c])
    pairs = [((0, 1), (1, 0)), ((0, 2), (2, 0)), ((1, 2), (2, 1))]
    for nm, ((c1, k1), (c2, k2)) in zip(SQUARENESS_NAMES, pairs, strict=True):
        det[nm] = bool(observed[k1, c1] and observed[k2, c2])
    sq = np.where([det[n] for n in SQUARENESS_NAMES], sq, 0.0)
    return values, sq, rot, det


def step_diagonal_session(session: Session) -> StepDiagonalResult:
    """Run :func:`solve_step_diagonals` on every step-diagonal measurement of a session.

    Parameters
    ----------
    session : Session
        A measured session.

    Returns
    -------
    StepDiagonalResult

    Raises
    ------
    VolcalInputError
        If the session has no step diagonals or they are inconsistent.
    """
    meas = [m for m in session.measurements if m.kind == "step_diagonal"]
    if not meas:
        raise VolcalInputError("the session has no step-diagonal measurements",
                               session.path / "session.toml" if session.path else None)
    return solve_step_diagonals(meas, session.chain, session.travel,
                                name=f"{session.name} (classic step diagonal)")
