"""Validate and group bidirectional positioning runs (targets x runs x directions).

Shared by the ISO 230-2 and VDI/DGQ 3441 evaluations: the readings of a linear
positioning test are checked (finite values, directions ``+``/``-``, no duplicate
(target, run, direction), at least two runs each way) and arranged as two arrays
``up[i, j]`` and ``down[i, j]`` (target i, run j). A run that did not reach a target
(a missed capture) leaves NaN in its cell: refused by default, listed in
:attr:`GroupedRuns.missing` with ``allow_incomplete=True``; :func:`target_statistics`
then evaluates each target over the runs that reached it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError

__all__ = ["MIN_RUNS", "GroupedRuns", "MissingReading", "group_runs", "target_statistics"]

#: Targets closer than this are the same target [mm].
TARGET_TOLERANCE_MM = 1e-4

#: Fewest runs in each direction a positioning evaluation accepts (a standard deviation
#: needs two; ISO 230-2 asks for five).
MIN_RUNS = 2


@dataclass(frozen=True)
class MissingReading:
    """A (target, run, direction) cell of a positioning test without a reading.

    Attributes
    ----------
    run : int
        Run number.
    target_mm : float
        Target position [mm].
    direction : str
        ``'+'`` or ``'-'``.
    """

    run: int
    target_mm: float
    direction: str

    def to_dict(self) -> dict[str, object]:
        """JSON-friendly dict (``run``, ``target_mm``, ``direction``)."""
        return {"run": self.run, "target_mm": self.target_mm, "direction": self.direction}

    def __str__(self) -> str:
        """``run 2 has no reading at target 570.944 mm in direction '+'``."""
        return (f"run {self.run} has no reading at target {self.target_mm:g} mm in "
                f"direction '{self.direction}'")


@dataclass
class GroupedRuns:
    """Deviations arranged by target and run.

    Attributes
    ----------
    targets : ndarray, shape (m,)
        Target positions, ascending [mm].
    up : ndarray, shape (m, n_up)
        Deviations approached in the positive direction, one column per run [um].
    down : ndarray, shape (m, n_down)
        Deviations approached in the negative direction [um].
    runs_up, runs_down : ndarray of int
        Run numbers of the columns.
    missing : list of MissingReading
        Cells without a reading (NaN in ``up``/``down``); empty for a complete test.
    """

    targets: NDArray[np.float64]
    up: NDArray[np.float64]
    down: NDArray[np.float64]
    runs_up: NDArray[np.int64]
    runs_down: NDArray[np.int64]
    missing: list[MissingReading] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when every run reached every target in both directions."""
        return not self.missing


def _row(rows: NDArray[np.int64] | None, i: int) -> int | None:
    return None if rows is None else int(rows[i])


def group_runs(targets_mm: ArrayLike, run: ArrayLike, direction: ArrayLike,
               deviation_um: ArrayLike, file: str | None = None,
               rows: ArrayLike | None = None, min_runs: int = MIN_RUNS, *,
               allow_incomplete: bool = False, target_column: str = "target_mm"
               ) -> GroupedRuns:
    """Check and arrange bidirectional positioning readings.

    Parameters
    ----------
    targets_mm : array_like, shape (n,)
        Target position of each reading [mm].
    run : array_like of int, shape (n,)
        Run number of each reading.
    direction : array_like of str, shape (n,)
        ``'+'`` (approach in the positive direction, ISO 230-2 "up") or ``'-'``.
    deviation_um : array_like, shape (n,)
        Actual minus target position [um].
    file : str, optional
        File named in error messages.
    rows : array_like of int, optional
        Row number (in ``file``) of each reading, for error messages.
    min_runs : int
        Fewest runs accepted in each direction (:data:`MIN_RUNS`).
    allow_incomplete : bool
        Accept runs that miss targets (missed captures): their cells are NaN and listed
        in :attr:`GroupedRuns.missing`. False (default): refused, naming the first.
    target_column : str
        Name of the target column in ``file`` for error messages (``'x_mm'`` in a
        session measurement CSV of an X line).

    Returns
    -------
    GroupedRuns

    Raises
    ------
    VolcalInputError
        Naming file, row and column of the first problem.
    """
    t, ri, s, d, rw = _checked(targets_mm, run, direction, deviation_um, file, rows,
                               target_column)
    tid, targets = _cluster(t)
    if targets.size < 2:
        raise VolcalInputError("a positioning test needs at least two target positions", file,
                               None, target_column)
    out = {sign: _grid(sign, tid, targets, ri, s, d, rw, file, min_runs, allow_incomplete,
                       target_column) for sign in "+-"}
    return GroupedRuns(targets, out["+"][0], out["-"][0], out["+"][1], out["-"][1],
                       out["+"][2] + out["-"][2])


