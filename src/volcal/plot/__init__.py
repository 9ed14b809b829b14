"""Plots of volcal results (matplotlib, Agg canvas, no pyplot state).

Analysis code never imports this package: the analysis functions return result objects
and the ``*_plot`` functions here turn them into :class:`matplotlib.figure.Figure`
objects (the split of python-control). Every function returns a new figure attached to
an Agg canvas, so it works without a display and without touching ``pyplot``'s global
state.
"""

from volcal.plot.deviation import direction_statistics, linear_deviation_plot
from volcal.plot.diagonal import diagonal_fit_plot
from volcal.plot.errorfunctions import error_functions_plot
from volcal.plot.identifiability import identifiability_plot
from volcal.plot.trend import trend_plot
from volcal.plot.volumetric import volumetric_map, volumetric_map_plot

__all__ = [
    "diagonal_fit_plot",
    "direction_statistics",
    "error_functions_plot",
    "identifiability_plot",
    "linear_deviation_plot",
    "trend_plot",
    "volumetric_map",
    "volumetric_map_plot",
]
