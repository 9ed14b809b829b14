"""Layout of a multilateration session: grid path, tracker stations, tool offsets."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from volcal.plot._figure import new_figure

__all__ = ["multilateration_layout_plot"]


def multilateration_layout_plot(path_mm: ArrayLike, stations_mm: ArrayLike,
                                fitted_mm: ArrayLike | None = None,
                                labels: Sequence[str] | None = None,
                                title: str | None = None) -> Figure:
    """Plan view and side view of the grid path and the tracker stations.

    Parameters
    ----------
    path_mm : array_like, shape (n, 3)
        Nominal tool points in the order visited [mm].
    stations_mm : array_like, shape (k, 3)
        Station pivots as set up [mm].
    fitted_mm : array_like, shape (k, 3), optional
        Fitted station pivots [mm] (drawn as crosses; their shift from the set-up is
        usually too small to see at this scale and is given in the table of the report).
    labels : sequence of str, optional
        Station labels (default S1, S2, ...).
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    p = np.asarray(path_mm, dtype=float).reshape(-1, 3)
    s = np.asarray(stations_mm, dtype=float).reshape(-1, 3)
    labels = list(labels) if labels is not None else [f"S{i + 1}" for i in range(len(s))]
    fig = new_figure(9.0, 4.5)
    axes = fig.subplots(1, 2)
    for ax, (i, j), name in zip(axes, ((0, 1), (0, 2)), ("plan view (X-Y)", "side view (X-Z)"),
                                strict=True):
        ax.plot(p[:, i], p[:, j], "-", color="0.7", lw=0.6, label="grid path")
        ax.plot(p[:, i], p[:, j], ".", color="C0", ms=3)
        ax.plot(s[:, i], s[:, j], "^", color="C3", ms=9, label="station (set up)")
        if fitted_mm is not None:
            f = np.asarray(fitted_mm, dtype=float).reshape(-1, 3)
            ax.plot(f[:, i], f[:, j], "x", color="k", ms=7, label="station (fitted)")
        for k, lab in enumerate(labels):
            ax.annotate(lab, (s[k, i], s[k, j]), textcoords="offset points", xytext=(5, 5))
        ax.set_xlabel(f"{'XYZ'[i]} [mm]")
        ax.set_ylabel(f"{'XYZ'[j]} [mm]")
        ax.set_title(name)
        ax.set_aspect("equal", adjustable="datalim")
    axes[0].legend(loc="best", fontsize="small")
    if title:
        fig.suptitle(title)
    return fig
