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
from typing import TypedDict

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


class PatchStyle(TypedDict):
    """Hatch and colours of a bar (keyword arguments of a matplotlib ``Patch``)."""

    hatch: str
    facecolor: str
    edgecolor: str


NOT_DETERMINED_STYLE: PatchStyle = {"hatch": "//", "facecolor": "0.85", "edgecolor": "0.3"}
"""Style of the bar of an error function the tests do not determine (the legend's "n/i")."""


def _bars(ax, names: list[str], values: list[float], unit: str, color: str,
          undetermined: set[str]) -> None:
    v = np.array(values, dtype=float)
    finite = np.isfinite(v) & (v > 0)
    top = float(v[finite].max()) * 3.0 if np.any(finite) else 1.0
    heights = np.where(finite, v, top)
    bars = ax.bar(np.arange(len(names)), heights, color=color, alpha=0.8, gid=f"u {unit}")
    for b, ok, name in zip(bars, finite, names, strict=True):
        if not ok or name in undetermined:
            b.set(**NOT_DETERMINED_STYLE, alpha=1.0, gid=f"{name} not determined")
            ax.annotate("n/i", (b.get_x() + b.get_width() / 2, b.get_height()),
                        ha="center", va="bottom", fontsize=7)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(names)), names, rotation=90, fontsize="small")
    ax.set_ylabel(f"max standard uncertainty [{unit}]")
    ax.grid(True, axis="y", which="both", alpha=0.3)


FRACTION_LIMITS = (0.5, 0.95)
"""Determined fractions below the first are 'not determined', below the second 'weak'."""

FRACTION_COLORS = ("tab:red", "tab:orange", "tab:green")
"""Colours of the determined fraction: not determined, weak, determined."""


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
        The uncertainty bars of the functions the data do not determine (no finite
        uncertainty, or a determined fraction below ``FRACTION_LIMITS[0]``) are hatched
        grey and marked "n/i", as the legend says; the fraction bars are coloured by
        :data:`FRACTION_COLORS` with their legend.
    """
    from matplotlib.patches import Patch

    u = function_uncertainty(std, squareness_std)
    undetermined = {n for n, f in (determined_fraction or {}).items()
                    if f < FRACTION_LIMITS[0]}
    ncol = 2 + (singular_values is not None) + (determined_fraction is not None)
    fig = fig or new_figure(min(11.0, 3.0 * ncol), 6.0)
    gs = fig.add_gridspec(2, ncol, height_ratios=[1.0, 0.04])
    axs = [fig.add_subplot(gs[0, j]) for j in range(ncol)]
    key = fig.add_subplot(gs[1, :])  # a row of its own for the legend, inside the layout
    key.axis("off")
    lin = [n for n in u if info(n).unit == "um"]
    ang = [n for n in u if n not in lin]
    _bars(axs[0], lin, [u[n] for n in lin], "µm", "tab:blue", undetermined)
    axs[0].set_title("translations")
    _bars(axs[1], ang, [u[n] for n in ang], "µrad", "tab:green", undetermined)
    axs[1].set_title("rotations and squareness")
    handles = [Patch(**NOT_DETERMINED_STYLE, label="n/i: not determined by the data")]
    col = 2
    if determined_fraction is not None:
        names = list(determined_fraction)
        f = np.array([determined_fraction[n] for n in names], dtype=float)
        colors = np.where(f < FRACTION_LIMITS[0], FRACTION_COLORS[0],
                          np.where(f < FRACTION_LIMITS[1], FRACTION_COLORS[1],
                                   FRACTION_COLORS[2]))
        ax = axs[col]
        ax.barh(np.arange(len(names)), 100.0 * f, color=colors, gid="determined")
        ax.set_yticks(np.arange(len(names)), names, fontsize="small")
        ax.invert_yaxis()
        ax.set_xlim(0, 100)
        for lim in FRACTION_LIMITS:
            ax.axvline(100 * lim, color="0.4", linewidth=0.6, linestyle=":")
        ax.set_xlabel("prior uncertainty removed [%]")
        ax.set_title("determined by the data")
        lo, hi = (f"{100 * x:g} %" for x in FRACTION_LIMITS)
        handles += [Patch(color=FRACTION_COLORS[0], label=f"removed < {lo}: not determined"),
                    Patch(color=FRACTION_COLORS[1], label=f"{lo} to {hi}: weak"),
                    Patch(color=FRACTION_COLORS[2], label=f"≥ {hi}: determined")]
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
    key.legend(handles=handles, loc="center", ncol=len(handles), fontsize="small",
               frameon=False)
    fig.suptitle("identifiability: what the tests determine")
    return fig
