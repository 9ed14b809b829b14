"""VDI/DGQ 3441 (1977): statistical test of the working and positioning accuracy of machine tools.

The guideline's positioning parameters, per target j (deviation = actual minus target):

=================================  ==========================================================
mean deviation per direction       ``xbar_j_up``, ``xbar_j_down``
mean position deviation            ``xbar_j = (xbar_j_up + xbar_j_down) / 2``
reversal span                      ``U_j = |xbar_j_up - xbar_j_down|``; ``U = max_j U_j``,
                                   ``U_mean = mean_j U_j``
position scatter                   ``Ps_j = 6 sbar_j`` with ``sbar_j = (s_j_up + s_j_down)/2``
                                   (sample standard deviations); ``Ps = max_j Ps_j``,
                                   ``Ps_mean = mean_j Ps_j``
position deviation                 ``Pa = max_j xbar_j - min_j xbar_j``
position uncertainty               ``P = max_j (xbar_j + (U_j + Ps_j)/2)
                                   - min_j (xbar_j - (U_j + Ps_j)/2)``
=================================  ==========================================================

Source note: the guideline text (withdrawn, Beuth) was not available to us; the
definitions above are the ones reproduced in machine-tool metrology textbooks (e.g.
Weck and Brecher, Werkzeugmaschinen 5, Messtechnische Untersuchung und Beurteilung) and
vendor manuals. JIS B 6192 and GB/T 17421.2 are not implemented: we could not source
their definitions reliably (GB/T 17421.2 is stated to be equivalent to ISO 230-2; use
:mod:`volcal.standards.iso230_2`).

References
----------
.. [1] VDI/DGQ 3441:1977, Statistische Prüfung der Arbeits- und Positionsgenauigkeit von
   Werkzeugmaschinen - Grundlagen.
.. [2] M. Weck, C. Brecher, Werkzeugmaschinen 5: Messtechnische Untersuchung und
   Beurteilung, Springer (2006), ch. on positioning accuracy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.standards.runs import group_runs, target_statistics

__all__ = ["Vdi3441Result", "evaluate"]


@dataclass
class Vdi3441Result:
    """VDI/DGQ 3441 positioning parameters [um].

    Attributes
    ----------
    P : float
        Position uncertainty [um].
    Pa : float
        Position deviation (range of the mean positions) [um].
    Ps, Ps_mean : float
        Largest and mean position scatter [um].
    U, U_mean : float
        Largest and mean reversal span [um].
    target_mm : ndarray
        Targets [mm].
    mean, U_j, Ps_j : ndarray
        Per-target mean position deviation, reversal span and scatter [um].
    missing : list of MissingReading
        Missed (target, run, direction) cells: each target is then evaluated over the runs
        that reached it (as in :mod:`volcal.standards.iso230_2`); empty when complete.
    """

    P: float
    Pa: float
    Ps: float
    Ps_mean: float
    U: float
    U_mean: float
    target_mm: NDArray[np.float64]
    mean: NDArray[np.float64]
    U_j: NDArray[np.float64]
    Ps_j: NDArray[np.float64]
    missing: list[Any] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when every run reached every target in both directions."""
        return not self.missing

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-friendly dict of the parameters and the per-target table."""
        d: dict[str, Any] = {k: float(getattr(self, k))
                             for k in ("P", "Pa", "Ps", "Ps_mean", "U", "U_mean")}
        d["targets"] = [{"target_mm": float(t), "mean": _num(m), "U": _num(u), "Ps": _num(p)}
                        for t, m, u, p in zip(self.target_mm, self.mean, self.U_j, self.Ps_j,
                                              strict=True)]
        d["complete"] = self.complete
        d["missing"] = [m.to_dict() for m in self.missing]
        return d


def _num(v: float) -> float | None:
    v = float(v)
    return v if np.isfinite(v) else None


def evaluate(targets_mm: ArrayLike, run: ArrayLike, direction: ArrayLike,
             deviation_um: ArrayLike, *, file: str | None = None,
             rows: ArrayLike | None = None, allow_incomplete: bool = False,
             target_column: str = "target_mm") -> Vdi3441Result:
    """Evaluate a bidirectional positioning test to VDI/DGQ 3441.

    Parameters
    ----------
    targets_mm : array_like, shape (n,)
        Target of each reading [mm].
    run : array_like of int, shape (n,)
        Run number.
    direction : array_like of str, shape (n,)
        ``'+'`` or ``'-'``.
    deviation_um : array_like, shape (n,)
        Actual minus target position [um].
    file : str, optional
        Source file for error messages.
    rows : array_like of int, optional
        Row of each reading in ``file``.
    allow_incomplete : bool
        Evaluate runs that missed targets per target over the runs that reached it
        (targets with fewer than two runs each way are left out of P and Ps).
    target_column : str
        Name of the target column in ``file``, for error messages.

    Returns
    -------
    Vdi3441Result
    """
    from volcal.errors import VolcalInputError

    g = group_runs(targets_mm, run, direction, deviation_um, file=file, rows=rows,
                   allow_incomplete=allow_incomplete, target_column=target_column)
    mu, su, _ = target_statistics(g.up)
    md, sd, _ = target_statistics(g.down)
    sbar = (su + sd) / 2
    u = np.abs(mu - md)
    ps = 6 * sbar
    mean = (mu + md) / 2
    half = (u + ps) / 2
    if not np.any(np.isfinite(half)):
        raise VolcalInputError("no target reached by two runs in each direction", file, None,
                               "run")
    return Vdi3441Result(P=float(np.nanmax(mean + half) - np.nanmin(mean - half)),
                         Pa=float(np.nanmax(mean) - np.nanmin(mean)), Ps=float(np.nanmax(ps)),
                         Ps_mean=float(np.nanmean(ps)), U=float(np.nanmax(u)),
                         U_mean=float(np.nanmean(u)), target_mm=g.targets, mean=mean, U_j=u,
                         Ps_j=ps, missing=list(g.missing))
