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
from volcal.standards.runs import GroupedRuns, group_runs

if TYPE_CHECKING:
    import pandas

__all__ = ["EDITIONS", "Iso2302Result", "TargetStatistics", "check_test_cycle", "evaluate",
           "evaluate_grouped"]

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

    def rows(self) -> list[dict[str, float]]:
        """Return the table as a list of dicts, one per target (JSON friendly)."""
        keys = ("target_mm", "mean_up", "mean_down", "mean", "s_up", "s_down", "B", "R_up",
                "R_down", "R")
        return [{k: float(getattr(self, k)[i]) for k in keys} for i in range(self.target_mm.size)]


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

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict: the axis parameters [um], ``targets`` table, edition, warnings."""
        d: dict[str, Any] = {k: float(getattr(self, k)) for k in AXIS_KEYS}
        d["targets"] = self.targets.rows()
        d["n_runs_up"] = self.targets.n_up
        d["n_runs_down"] = self.targets.n_down
        d["edition"] = self.edition
        d["warnings"] = list(self.warnings)
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


def evaluate_grouped(g: GroupedRuns, edition: str = "2014") -> Iso2302Result:
    """ISO 230-2 parameters from runs already grouped by :func:`group_runs`.

    Parameters
    ----------
    g : GroupedRuns
        Deviations by target and run [um].
    edition : str
        ``'2014'`` (default), ``'2006'``, ``'1997'`` or ``'1988'``.

    Returns
    -------
    Iso2302Result
    """
    edition = str(edition)
    if edition not in EDITIONS:
        raise VolcalInputError(f"unknown ISO 230-2 edition {edition!r}: expected one of "
                               f"{', '.join(EDITIONS)}", column="edition")
    k = EDITIONS[edition]
    mu, md = g.up.mean(axis=1), g.down.mean(axis=1)
    su, sd = g.up.std(axis=1, ddof=1), g.down.std(axis=1, ddof=1)
    b = mu - md
    ru, rd = 2 * k * su, 2 * k * sd
    r = np.maximum.reduce([k * su + k * sd + np.abs(b), ru, rd])
    mean = (mu + md) / 2
    both = np.concatenate([mu, md])
    table = TargetStatistics(g.targets, mu, md, mean, su, sd, b, ru, rd, r,
                             g.up.shape[1], g.down.shape[1])
    a_up = float(np.max(mu + k * su) - np.min(mu - k * su))
    a_down = float(np.max(md + k * sd) - np.min(md - k * sd))
    a = float(max(np.max(mu + k * su), np.max(md + k * sd))
              - min(np.min(mu - k * su), np.min(md - k * sd)))
    return Iso2302Result(
        A=a, A_up=a_up, A_down=a_down,
        E=float(np.ptp(both)), E_up=float(np.ptp(mu)), E_down=float(np.ptp(md)),
        M=float(np.ptp(mean)),
        R=float(np.max(r)), R_up=float(np.max(ru)), R_down=float(np.max(rd)),
        B=float(np.max(np.abs(b))), B_mean=float(np.mean(b)),
        targets=table, edition=edition,
        warnings=check_test_cycle(g.targets, g.up.shape[1], g.down.shape[1]))


def evaluate(targets_mm: ArrayLike, run: ArrayLike, direction: ArrayLike,
             deviation_um: ArrayLike, edition: str = "2014", *, file: str | None = None,
             rows: ArrayLike | None = None) -> Iso2302Result:
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

    Returns
    -------
    Iso2302Result
        Axis parameters A, A_up, A_down, E, E_up, E_down, M, R, R_up, R_down, B, B_mean
        [um], the per-target table and test-cycle warnings.

    Raises
    ------
    VolcalInputError
        Missing direction, fewer than two runs a direction, NaN, duplicate readings,
        incomplete runs.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.repeat([0.0, 100.0], 4)
    >>> res = evaluate(t, [1, 1, 2, 2] * 2, ["+", "-"] * 4, [0, 1, 0, 1, 2, 3, 2, 3])
    >>> res.B, res.E
    (1.0, 3.0)
    """
    g = group_runs(targets_mm, run, direction, deviation_um, file=file, rows=rows)
    return evaluate_grouped(g, edition)

