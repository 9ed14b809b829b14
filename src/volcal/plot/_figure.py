"""A new figure on an Agg canvas, and the shared look of volcal plots."""

from __future__ import annotations

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

DIRECTION_COLORS: dict[str, str] = {"+": "tab:blue", "-": "tab:red"}
"""Colour of the approach directions (ISO 230-2: up arrow, down arrow)."""

TRUTH_STYLE: dict = {"color": "black", "linestyle": "--", "linewidth": 1.0, "label": "truth"}
"""Style of the simulated truth."""


def new_figure(width_in: float = 8.0, height_in: float = 5.0) -> Figure:
    """Create a figure attached to an Agg canvas (no pyplot, no display needed).

    Parameters
    ----------
    width_in, height_in : float
        Size [inch].

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig
