"""Linear-measurement files and sessions prepared for :func:`volcal.classic.abbe.abbe_lines`.

Averages runs and approach directions per target (ISO 230-2 style mean positional
deviation), checks that all lines share their targets, and computes each line's Abbe lever
arm from the chain: the tool offset plus the positions of the axes after the measured one
(``docs/classic.md``, section 1).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.classic.abbe import abbe_lines, other_axes, rotation_names
from volcal.errors import VolcalInputError
from volcal.model.chain import parse_chain
from volcal.model.names import AXES
from volcal.session.format import Measurement, Session, read_measurement_csv

__all__ = ["AbbeAxisResult", "abbe_session", "average_line", "lever_offsets",
           "lines_from_files"]

_TOL_MM = 1e-6


@dataclass
class AbbeAxisResult:
    """Abbe-line solution of one axis of a session.

    Attributes
    ----------
    axis : int
        Measured axis.
    targets_mm : ndarray, shape (n,)
        Target positions [mm].
    positioning_um : ndarray, shape (n,) or None
        Positioning error on the reference line [um]; None if not determined.
    rotations_urad : ndarray, shape (n, 2) or None
        Rotations about the two other axes, alphabetical order [urad].
    offsets_mm : ndarray, shape (k, 2)
        Lever-arm offsets of the lines from the reference (first) line [mm].
    ids : list of str
        Measurement ids, reference first.
    message : str
        Why the solution is missing, or an empty string.
    """

    axis: int
    targets_mm: NDArray[np.float64]
    positioning_um: NDArray[np.float64] | None
    rotations_urad: NDArray[np.float64] | None
    offsets_mm: NDArray[np.float64]
    ids: list[str]
    message: str = ""

    def to_csv(self) -> str:
        """CSV text: ``<axis>_mm, E<KK>_um`` and the two rotations ``[urad]``."""
        if self.positioning_um is None or self.rotations_urad is None:
            raise ValueError("no solution to write")
        return abbe_csv(self.axis, self.targets_mm, self.positioning_um, self.rotations_urad)


def abbe_csv(axis: int, targets: NDArray[np.float64], positioning: NDArray[np.float64],
             rotations: NDArray[np.float64]) -> str:
    """Format an Abbe-line solution as CSV text.

    Parameters
    ----------
    axis : int
        Measured axis.
    targets : ndarray, shape (n,)
        Targets [mm].
    positioning : ndarray, shape (n,)
        Positioning [um].
    rotations : ndarray, shape (n, 2)
        Rotations [urad].

    Returns
    -------
    str
        Header ``x_mm,EXX_um,EBX_urad,ECX_urad`` (for X) and one row per target.
    """
    a = AXES[axis]
    r1, r2 = rotation_names(axis)
    lines = [f"{a.lower()}_mm,E{a}{a}_um,{r1}_urad,{r2}_urad"]
    for q, p, (u, v) in zip(targets, positioning, rotations, strict=True):
        lines.append(f"{q:.6g},{p:.6f},{u:.6f},{v:.6f}")
    return "\n".join(lines) + "\n"


def average_line(positions: NDArray[np.float64], deviation: NDArray[np.float64], axis: int,
                 file: str | Path = "") -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                  NDArray[np.float64]]:
    """Mean deviation per target of a linear measurement (all runs and directions).

    Parameters
    ----------
    positions : ndarray, shape (m, 3)
        Commanded positions [mm].
    deviation : ndarray, shape (m,)
        Deviations [um].
    axis : int
        Measured axis.
    file : str or Path
        File name for error messages.

    Returns
    -------
    targets : ndarray, shape (n,)
        Sorted distinct targets [mm].
    mean : ndarray, shape (n,)
        Mean deviation at each target [um].
    point : ndarray, shape (3,)
        A point of the line [mm] (its coordinates in the two other axes).

    Raises
    ------
    VolcalInputError
        If the line moves another axis (names the file, row and column).
    """
    for j in other_axes(axis):
        bad = np.flatnonzero(np.abs(positions[:, j] - positions[0, j]) > _TOL_MM)
        if bad.size:
            raise VolcalInputError(
                f"a linear measurement of {AXES[axis]} must keep {AXES[j]} constant "
                f"({positions[0, j]:g} mm in the first row)", file, int(bad[0]) + 2,
                f"{AXES[j].lower()}_mm")
    q = positions[:, axis]
    order = np.argsort(q, kind="stable")
    qs = q[order]
    start = np.concatenate([[True], np.diff(qs) > _TOL_MM])
    group = np.cumsum(start) - 1
    n = int(group[-1]) + 1
    mean = np.bincount(group, weights=deviation[order], minlength=n) / np.bincount(group)
    return qs[start], mean, positions[0].copy()


def lines_from_files(paths: Sequence[str | Path], axis: int | str
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Read ``k`` linear measurement CSVs of one axis and average them per target.

    Parameters
    ----------
    paths : sequence of path
        Session measurement CSV files (``x_mm,y_mm,z_mm,deviation_um``...).
    axis : int or str
        Measured axis.

    Returns
    -------
    targets : ndarray, shape (n,)
        Targets [mm], shared by all files.
    deviations : ndarray, shape (k, n)
        Mean deviation per file and target [um].
    points : ndarray, shape (k, 3)
        A point of each line [mm].

    Raises
    ------
    VolcalInputError
        If a file is invalid or its targets differ from the first file's.
    """
    k = AXES.index(axis.upper()) if isinstance(axis, str) else int(axis)
    targets = None
    devs, points = [], []
    for p in paths:
        pos, dev, _ = read_measurement_csv(p)
        t, mean, point = average_line(pos, dev, k, p)
        if targets is None:
            targets = t
        elif t.shape != targets.shape or np.abs(t - targets).max() > _TOL_MM:
            raise VolcalInputError(
                f"targets differ from those of {Path(paths[0]).name}: every line needs the "
                f"same start, end and number of points ({targets.size} targets "
                f"{targets[0]:g}..{targets[-1]:g} mm)", p, None, f"{AXES[k].lower()}_mm")
        devs.append(mean)
        points.append(point)
    assert targets is not None
    return targets, np.array(devs), np.array(points)