def target_statistics(grid: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Mean, sample standard deviation and number of runs of each target (row).

    Missed cells (NaN) are left out: target i is evaluated over the ``n_i`` runs that
    reached it, ``s_i = sqrt(sum_j (x_ij - xbar_i)^2 / (n_i - 1))`` (ISO 230-2:2014,
    3.3.8 with ``n`` the number of runs at that target).

    Parameters
    ----------
    grid : ndarray, shape (m, n)
        Deviations, target x run, NaN where a run has no reading [um].

    Returns
    -------
    mean : ndarray, shape (m,)
        Mean deviation [um]; NaN where no run reached the target.
    s : ndarray, shape (m,)
        Sample standard deviation [um]; NaN where fewer than 2 runs reached it.
    n : ndarray of int, shape (m,)
        Runs that reached each target.
    """
    ok = np.isfinite(grid)
    n = ok.sum(axis=1)
    x = np.where(ok, grid, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 0, x.sum(axis=1) / np.maximum(n, 1), np.nan)
        r2 = np.where(ok, (grid - mean[:, None]) ** 2, 0.0).sum(axis=1)
        s = np.where(n >= 2, np.sqrt(r2 / np.maximum(n - 1, 1)), np.nan)
    return mean, s, n


def _checked(targets_mm: ArrayLike, run: ArrayLike, direction: ArrayLike,
             deviation_um: ArrayLike, file: str | None, rows: ArrayLike | None,
             target_column: str = "target_mm"):
    """The inputs as arrays (targets, whole runs, directions, deviations, rows), checked."""
    t = np.asarray(targets_mm, dtype=float).reshape(-1)
    d = np.asarray(deviation_um, dtype=float).reshape(-1)
    r = np.asarray(run).reshape(-1)
    s = np.asarray(direction).astype(str).reshape(-1)
    rw = None if rows is None else np.asarray(rows, dtype=int).reshape(-1)
    n = t.size
    for name, a in (("run", r), ("direction", s), ("deviation_um", d)):
        if a.size != n:
            raise VolcalInputError(f"{name} has {a.size} values for {n} targets", file, None,
                                   name)
    if n == 0:
        raise VolcalInputError("no readings", file)
    for name, a in ((target_column, t), ("deviation_um", d)):
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise VolcalInputError(f"not a finite number: {float(a[bad[0]])}", file,
                                   _row(rw, bad[0]), name)
    for i, v in enumerate(s):
        if v not in ("+", "-"):
            raise VolcalInputError(f"direction must be '+' or '-', got {v!r}", file,
                                   _row(rw, i), "direction")
    try:
        ri = r.astype(float)
        if not np.all(np.isfinite(ri)) or np.any(ri != np.round(ri)):
            raise ValueError
        ri = ri.astype(int)
    except (ValueError, TypeError):
        raise VolcalInputError("run numbers must be whole numbers", file, None, "run") from None
    return t, ri, s, d, rw


def _cluster(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Target index of each reading, and the targets [mm].

    A reading within the tolerance of the previous target (in sorted order) shares it.
    """
    order = np.argsort(t, kind="stable")
    tid = np.empty(t.size, dtype=int)
    centres: list[float] = []
    for k in order:
        if not (centres and abs(t[k] - centres[-1]) <= TARGET_TOLERANCE_MM):
            centres.append(float(t[k]))
        tid[k] = len(centres) - 1
    return tid, np.array(centres)


def _grid(sign: str, tid: np.ndarray, targets: np.ndarray, ri: np.ndarray, s: np.ndarray,
          d: np.ndarray, rw: np.ndarray | None, file: str | None, min_runs: int,
          allow_incomplete: bool = False, target_column: str = "target_mm"
          ) -> tuple[np.ndarray, np.ndarray, list[MissingReading]]:
    """Deviations of one direction as (targets x runs), the run numbers, the missed cells."""
    sel = np.flatnonzero(s == sign)
    if sel.size == 0:
        raise VolcalInputError(f"no readings in direction '{sign}': ISO 230-2 needs "
                               "bidirectional runs", file, None, "direction")
    runs = np.unique(ri[sel])
    if runs.size < min_runs:
        raise VolcalInputError(
            f"only {runs.size} run(s) in direction '{sign}': at least {min_runs} needed "
            "to estimate repeatability (ISO 230-2 asks for 5)", file, None, "run")
    col = {v: j for j, v in enumerate(runs)}
    grid = np.full((targets.size, runs.size), np.nan)
    seen = np.full((targets.size, runs.size), -1)
    for k in sel:
        i, j = tid[k], col[ri[k]]
        if seen[i, j] >= 0:
            raise VolcalInputError(
                f"duplicate reading: target {targets[i]:g} mm, run {ri[k]}, direction "
                f"'{sign}' already given" + ("" if rw is None else f" in row {rw[seen[i, j]]}"),
                file, _row(rw, int(k)), target_column)
        seen[i, j] = k
        grid[i, j] = d[k]
    miss = [MissingReading(int(runs[j]), float(targets[i]), sign)
            for i, j in np.argwhere(seen < 0)]
    if miss and not allow_incomplete:
        raise VolcalInputError(
            f"missing reading: {miss[0]} (every run must visit every target; "
            "allow_incomplete=True evaluates each target over the runs that reached it)",
            file, None, target_column)
    return grid, runs, miss
