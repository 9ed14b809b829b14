"""Identifiability overview: what the measurements pin down and what they leave open.

Left: the largest standard uncertainty of each of the 21 errors over its nodes
(translations [um], rotations and squareness [urad]), log scale; functions the tests do
not determine (for instance the roll errors, which no laser displacement reading sees:
Wang & Liotto 2003, seed 000, section 1) show as tall or missing bars marked "n/i".
Middle, when given: the fraction of each function's prior uncertainty that the data
remove (1 - posterior/prior variance, as the identification reports it), coloured red
below 50 %, orange below 95 %. Right, when given: the singular values of the scaled
observation matrix, whose tail shows how close the problem is to losing rank (Golub &
Van Loan, Matrix Computations, 4th ed., 2013, 2.4 and 6.1).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from volcal.model.names import AXES, COMPONENTS, SQUARENESS_NAMES, info
from volcal.plot._figure import new_figure

__all__ = ["function_uncertainty", "identifiability_plot"]


def function_uncertainty(std: Sequence[NDArray[np.float64]],
                         squareness_std: ArrayLike | None = None) -> dict[str, float]:
    """Largest standard uncertainty of each error function over its nodes.

    Parameters
    ----------
    std : list of 3 arrays, shape (n_k, 6)
        Standard uncertainties of the node values [um] / [urad].
    squareness_std : array_like, shape (3,), optional
        Standard uncertainties of EC0Y, EB0Z, EA0Z [urad].

    Returns
    -------
    dict of str to float
        ISO 230-1 name -> max standard uncertainty [um] or [urad]; ``inf`` where any
        node is undetermined (non-finite).
    """
    out: dict[str, float] = {}
    for a in range(3):
        s = np.asarray(std[a], dtype=float).reshape(-1, 6)
        for c in range(6):
            col = s[:, c]
            out[COMPONENTS[c] + AXES[a]] = (float(np.max(col)) if np.all(np.isfinite(col))
                                            else float("inf"))
    if squareness_std is not None:
        for n, v in zip(SQUARENESS_NAMES, np.asarray(squareness_std, dtype=float).reshape(3),
                        strict=True):
            out[n] = float(v) if np.isfinite(v) else float("inf")
    return out


def _bars(ax, names: list[str], values: list[float], unit: str, color: str) -> None:
    v = np.array(values, dtype=float)
    finite = np.isfinite(v) & (v > 0)
    top = float(v[finite].max()) * 3.0 if np.any(finite) else 1.0
    heights = np.where(finite, v, top)
    bars = ax.bar(np.arange(len(names)), heights, color=color, alpha=0.8, gid=f"u {unit}")
    for b, ok in zip(bars, finite, strict=True):
        if not ok:
            b.set_hatch("//")
            b.set_facecolor("0.85")
            ax.annotate("n/i", (b.get_x() + b.get_width() / 2, b.get_height()),
                        ha="center", va="bottom", fontsize="x-small")
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(names)), names, rotation=90, fontsize="small")
    ax.set_ylabel(f"max standard uncertainty [{unit}]")
    ax.grid(True, axis="y", which="both", alpha=0.3)


FRACTION_LIMITS = (0.5, 0.95)
"""Determined fractions below the first are 'not determined', below the second 'weak'."""


def identifiability_plot(std: Sequence[NDArray[np.float64]],
                         squareness_std: ArrayLike | None = None,
                         singular_values: ArrayLike | None = None,
                         determined_fraction: Mapping[str, float] | None = None,
                         fig: Figure | None = None) -> Figure:
    """Plot per-function uncertainty bars, determined fractions and singular values.

    Parameters
    ----------
    std : list of 3 arrays, shape (n_k, 6)
        Standard uncertainties of the node values [um] / [urad].
    squareness_std : array_like, shape (3,), optional
        Standard uncertainties of the squareness errors [urad].
    singular_values : array_like, optional
        Singular values of the (column-scaled) observation matrix, any order.
    determined_fraction : mapping of str to float, optional
        ISO 230-1 name -> fraction of the prior uncertainty removed by the data [-].
    fig : Figure, optional
        Figure to draw into.

    Returns
    -------
    matplotlib.figure.Figure
    """
    u = function_uncertainty(std, squareness_std)
    ncol = 2 + (singular_values is not None) + (determined_fraction is not None)
    fig = fig or new_figure(4.2 * ncol, 4.2)
    axs = fig.subplots(1, ncol, squeeze=False)[0]
    lin = [n for n in u if info(n).unit == "um"]
    ang = [n for n in u if n not in lin]
    _bars(axs[0], lin, [u[n] for n in lin], "µm", "tab:blue")
    axs[0].set_title("translations")
    _bars(axs[1], ang, [u[n] for n in ang], "µrad", "tab:green")
    axs[1].set_title("rotations and squareness")
    col = 2
    if determined_fraction is not None:
        names = list(determined_fraction)
        f = np.array([determined_fraction[n] for n in names], dtype=float)
        colors = np.where(f < FRACTION_LIMITS[0], "tab:red",
                          np.where(f < FRACTION_LIMITS[1], "tab:orange", "tab:green"))
        ax = axs[col]
        ax.barh(np.arange(len(names)), 100.0 * f, color=colors, gid="determined")
        ax.set_yticks(np.arange(len(names)), names, fontsize="small")
        ax.invert_yaxis()
        ax.set_xlim(0, 100)
        for lim in FRACTION_LIMITS:
            ax.axvline(100 * lim, color="0.4", linewidth=0.6, linestyle=":")
        ax.set_xlabel("prior uncertainty removed [%]")
        ax.set_title("determined by the data")
        col += 1
    if singular_values is not None:
        sv = np.sort(np.abs(np.asarray(singular_values, dtype=float)))[::-1]
        ax = axs[col]
        rel = sv / sv[0] if sv.size and sv[0] > 0 else sv
        ax.semilogy(np.arange(1, sv.size + 1), np.maximum(rel, 1e-17), marker=".",
                    gid="singular values")
        ax.set_xlabel("index")
        ax.set_ylabel("σ_i / σ_1")
        ax.set_title("singular values")
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("identifiability: what the tests determine")
    return fig
