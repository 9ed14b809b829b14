"""ISO 230-2: accuracy and repeatability of positioning of numerically controlled axes.

Definitions (ISO 230-2:2014 clause 3; identical in the 1997 and 2006 editions), for
target i, run j, approach direction up (+) or down (-), deviation ``x_ij`` = actual
minus target position:

==============================  ===================================================
mean unidirectional deviation   ``xbar_i_up = mean_j x_ij_up`` (same for down)
reversal value                  ``B_i = xbar_i_up - xbar_i_down``
reversal value of the axis      ``B = max_i |B_i|``
mean reversal value             ``B_mean = mean_i B_i`` (signed)
mean bidirectional deviation    ``xbar_i = (xbar_i_up + xbar_i_down) / 2``
standard uncertainty (est.)     ``s_i_up = sqrt(sum_j (x_ij_up - xbar_i_up)^2 / (n-1))``
unidirectional repeatability    ``R_i_up = 4 s_i_up``;  ``R_up = max_i R_i_up``
bidirectional repeatability     ``R_i = max(2 s_i_up + 2 s_i_down + |B_i|, R_i_up,
                                R_i_down)``;  ``R = max_i R_i``
unidirectional systematic error ``E_up = max_i xbar_i_up - min_i xbar_i_up``
bidirectional systematic error  ``E = max(xbar_i_up, xbar_i_down) - min(xbar_i_up,
                                xbar_i_down)`` over all i and both directions
range of mean bidir. deviation  ``M = max_i xbar_i - min_i xbar_i``
unidirectional accuracy         ``A_up = max_i(xbar_i_up + 2 s_i_up)
                                - min_i(xbar_i_up - 2 s_i_up)``
bidirectional accuracy          ``A = max(xbar_i_up + 2 s_i_up, xbar_i_down + 2 s_i_down)
                                - min(xbar_i_up - 2 s_i_up, xbar_i_down - 2 s_i_down)``
==============================  ===================================================

Edition differences: ISO 230-2:1988 used a coverage of 3 s (accuracy envelopes
``xbar +- 3 s``, repeatability ``6 s``) where 1997, 2006 and 2014 use 2 s and 4 s; the
2006 and 2014 editions add the estimation of the measurement uncertainty (ISO/TR 230-9),
which does not change these parameters. ``edition='1988'`` applies the 3 s coverage to
the same formulas; the 1988 edition itself did not define E and M, which are then
reported with the later definitions.

Incomplete runs (missed captures): with ``allow_incomplete=True`` a run that did not
reach a target is left out of that target only; each target is evaluated over the ``n_i``
runs that reached it (``xbar_i`` over ``n_i`` readings, ``s_i`` with ``n_i - 1`` in the
denominator). A target reached by fewer than two runs in a direction has no ``s_i`` and is
left out of the parameters that need it (R, A) but kept in those that do not (E, M, B).
The result is marked incomplete (:attr:`Iso2302Result.complete`) and its notes name every
missed run, target and direction.

Test cycle (ISO 230-2:2014 clause 5): at least five target positions per metre of travel
and at least five overall, chosen with unequal spacing so that periodic errors (lead
screw pitch, scale period) are not sampled at one phase only; five runs in each
direction; axes longer than 2000 mm are tested by another procedure. The evaluation
returns these checks as warnings; it still computes the figures.

References
----------
.. [1] ISO 230-2:2014, Test code for machine tools - Part 2: Determination of accuracy and
   repeatability of positioning of numerically controlled axes.
.. [2] ISO 230-2:1997 (same definitions, 2 s coverage) and ISO 230-2:1988 (3 s coverage).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.standards.runs import GroupedRuns, MissingReading, group_runs, target_statistics

if TYPE_CHECKING:
    import pandas

__all__ = ["EDITIONS", "Iso2302Result", "TargetStatistics", "check_test_cycle", "evaluate",
           "evaluate_grouped", "incomplete_notes"]

EDITIONS: dict[str, float] = {"1988": 3.0, "1997": 2.0, "2006": 2.0, "2014": 2.0}
AXIS_KEYS: tuple[str, ...] = ("A", "A_up", "A_down", "E", "E_up", "E_down", "M", "R", "R_up",
                              "R_down", "B", "B_mean")


@dataclass
class TargetStatistics:
    """Per-target statistics of ISO 230-2 (all in um except ``target_mm``).

    Attributes
    ----------
    target_mm : ndarray, shape (m,)
        Target positions [mm].
    mean_up, mean_down : ndarray, shape (m,)
        Mean unidirectional positional deviations [um].
    mean : ndarray, shape (m,)
        Mean bidirectional positional deviation [um].
    s_up, s_down : ndarray, shape (m,)
        Estimators of the unidirectional standard uncertainty of positioning [um].
    B : ndarray, shape (m,)
        Reversal value ``mean_up - mean_down`` [um].
    R_up, R_down, R : ndarray, shape (m,)
        Unidirectional and bidirectional repeatability of positioning [um].
    n_up, n_down : int
        Number of runs in each direction.
    n_up_target, n_down_target : ndarray of int, shape (m,), optional
        Runs that reached each target in each direction (fewer than ``n_up``/``n_down``
        where a capture was missed); None means every run reached every target.
    """

    target_mm: NDArray[np.float64]
    mean_up: NDArray[np.float64]
    mean_down: NDArray[np.float64]
    mean: NDArray[np.float64]
    s_up: NDArray[np.float64]
    s_down: NDArray[np.float64]
    B: NDArray[np.float64]
    R_up: NDArray[np.float64]
    R_down: NDArray[np.float64]
    R: NDArray[np.float64]
    n_up: int
    n_down: int
    n_up_target: NDArray[np.int64] | None = None
    n_down_target: NDArray[np.int64] | None = None

    def counts(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Runs that reached each target, up and down (arrays of shape (m,))."""
        m = self.target_mm.size
        up = (np.full(m, self.n_up) if self.n_up_target is None
              else np.asarray(self.n_up_target))
        down = (np.full(m, self.n_down) if self.n_down_target is None
                else np.asarray(self.n_down_target))
        return up.astype(int), down.astype(int)

    def rows(self) -> list[dict[str, Any]]:
        """Return the table as a list of dicts, one per target (JSON friendly).

        Each row holds the statistics [um] (None where a target has too few runs), the
        target [mm], ``n_up`` and ``n_down`` (runs that reached the target in each
        direction) and ``n`` (the smaller of the two).
        """
        keys = ("target_mm", "mean_up", "mean_down", "mean", "s_up", "s_down", "B", "R_up",
                "R_down", "R")
        nu, nd = self.counts()
        out = []
        for i in range(self.target_mm.size):
            row: dict[str, Any] = {k: _num(getattr(self, k)[i]) for k in keys}
            row.update(n_up=int(nu[i]), n_down=int(nd[i]), n=int(min(nu[i], nd[i])))
            out.append(row)
        return out


