"""The trend of one history parameter: its value at each calibration, with U as bars.

The rows are :func:`volcal.history.trend.trend`'s (``id``, ``date``, ``value``, ``U``,
``unit``); this module needs nothing of the history and, like every plot of volcal, never
touches ``pyplot`` or the matplotlib backend of the caller (a new figure on an Agg canvas).
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from volcal.errors import VolcalInputError
from volcal.io.atomic import atomic_path
from volcal.plot._figure import new_figure

__all__ = ["trend_plot", "write_trend_plot"]


def trend_plot(rows: Sequence[dict[str, Any]], parameter: str, machine: str) -> Figure:
    """The trend as a figure: value with its expanded uncertainty U (k = 2) as a band.

    The band ``value - U`` to ``value + U`` joins the calibrations that have a U (shaded),
    and each of them has its error bar; a calibration without U is a point alone.

    Parameters
    ----------
    rows : sequence of dict
        ``date`` (ISO 8601, the first 10 characters are the day), ``value`` and ``U`` (in
        ``unit``: ``'um'``, ``'urad'`` or ``''``); a row without a value is left out, one
        without U has no bar.
    parameter : str
        Parameter name (the y label).
    machine : str
        Machine (the title).

    Returns
    -------
    matplotlib.figure.Figure
        A new figure on an Agg canvas.
    """
    pts = [r for r in rows if r["value"] is not None]
    fig = new_figure(6.5, 3.2)
    ax = fig.add_subplot()
    x = [_dt.date.fromisoformat(r["date"][:10]) for r in pts]
    y = [r["value"] for r in pts]
    e = [0.0 if r["U"] is None else r["U"] for r in pts]
    # matplotlib's stubs type the data as numbers (ArrayLike); its unit converters plot
    # datetime.date on a date axis, which is what this figure wants
    ax.errorbar(x, y, yerr=e, marker="o", capsize=3)  # type: ignore[arg-type]
    band = [(xi, r["value"], r["U"]) for xi, r in zip(x, pts, strict=True)
            if r["U"] is not None]
    if band:
        bx = [b[0] for b in band]
        ax.fill_between(bx, [b[1] - b[2] for b in band],  # type: ignore[arg-type]
                        [b[1] + b[2] for b in band], alpha=0.25, linewidth=0,
                        label="U (k = 2)")
    unit = pts[0]["unit"].replace("um", "µm").replace("urad", "µrad") if pts else ""
    ax.set_ylabel(f"{parameter} [{unit}]")
    ax.set_title(f"{machine}: {parameter} (band and bars: U, k = 2)")
    fig.autofmt_xdate()
    return fig


TREND_FORMATS = ("png", "svg", "pdf")
"""Formats of ``volcal history trend --plot`` (from the file's suffix)."""


def check_trend_plot_path(path: str | Path) -> Path:
    """Check a trend figure's file before anything is read or drawn.

    Parameters
    ----------
    path : str or Path
        Figure file (``.png``, ``.svg``, ``.pdf``).

    Returns
    -------
    Path

    Raises
    ------
    VolcalInputError
        The suffix names none of :data:`TREND_FORMATS`; the folder is missing or read-only;
        the path is a folder, a session's file or a file volcal did not write
        (:func:`volcal.io.paths.check_output_file`: a figure volcal wrote carries its mark
        in its metadata and may be replaced).
    """
    from volcal.io.paths import check_output_file

    path = Path(path)
    fmt = path.suffix.lstrip(".").lower()
    if fmt not in TREND_FORMATS:
        raise VolcalInputError("the figure's format comes from its suffix: expected one of "
                               f"{', '.join('.' + f for f in TREND_FORMATS)}", path)
    return check_output_file(path)


def write_trend_plot(rows: Sequence[dict[str, Any]], parameter: str, machine: str,
                     path: str | Path) -> Path:
    """Write :func:`trend_plot` to a file, atomically; the format from its suffix.

    Parameters
    ----------
    rows : sequence of dict
        See :func:`trend_plot`.
    parameter : str
        Parameter name.
    machine : str
        Machine.
    path : str or Path
        Figure file (``.png``, ``.svg``, ``.pdf``), checked with
        :func:`check_trend_plot_path`.

    Returns
    -------
    Path
        The file, with volcal's mark in its metadata (PNG ``Software``, SVG and PDF
        ``Creator``).

    Raises
    ------
    VolcalInputError
        See :func:`check_trend_plot_path` (nothing is written).
    """
    path = check_trend_plot_path(path)
    fmt = path.suffix.lstrip(".").lower()
    fig = trend_plot(rows, parameter, machine)
    key = "Software" if fmt == "png" else "Creator"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, metadata={key: "volcal history trend"})
    return path
