"""Diagonal and step-diagonal readings with the model fit and the residuals.

The abscissa is the commanded displacement along the nominal beam, ``(q - q_0) . n``
[mm]: the diagonal length for a body diagonal (ISO 230-6:2002), and the running
projection of the single-axis moves for a sequential step diagonal (Wang & Liotto 2003,
seed 000, section 4), so both kinds read from left to right.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from volcal.plot._figure import new_figure
from volcal.session.format import Measurement

__all__ = ["beam_displacement", "diagonal_fit_plot"]


def beam_displacement(measurement: Measurement) -> NDArray[np.float64]:
    """Commanded displacement along the nominal beam from the first reading [mm].

    Parameters
    ----------
    measurement : Measurement
        Any measurement.

    Returns
    -------
    ndarray, shape (n,)
        ``(q - q_0) . n`` [mm].
    """
    q = measurement.positions
    return (q - q[0]) @ measurement.beam_direction


def diagonal_fit_plot(measurements: Sequence[Measurement],
                      fitted: Mapping[str, NDArray[np.float64]] | None = None,
                      residuals: Mapping[str, NDArray[np.float64]] | None = None,
                      title: str | None = None, fig: Figure | None = None) -> Figure:
    """Plot readings, model fit and residuals of diagonal or step-diagonal tests.

    Parameters
    ----------
    measurements : sequence of Measurement
        Diagonal or step-diagonal measurements with deviations [um].
    fitted : mapping of str to ndarray, optional
        Model value of each reading by measurement id [um] (the identified machine plus
        the set-up terms).
    residuals : mapping of str to ndarray, optional
        Residuals by measurement id [um]; computed as reading minus fit when omitted.
    title : str, optional
        Figure title.
    fig : Figure, optional
        Figure to draw into.

    Returns
    -------
    matplotlib.figure.Figure
        One column per measurement: readings (dots) and fit (line) on top, residuals
        below.

    References
    ----------
    J. A. Soons, "Analysis of the step-diagonal test", NIST (seed 004), section 1:
    regression over all readings; the residuals check the model.
    """
    meas = [m for m in measurements if m.deviation is not None]
    if not meas:
        raise ValueError("no measurement with deviations to plot")
    n = len(meas)
    fig = fig or new_figure(max(4.0, 3.2 * n), 5.5)
    axs = fig.subplots(2, n, sharex="col", squeeze=False,
                       gridspec_kw={"height_ratios": [2.0, 1.0]})
    for j, m in enumerate(meas):
        s = beam_displacement(m)
        dev = m.deviation
        assert dev is not None  # meas keeps the measurements with readings
        top, bottom = axs[0, j], axs[1, j]
        top.plot(s, dev, linestyle="none", marker=".", markersize=4, color="tab:blue",
                 gid=f"{m.id} reading", label="reading")
        fit = None if fitted is None else fitted.get(m.id)
        res = None if residuals is None else residuals.get(m.id)
        if fit is not None:
            top.plot(s, fit, color="tab:orange", linewidth=1.2, gid=f"{m.id} fit", label="fit")
            if res is None:
                res = dev - np.asarray(fit)
        if res is not None:
            bottom.plot(s, res, linestyle="none", marker=".", markersize=3, color="tab:red",
                        gid=f"{m.id} residual")
            rms = float(np.sqrt(np.mean(np.square(res))))
            bottom.set_title(f"residual rms {rms:.2f} µm", fontsize="small")
        bottom.axhline(0.0, color="0.6", linewidth=0.6)
        top.set_title(m.id, fontsize="medium")
        bottom.set_xlabel("along beam [mm]", fontsize="small")
        for ax in (top, bottom):
            ax.grid(True, alpha=0.3)
            ax.tick_params(labelsize="x-small")
        if j == 0:
            top.set_ylabel("deviation [µm]")
            bottom.set_ylabel("residual [µm]")
            top.legend(fontsize="x-small")
    if title:
        fig.suptitle(title)
    return fig