def _num(v: float) -> float | None:
    """A float, or None for NaN (JSON has no NaN)."""
    v = float(v)
    return v if np.isfinite(v) else None


@dataclass
class Iso2302Result:
    """ISO 230-2 evaluation of one axis; all parameters in um.

    Attributes
    ----------
    A, A_up, A_down : float
        Bidirectional and unidirectional accuracy of positioning [um].
    E, E_up, E_down : float
        Bidirectional and unidirectional systematic positioning error [um].
    M : float
        Range of the mean bidirectional positional deviation [um].
    R, R_up, R_down : float
        Bidirectional and unidirectional repeatability of positioning [um].
    B : float
        Reversal value of the axis, ``max |B_i|`` [um].
    B_mean : float
        Mean reversal value (signed) [um].
    targets : TargetStatistics
        Per-target table.
    edition : str
        Edition of ISO 230-2 whose definitions were applied.
    warnings : list of str
        Test-cycle deviations from the standard (too few runs, targets, spacing...).
    missing : list of MissingReading
        Missed (target, run, direction) cells; empty for a complete test.
    notes : list of str
        What the incompleteness does: each missed run and target, and the targets left
        out of R and A for want of two runs.
    """

    A: float
    A_up: float
    A_down: float
    E: float
    E_up: float
    E_down: float
    M: float
    R: float
    R_up: float
    R_down: float
    B: float
    B_mean: float
    targets: TargetStatistics
    edition: str = "2014"
    warnings: list[str] = field(default_factory=list)
    missing: list[MissingReading] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when every run reached every target in both directions."""
        return not self.missing

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-friendly dict of the parameters [um] and the per-target table.

        Also the edition, warnings, ``complete``, ``missing`` readings and ``notes``; each
        row of ``targets`` holds its ``n`` (runs that reached the target).
        """
        d: dict[str, Any] = {k: float(getattr(self, k)) for k in AXIS_KEYS}
        d["targets"] = self.targets.rows()
        d["n_runs_up"] = self.targets.n_up
        d["n_runs_down"] = self.targets.n_down
        d["edition"] = self.edition
        d["warnings"] = list(self.warnings)
        d["complete"] = self.complete
        d["missing"] = [m.to_dict() for m in self.missing]
        d["notes"] = list(self.notes)
        return d

    def to_rows(self) -> list[dict[str, Any]]:
        """The per-target table, one row per target, units in the column names.

        Returns
        -------
        list of dict
            ``target_mm`` [mm], ``mean_up_um`` ... ``R_um`` [um]
            (:func:`volcal.io.frames.iso230_2_rows`).
        """
        from volcal.io.frames import iso230_2_rows

        return iso230_2_rows(self)

    def to_dataframe(self) -> pandas.DataFrame:
        """:meth:`to_rows` as a pandas DataFrame (needs pandas).

        Returns
        -------
        pandas.DataFrame
        """
        from volcal.io.frames import to_dataframe

        return to_dataframe(self.to_rows(), "Iso2302Result")


