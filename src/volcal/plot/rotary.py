"""The deviation plot of a rotary test: every run, the means and the ISO 230-2 bands."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

from volcal.plot._figure import DIRECTION_COLORS, new_figure

__all__ = ["rotary_deviation_plot"]


def rotary_deviation_plot(m: Any, res: Any, units: str = "urad", fig: Figure | None = None
                          ) -> Figure:
    """Angular deviation against target angle, every run, with the mean ± 2 s bands.

    Parameters
    ----------
    m : Measurement
        A ``rotary`` measurement with readings [urad] and ``target_deg``, ``run``,
        ``direction``.
    res : RotaryIso2302Result
        Its ISO 230-2 evaluation (:mod:`volcal.standards.iso230_2_rotary`): the means and
        standard deviations per target and direction.
    units : str
        ``'urad'`` or ``'arcsec'`` (the y axis).
    fig : Figure, optional
        Figure to draw into; a new one by default.

    Returns
    -------
    matplotlib.figure.Figure
        Thin lines per run and direction, thick lines for the mean of each direction,
        dashed lines for ``mean ± 2 s`` (ISO 230-2, Figure 1, for a rotary axis); with an
        uncertainty, error bars ``x̄ ± U`` at each target.
    """
    from volcal.standards.iso230_2_rotary import UNITS

    f = UNITS[units]
    fig = fig or new_figure(7.0, 4.0)
    ax = fig.add_subplot()
    t = np.asarray(m.columns["target_deg"], dtype=float)
    dev = np.asarray(m.deviation, dtype=float) * f
    runs = np.asarray(m.columns.get("run", np.ones(t.size, int)))
    dirs = np.asarray(m.columns.get("direction", np.full(t.size, "+")))
    for r in np.unique(runs):
        for d in ("+", "-"):
            sel = (runs == r) & (dirs == d)
            if np.count_nonzero(sel) < 2:
                continue
            o = np.argsort(t[sel])
            ax.plot(t[sel][o], dev[sel][o], color=DIRECTION_COLORS[d], alpha=0.35,
                    linewidth=0.8, marker=".", markersize=3, gid=f"run {r} {d}")
    st = res.iso.targets
    for d, mean, s in (("+", st.mean_up, st.s_up), ("-", st.mean_down, st.s_down)):
        c = DIRECTION_COLORS[d]
        ax.plot(st.target_mm, mean * f, color=c, linewidth=2.0, gid=f"mean {d}",
                label=f"mean {d}  (x̄)")
        ok = np.isfinite(s)
        ax.plot(st.target_mm[ok], (mean + 2 * s)[ok] * f, color=c, linestyle="--",
                linewidth=1.0, gid=f"upper {d}", label=f"x̄ ± 2s {d}")
        ax.plot(st.target_mm[ok], (mean - 2 * s)[ok] * f, color=c, linestyle="--",
                linewidth=1.0, gid=f"lower {d}")
    if res.uncertainty is not None:
        U = np.array([e.U for e in res.uncertainty.targets]) * f
        ax.errorbar(st.target_mm, st.mean * f, yerr=U, fmt="o", color="k", markersize=3,
                    capsize=3, linewidth=1.0, gid="U", label="x̄ ± U (95 %)")
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    unit = "µrad" if units == "urad" else "arcsec"
    ax.set_xlabel(f"target angle {res.axis} [deg]")
    ax.set_ylabel(f"angular deviation [{unit}]")
    ax.set_title(f"{m.id}: {res.axis} angular positioning (ISO 230-2)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="best")
    return fig
