"""Positional deviation against target position, per run, with the ISO 230-2 envelopes.

ISO 230-2:2014, 3.3-3.4: at each target ``P_i`` and for each approach direction the mean
unidirectional positional deviation ``x̄_i`` is the mean of the ``n`` runs and ``s_i``
the estimator of the unidirectional standard uncertainty (``n - 1`` in the denominator);
the envelopes ``x̄_i ± 2 s_i`` bound the plot of the standard's Figure 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from volcal.model.names import AXES
from volcal.plot._figure import DIRECTION_COLORS, new_figure
from volcal.session.format import Measurement

__all__ = ["DirectionStatistics", "direction_statistics", "linear_deviation_plot"]


@dataclass(frozen=True)
class DirectionStatistics:
    """Per-target statistics of one approach direction (ISO 230-2:2014, 3.3).

    Attributes
    ----------
    direction : str
        ``'+'`` or ``'-'``.
    targets : ndarray, shape (m,)
        Target positions [mm], increasing.
    mean : ndarray, shape (m,)
        Mean unidirectional positional deviation ``x̄_i`` [um].
    std : ndarray, shape (m,)
        Estimator of the unidirectional standard uncertainty ``s_i`` [um] (NaN with one run).
    runs : int
        Largest number of readings at one target.
    """

    direction: str
    targets: NDArray[np.float64]
    mean: NDArray[np.float64]
    std: NDArray[np.float64]
    runs: int


def direction_statistics(measurement: Measurement) -> dict[str, DirectionStatistics]:
    """Mean and standard uncertainty per target and approach direction.

    Parameters
    ----------
    measurement : Measurement
        A linear measurement with deviations [um]; the ``direction`` column is optional
        (all readings count as ``'+'`` without it).

    Returns
    -------
    dict of str to DirectionStatistics
        Keyed by the directions present.

    References
    ----------
    ISO 230-2:2014, Test code for machine tools - Part 2: Determination of accuracy and
    repeatability of positioning of numerically controlled axes, 3.3.
    """
    if measurement.deviation is None:
        raise ValueError(f"measurement {measurement.id!r} has no deviations")
    axis = measurement.axis if measurement.axis is not None else 0
    pos = np.round(measurement.positions[:, axis], 6)
    dev = measurement.deviation
    dirs = measurement.direction
    if dirs is None:
        dirs = np.full(measurement.n, "+")
    out = {}
    for d in ("+", "-"):
        sel = dirs == d
        if not np.any(sel):
            continue
        targets = np.unique(pos[sel])
        mean = np.empty(targets.size)
        std = np.empty(targets.size)
        runs = 0
        for i, t in enumerate(targets):
            x = dev[sel & (pos == t)]
            runs = max(runs, x.size)
            mean[i] = x.mean()
            std[i] = x.std(ddof=1) if x.size > 1 else np.nan
        out[d] = DirectionStatistics(d, targets, mean, std, runs)
    return out


def linear_deviation_plot(measurement: Measurement, fig: Figure | None = None,
                          uncertainty: tuple[Any, Any, Any] | None = None) -> Figure:
    """Deviation against target position, every run, with the mean ± 2s envelopes.

    Parameters
    ----------
    measurement : Measurement
        A linear measurement with deviations [um], ideally with ``run`` and
        ``direction`` columns (bidirectional runs, ISO 230-2).
    fig : Figure, optional
        Figure to draw into; a new one by default.
    uncertainty : tuple of 3 array_like, optional
        ``(targets_mm, mean_um, U_um)``: the mean bidirectional deviation of each target
        [um] and its expanded uncertainty [um] (an uncertainty budget,
        :mod:`volcal.standards.iso230_2_uncertainty`), drawn as error bars ``± U``.

    Returns
    -------
    matplotlib.figure.Figure
        One axes: thin lines per run and direction, thick lines for the mean of each
        direction and dashed lines for ``mean ± 2 s``; black error bars ``x̄ ± U`` when
        ``uncertainty`` is given.

    References
    ----------
    ISO 230-2:2014, Figure 1 (typical plot of positioning deviations).
    """
    fig = fig or new_figure(7.0, 4.0)
    ax = fig.add_subplot()
    axis = measurement.axis if measurement.axis is not None else 0
    pos = measurement.positions[:, axis]
    dev = measurement.deviation
    if dev is None:
        raise ValueError(f"measurement {measurement.id!r} has no deviations")
    runs = measurement.run if measurement.run is not None else np.ones(measurement.n, int)
    dirs = measurement.direction
    if dirs is None:
        dirs = np.full(measurement.n, "+")
    for r in np.unique(runs):
        for d in ("+", "-"):
            sel = (runs == r) & (dirs == d)
            if np.count_nonzero(sel) < 2:
                continue
            order = np.argsort(pos[sel])
            ax.plot(pos[sel][order], dev[sel][order], color=DIRECTION_COLORS[d], alpha=0.35,
                    linewidth=0.8, marker=".", markersize=3, gid=f"run {r} {d}")
    for d, st in direction_statistics(measurement).items():
        c = DIRECTION_COLORS[d]
        ax.plot(st.targets, st.mean, color=c, linewidth=2.0, gid=f"mean {d}",
                label=f"mean {d}  (x̄)")
        if np.all(np.isfinite(st.std)):
            ax.plot(st.targets, st.mean + 2 * st.std, color=c, linestyle="--", linewidth=1.0,
                    gid=f"upper {d}", label=f"x̄ ± 2s {d}")
            ax.plot(st.targets, st.mean - 2 * st.std, color=c, linestyle="--", linewidth=1.0,
                    gid=f"lower {d}")
    if uncertainty is not None:
        t, mu, U = (np.asarray(v, dtype=float) for v in uncertainty)
        ax.errorbar(t, mu, yerr=U, fmt="o", color="k", markersize=3, capsize=3,
                    linewidth=1.0, gid="U", label="x̄ ± U (95 %)")
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    ax.set_xlabel(f"target position {AXES[axis]} [mm]")
    ax.set_ylabel("positional deviation [µm]")
    ax.set_title(f"{measurement.id}: {AXES[axis]} positioning (ISO 230-2)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="best")
    return fig