def check_test_cycle(targets_mm: NDArray[np.float64], n_up: int, n_down: int) -> list[str]:
    """Warnings where a test cycle departs from ISO 230-2:2014 clause 5.

    Parameters
    ----------
    targets_mm : ndarray, shape (m,)
        Target positions, ascending [mm].
    n_up, n_down : int
        Runs in each direction.

    Returns
    -------
    list of str
        Human-readable warnings (empty if the cycle conforms).
    """
    w: list[str] = []
    if min(n_up, n_down) < 5:
        w.append(f"only {n_up} run(s) up and {n_down} down: ISO 230-2 asks for 5 runs in "
                 "each direction")
    length = float(targets_mm[-1] - targets_mm[0])
    m = targets_mm.size
    need = max(5, int(np.ceil(5.0 * length / 1000.0)))
    if m < need:
        w.append(f"{m} target positions over {length:g} mm: ISO 230-2 asks for at least "
                 f"{need} (five per metre, five at least)")
    if length > 2000.0:
        w.append(f"measured length {length:g} mm exceeds 2000 mm: ISO 230-2 prescribes a "
                 "different test for long axes")
    if m >= 3:
        steps = np.diff(targets_mm)
        if np.ptp(steps) <= 1e-6 * max(1.0, float(np.mean(steps))):
            w.append("targets are equally spaced: ISO 230-2 recommends unequal spacing so "
                     "that periodic errors are sampled at different phases")
    return w


def evaluate_grouped(g: GroupedRuns, edition: str = "2014", file: str | None = None
                     ) -> Iso2302Result:
    """ISO 230-2 parameters from runs already grouped by :func:`group_runs`.

    Parameters
    ----------
    g : GroupedRuns
        Deviations by target and run [um].
    edition : str
        ``'2014'`` (default), ``'2006'``, ``'1997'`` or ``'1988'``.
    file : str, optional
        Source file named in error messages.

    Returns
    -------
    Iso2302Result
    """
    edition = str(edition)
    if edition not in EDITIONS:
        raise VolcalInputError(f"unknown ISO 230-2 edition {edition!r}: expected one of "
                               f"{', '.join(EDITIONS)}", column="edition")
    k = EDITIONS[edition]
    mu, su, nu = target_statistics(g.up)
    md, sd, nd = target_statistics(g.down)
    for sign, n in (("+", nu), ("-", nd)):
        if not np.any(n >= 2):
            raise VolcalInputError(f"no target reached by two runs in direction '{sign}': "
                                   "no repeatability can be estimated", file, None, "run")
    b = mu - md
    if not np.any(np.isfinite(b)):
        raise VolcalInputError("no target reached in both directions: no reversal value",
                               file, None, "direction")
    ru, rd = 2 * k * su, 2 * k * sd
    r = np.maximum.reduce([k * su + k * sd + np.abs(b), ru, rd])  # NaN: too few runs
    mean = (mu + md) / 2
    both = np.concatenate([mu, md])
    complete = g.complete
    table = TargetStatistics(g.targets, mu, md, mean, su, sd, b, ru, rd, r,
                             g.up.shape[1], g.down.shape[1],
                             None if complete else nu, None if complete else nd)
    hi_u, lo_u = np.nanmax(mu + k * su), np.nanmin(mu - k * su)
    hi_d, lo_d = np.nanmax(md + k * sd), np.nanmin(md - k * sd)
    return Iso2302Result(
        A=float(max(hi_u, hi_d) - min(lo_u, lo_d)), A_up=float(hi_u - lo_u),
        A_down=float(hi_d - lo_d),
        E=_ptp(both), E_up=_ptp(mu), E_down=_ptp(md), M=_ptp(mean),
        R=float(np.nanmax(r)), R_up=float(np.nanmax(ru)), R_down=float(np.nanmax(rd)),
        B=float(np.nanmax(np.abs(b))), B_mean=float(np.nanmean(b)),
        targets=table, edition=edition,
        warnings=check_test_cycle(g.targets, g.up.shape[1], g.down.shape[1]),
        missing=list(g.missing), notes=incomplete_notes(g, nu, nd))


