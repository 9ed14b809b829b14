"""Uncertainty between the readings: what readings at one spacing cannot show.

Readings every ``h`` cannot show a function's wiggles shorter than ``2 h``: those alias onto
longer ones (the sampling theorem), so the readings fit a smooth function and a rough one
alike. Between the readings the smoothness prior (:mod:`volcal.identify.prior`, a cubic
smoothing spline's penalty) interpolates, and its posterior variance there is at least the
prior's conditional variance of a node given its neighbours, which assumes a spectrum
falling with the fourth power of the wavenumber beyond what the readings show. Guideways,
scales and lead screws are often rougher than that (their profiles' spectra fall more
slowly), and the 95 % intervals between the readings then under-cover where the readings
are exact enough to pin the nodes at the readings (benchmarks/README.md, lab notebook
``between_readings_factor``).

:func:`between_factor` gives, at each node value no reading depends on (a zero column of
the design: the nodes the estimator places between the visited positions,
:func:`volcal.identify.design.choose_nodes`) of a function some reading moves,
``factor`` times that conditional variance, ``a^2 / P_ii`` of the fitted prior, as a
covariance part of its own beside the posterior's (``between_readings`` in the model file:
the history's change test, which compares two calibrations of one machine, leaves it out,
as it leaves out the prior's share). The estimate, the residuals and every figure at the
readings are unchanged. A function no reading moves at all
(:func:`volcal.identify.design.read_functions`: the straightnesses of a session of linear
tests) is not "between the readings": its whole prior is its uncertainty, and it gets no
part (session 18; before, its nodes had the part on top of the prior). The uncertainty
between the readings grows with the roughness the evidence found (a smooth function's
conditional variance is small) and vanishes where the readings are dense (every node
visited).

References
----------
Shannon, C. E. (1949). Communication in the presence of noise. *Proc. IRE* 37, 10-21.
Wahba, G. (1990). *Spline Models for Observational Data*. SIAM, ch. 1 and 5 (the spline's
prior and its Bayesian confidence intervals).
Rasmussen, C. E., Williams, C. K. I. (2006). *Gaussian Processes for Machine Learning*,
sect. 4.2 and 7.1 (a covariance's spectrum and what equally spaced samples determine).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from volcal.identify.design import UNTOUCHED_TOL, Design, read_functions, untouched_parameters
from volcal.identify.prior import PriorStructure
from volcal.identify.result import diagonal_factor
from volcal.identify.settings import EstimatorSettings
from volcal.identify.solver import Solution
from volcal.model.parameters import ParameterLayout

__all__ = ["UNTOUCHED_TOL", "between_factor", "between_readings_variance", "fitted_prior",
           "untouched_parameters"]

def between_readings_variance(design: Design, prior: PriorStructure,
                              function_scales: NDArray[np.float64],
                              factor: float) -> NDArray[np.float64]:
    """Variance to add at each free parameter between the readings.

    Parameters
    ----------
    design : Design
        Assembled observation system.
    prior : PriorStructure
        The fitted prior (its ``kappa``, factors, trend and nugget those of the fit).
    function_scales : ndarray, shape (18,)
        The fit's function scales [um or urad].
    factor : float
        Multiple of the prior's conditional variance [1]; 0: none.

    Returns
    -------
    ndarray, shape (design.n_free,)
        ``factor * 1 / P_ii`` at the untouched nodes of each function some reading moves
        (``P`` the block's prior precision), 0 elsewhere [um^2 or urad^2].
    """
    out = np.zeros(design.n_free)
    if factor <= 0:
        return out
    free = untouched_parameters(design)
    # a function no reading moves keeps its whole prior (session 18: it had the part too)
    free &= read_functions(design.layout, np.asarray(design.free), free)
    for b, block in enumerate(prior.blocks):
        idx = block[0]
        sel = free[idx]
        if not sel.any() or not function_scales[block[4]] > 0:
            continue
        q = np.diag(prior.block_precision(b, function_scales))
        out[idx[sel]] = factor / q[sel]
    return out


def fitted_prior(layout: ParameterLayout, free: NDArray[np.intp], sol: Solution,
                 settings: EstimatorSettings, kappa: float | None = None) -> PriorStructure:
    """The prior with a fit's hyperparameters, on a layout.

    Parameters
    ----------
    layout : ParameterLayout
        Parameter layout (the fit's, or another grid of the same session).
    free : ndarray of int
        Estimated parameters of ``layout``.
    sol : Solution
        The fit (its ``kappa``, trend, curvature factors, nugget, tilts' trend).
    settings : EstimatorSettings
        The estimator's settings.
    kappa : float, optional
        Curvature scale instead of ``sol.kappa``.

    Returns
    -------
    PriorStructure
    """
    k = sol.kappa if kappa is None else kappa
    return (PriorStructure.build(layout, free, k, settings=settings)
            .with_trend(sol.trend_um).with_kappa_factor(sol.kappa_factor)
            .with_nugget(sol.nugget_um).with_axis_kappa(sol.axis_kappa)
            .with_tilt_trend(sol.tilt_trend_urad))


def between_factor(design: Design, sol: Solution,
                   settings: EstimatorSettings) -> NDArray[np.float64] | None:
    """Covariance factor of the variance between the readings, or None.

    Parameters
    ----------
    design : Design
        Assembled observation system.
    sol : Solution
        A Bayesian solution (``method == 'bayes'``, its function scales known).
    settings : EstimatorSettings
        Its :attr:`~volcal.identify.settings.EstimatorSettings.between_readings_factor`.

    Returns
    -------
    ndarray, shape (design.n_free, k), or None
        One column per widened parameter, ``sqrt`` of its
        :func:`between_readings_variance` in its row (the parts are independent); None
        when nothing is added (factor 0, a minimum-norm fit, every node read).
    """
    factor = settings.between_readings_factor
    if (factor <= 0 or sol.method != "bayes" or sol.function_scales is None
            or not np.isfinite(sol.kappa)):
        return None
    prior = fitted_prior(design.layout, design.free, sol, settings)
    add = between_readings_variance(design, prior, np.asarray(sol.function_scales), factor)
    return diagonal_factor(add) if np.any(add > 0) else None