def lever_offsets(points_mm: ArrayLike, tool_offsets_mm: ArrayLike, chain: str,
                  axis: int) -> NDArray[np.float64]:
    """Lever-arm offsets of lines of one axis relative to the first line.

    Parameters
    ----------
    points_mm : array_like, shape (k, 3)
        A point of each line [mm].
    tool_offsets_mm : array_like, shape (k, 3) or (3,)
        Tool offset of each line [mm].
    chain : str
        Chain code.
    axis : int
        Measured axis.

    Returns
    -------
    ndarray, shape (k, 2)
        Lever arm minus the first line's, along the two other axes (alphabetical) [mm].
    """
    pts = np.asarray(points_mm, dtype=float).reshape(-1, 3)
    t = np.broadcast_to(np.asarray(tool_offsets_mm, dtype=float).reshape(-1, 3), pts.shape)
    L = t.copy()
    for j in parse_chain(chain).downstream(axis):
        L[:, j] += pts[:, j]
    a, b = other_axes(axis)
    return L[:, [a, b]] - L[0, [a, b]]


def _chain_hint(chain: str, axis: int) -> str:
    up = [AXES[j] for j in parse_chain(chain).order if j != axis
          and j not in parse_chain(chain).downstream(axis)]
    if not up:
        return ""
    return (f" In chain {chain}, moving {' or '.join(up)} does not change the Abbe offset of "
            f"{AXES[axis]} (those axes come before it from workpiece to tool); vary the tool "
            "offset or the downstream axes instead.")


def abbe_session(session: Session) -> list[AbbeAxisResult]:
    """Solve :func:`abbe_lines` for every axis with 3 or more linear measurements.

    Parameters
    ----------
    session : Session
        A measured session.

    Returns
    -------
    list of AbbeAxisResult
        One per axis with linear measurements; ``message`` explains a missing solution.
    """
    out = []
    for k in range(3):
        meas: list[Measurement] = [m for m in session.measurements
                                   if m.kind == "linear" and m.axis == k]
        if not meas:
            continue
        targets = None
        devs, pts, tools, ids = [], [], [], []
        for m in meas:
            if m.deviation is None:
                raise VolcalInputError("linear measurement has no deviations", m.file, None,
                                       "deviation_um")
            t, mean, point = average_line(m.positions, m.deviation, k, m.file)
            if targets is None:
                targets = t
            elif t.shape != targets.shape or np.abs(t - targets).max() > _TOL_MM:
                raise VolcalInputError(f"targets differ from those of {meas[0].file}", m.file,
                                       None, f"{AXES[k].lower()}_mm")
            devs.append(mean)
            pts.append(point)
            tools.append(m.tool_offset)
            ids.append(m.id)
        assert targets is not None
        off = lever_offsets(pts, tools, session.chain, k)
        try:
            if len(meas) < 3:
                raise ValueError(f"only {len(meas)} line(s) of {AXES[k]}; at least 3 at "
                                 "different Abbe offsets are needed")
            pos, rot = abbe_lines(np.array(devs), off, k)
            out.append(AbbeAxisResult(k, targets, pos, rot, off, ids))
        except ValueError as exc:
            out.append(AbbeAxisResult(k, targets, None, None, off, ids,
                                      str(exc) + '.' + _chain_hint(session.chain, k)))
    return out