def _ptp(a: NDArray[np.float64]) -> float:
    """Range of the finite values."""
    return float(np.nanmax(a) - np.nanmin(a))


def incomplete_notes(g: GroupedRuns, n_up: NDArray[np.int64], n_down: NDArray[np.int64]
                     ) -> list[str]:
    """Plain-word notes on an incomplete test: each missed reading and what it changes.

    Parameters
    ----------
    g : GroupedRuns
        The grouped runs (``missing`` lists the missed cells).
    n_up, n_down : ndarray of int, shape (m,)
        Runs that reached each target in each direction.

    Returns
    -------
    list of str
        Empty for a complete test.
    """
    if g.complete:
        return []
    out = []
    for miss in g.missing:
        i = int(np.argmin(np.abs(g.targets - miss.target_mm)))
        n = (n_up if miss.direction == "+" else n_down)[i]
        total = g.up.shape[1] if miss.direction == "+" else g.down.shape[1]
        out.append(f"incomplete: {miss} (missed capture); that target is evaluated over the "
                   f"{n} of {total} runs that reached it")
    for sign, counts in (("+", n_up), ("-", n_down)):
        for j in np.flatnonzero(counts < 2):
            out.append(f"target {g.targets[j]:g} mm reached by {counts[j]} run(s) in direction "
                       f"'{sign}': no standard deviation there, left out of R and A")
    return out


def evaluate(targets_mm: ArrayLike, run: ArrayLike, direction: ArrayLike,
             deviation_um: ArrayLike, edition: str = "2014", *, file: str | None = None,
             rows: ArrayLike | None = None, allow_incomplete: bool = False,
             target_column: str = "target_mm") -> Iso2302Result:
    """Evaluate a bidirectional positioning test of one axis to ISO 230-2.

    Parameters
    ----------
    targets_mm : array_like, shape (n,)
        Target position of each reading [mm].
    run : array_like of int, shape (n,)
        Run number of each reading.
    direction : array_like of str, shape (n,)
        ``'+'`` for readings approached in the positive direction (up), ``'-'`` (down).
    deviation_um : array_like, shape (n,)
        Positional deviation, actual minus target position [um].
    edition : str
        Edition of ISO 230-2: ``'2014'`` (default), ``'2006'``, ``'1997'``, ``'1988'``.
    file : str, optional
        Source file named in error messages.
    rows : array_like of int, optional
        Row of each reading in ``file``.
    allow_incomplete : bool
        Evaluate runs that missed targets (missed captures) per target over the runs that
        reached it, marking the result incomplete; False (default): refuse them.
    target_column : str
        Name of the target column in ``file``, for error messages.

    Returns
    -------
    Iso2302Result
        Axis parameters A, A_up, A_down, E, E_up, E_down, M, R, R_up, R_down, B, B_mean
        [um], the per-target table and test-cycle warnings.

    Raises
    ------
    VolcalInputError
        Missing direction, fewer than two runs a direction, NaN, duplicate readings,
        incomplete runs (unless ``allow_incomplete``).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.repeat([0.0, 100.0], 4)
    >>> res = evaluate(t, [1, 1, 2, 2] * 2, ["+", "-"] * 4, [0, 1, 0, 1, 2, 3, 2, 3])
    >>> res.B, res.E
    (1.0, 3.0)
    """
    g = group_runs(targets_mm, run, direction, deviation_um, file=file, rows=rows,
                   allow_incomplete=allow_incomplete, target_column=target_column)
    return evaluate_grouped(g, edition, file)

