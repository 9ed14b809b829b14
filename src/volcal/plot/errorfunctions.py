"""The 18 component error functions with their uncertainty bands, and the 3 squareness errors.

The band is the expanded uncertainty ``± k u`` with coverage factor ``k = 2`` (about 95 %
for a normal distribution; JCGM 100:2008, GUM, 6.2-6.3) around the estimated function.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES, COMPONENTS, SQUARENESS_NAMES, info
from volcal.plot._figure import TRUTH_STYLE, new_figure

__all__ = ["COVERAGE_FACTOR", "error_functions_plot"]

COVERAGE_FACTOR = 2.0
"""Coverage factor ``k`` of the drawn uncertainty bands (GUM 6.2)."""

FIGURE_SIZE = (11.0, 7.0)
"""Size of the figure [inch]: the free area of an A4 landscape page, so that the report
prints it at this size and its smallest labels (:data:`FONT_SIZES`) at their point size."""

FONT_SIZES = {"title": 7.5, "label": 7.0, "tick": 6.5, "legend": 6.5, "suptitle": 10.0}
"""Font sizes of the 21 panels [pt]; the smallest, 6.5 pt, is above the 6 pt a printed
label needs to be read."""


def error_functions_plot(errors: MachineErrors,
                         std: Sequence[NDArray[np.float64]] | None = None,
                         truth: MachineErrors | None = None,
                         squareness_std: NDArray[np.float64] | None = None,
                         k: float = COVERAGE_FACTOR, fig: Figure | None = None) -> Figure:
    """Each identified error function with its band ``± k u`` and the truth if known.

    Parameters
    ----------
    errors : MachineErrors
        Estimated machine: node values EX, EY, EZ [um], EA, EB, EC [urad].
    std : list of 3 arrays, shape (n_k, 6), optional
        Standard uncertainties of the node values [um] / [urad].
    truth : MachineErrors, optional
        The simulated truth, drawn dashed (evaluated at the estimate's nodes and its own).
    squareness_std : ndarray, shape (3,), optional
        Standard uncertainties of EC0Y, EB0Z, EA0Z [urad].
    k : float
        Coverage factor of the band.
    fig : Figure, optional
        Figure to draw into.

    Returns
    -------
    matplotlib.figure.Figure
        A 3 x 7 grid: one row per axis, the six components (titled with their name, unit
        and meaning from :data:`volcal.model.names.ERROR_TABLE`), then the squareness
        errors (bars with ``± k u`` error bars, truth as black marks).

    References
    ----------
    ISO 230-1:2012, 3.4 (names of the component errors). JCGM 100:2008 (GUM), 6.
    """
    fs = FONT_SIZES
    fig = fig or new_figure(*FIGURE_SIZE)
    gs = fig.add_gridspec(3, 7)
    for a in range(3):
        q = errors.nodes[a]
        for c in range(6):
            ax = fig.add_subplot(gs[a, c])
            name = COMPONENTS[c] + AXES[a]
            e = info(name)
            v = errors.values[a][:, c]
            ax.plot(q, v, color="tab:blue", linewidth=1.4, gid=f"{name} estimate",
                    label="estimate")
            if std is not None:
                u = np.asarray(std[a])[:, c]
                ax.fill_between(q, v - k * u, v + k * u, color="tab:blue", alpha=0.25,
                                linewidth=0, gid=f"{name} band", label=f"± {k:g} u")
            if truth is not None:
                qt = np.union1d(truth.nodes[a], q)
                qt = qt[(qt >= q[0]) & (qt <= q[-1])]
                ax.plot(qt, truth.function(name, qt), gid=f"{name} truth", **TRUTH_STYLE)
            ax.set_title(f"{name} [{e.unit_symbol}]\n{e.label}", fontsize=fs["title"])
            ax.tick_params(labelsize=fs["tick"])
            ax.grid(True, alpha=0.3)
            ax.set_xlabel(f"{AXES[a]} [mm]", fontsize=fs["label"])
            if a == 0 and c == 0:
                ax.legend(fontsize=fs["legend"])
    ax = fig.add_subplot(gs[:, 6])
    x = np.arange(3)
    yerr = None if squareness_std is None else k * np.asarray(squareness_std)
    ax.bar(x, errors.squareness, yerr=yerr, color="tab:blue", alpha=0.7, capsize=4,
           gid="squareness estimate")
    if truth is not None:
        ax.plot(x, truth.squareness, linestyle="none", marker="_", markersize=18,
                markeredgewidth=2, color="black", gid="squareness truth", label="truth")
        ax.legend(fontsize=fs["legend"])
    ax.set_xticks(x, [f"{n}\n{info(n).axis} to {info(n).reference}" for n in SQUARENESS_NAMES])
    ax.tick_params(labelsize=fs["tick"])
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    ax.set_title("squareness [µrad]", fontsize=fs["title"])
    ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle(f"{errors.name}: error functions (band ± {k:g} u)", fontsize=fs["suptitle"])
    return fig
