"""The estimator's settings: one frozen object, passed down from the identify options.

Every tuning constant of the Bayesian estimator (hyperprior of the evidence, the rolls'
prior, the node grids, the numerical limits) is a field of :class:`EstimatorSettings`.
It is reached as ``IdentifyOptions(settings=...)`` (:class:`volcal.identify.IdentifyOptions`)
and ``Calibration.identify(settings=...)``; the defaults are volcal's estimator. The
measurements that chose each default are in ``benchmarks/README.md`` (section "The
estimator's lab notebook").

References
----------
MacKay, D. J. C. (1992). Bayesian interpolation. *Neural Computation* 4, 415-447.
Rasmussen, C. E., Williams, C. K. I. (2006). *Gaussian Processes for Machine Learning*,
ch. 5 (type-II maximum likelihood).
Hoeting, J. A., Madigan, D., Raftery, A. E., Volinsky, C. T. (1999). Bayesian model
averaging: a tutorial. *Statistical Science* 14, 382-417.
Kass, R. E., Raftery, A. E. (1995). Bayes factors. *JASA* 90, 773-795.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["EstimatorSettings"]


@dataclass(frozen=True)
class EstimatorSettings:
    """Settings of the evidence-optimised Bayesian estimator (:mod:`volcal.identify.solver`).

    Frozen: a result is computed with one set of settings; make another with
    :func:`dataclasses.replace`.

    Attributes
    ----------
    typical_scales : tuple of 4 float
        Amplitude scales of a typical machining centre: positioning [um], straightness
        [um], roll [urad], tilts [urad]. Used where nothing is measured yet
        (``volcal advise``) and as the fallback of the identifiability analysis.
    hyper_centre : tuple of 4 float
        Centre of the log-normal hyperprior of the four group scales (same order and
        units as ``typical_scales``); it only holds the scales the readings do not
        inform. The straightness centre is 2 um (the difference form of the prior at the
        gauge zeros, ``boundary``, doubles an unseen straightness' variance mid-travel).
        The roll's entry is not used: the roll takes the tilts' scale times
        ``roll_factor``.
    kappa_centre : float
        Centre of the hyperprior of the curvature scale ``kappa`` [1, per normalised
        travel].
    hyper_spread : float
        Spread of the hyperprior of the group scales and of ``kappa`` (one standard
        deviation, as a factor) [1].
    tilt_centre_urad : float
        Centre of the hyperprior of the set-up tilts' scale (beam and flat mirror aligned
        by eye and autoreflection) [urad].
    tilt_spread : float
        Spread of the set-up tilts' hyperprior (a factor) [1].
    trend_centre_um : float
        Centre of the hyperprior of the positioning errors' linear trend at the end of
        travel (1 m of steel scale 2 K off 20 C) [um].
    trend_spread : float
        Spread of the trend scale's hyperprior (a factor) [1].
    trend_per_metre : bool
        The positioning trend is a scale error per length: one evidence-chosen scale in
        um/m, each axis' trend at the end of its travel that scale times its travel
        (:attr:`volcal.identify.prior.PriorStructure.trend_length`), the hyperprior
        centred on ``trend_centre_um_per_m``. False: one trend in um at the end of every
        travel, centred on ``trend_centre_um`` (volcal <= issue 29), which on a 6 m axis
        expects the scale error of a 0.8 m one.
    trend_centre_um_per_m : float
        Centre of the hyperprior of the trend with ``trend_per_metre`` [um/m]: 25 um/m is
        the 20 um over the 800 mm X axis of ``trend_centre_um`` (steel 2 K off 20 C).
    tilt_trend_centre_urad : float
        Centre of the hyperprior of the tilts' linear part at the end of travel
        (:attr:`volcal.identify.prior.PriorStructure.tilt_trend_urad`) [urad]; 0: no
        linear part of its own (the tilts' wiggles' scale holds it).
    tilt_trend_spread : float
        Spread of that hyperprior (a factor) [1].
    axis_kappa_spread : float
        Spread (a factor, one standard deviation) of each axis' curvature factor around
        the common ``kappa``, chosen by the evidence
        (:attr:`volcal.identify.prior.PriorStructure.axis_kappa`), used only when
        ``kappa_travel_exponent_spread`` is 0; both 0: one curvature scale for the three
        axes [1].
    kappa_travel_exponent_spread : float
        Spread (one standard deviation) of the curvature's travel exponent ``gamma`` [1]:
        each axis' curvature factor is ``(L_k / L_mean)^gamma`` (``L_k`` the axis' travel,
        ``L_mean`` the geometric mean over the axes with functions), one exponent chosen
        by the evidence within ``kappa_travel_exponent_bounds`` (normal hyperprior centred
        on 0), searched where the travels differ by more than 1 %. Errors that keep their
        shape per millimetre undulate ``L_k / L_mean`` times more over a long axis'
        normalised travel (``gamma`` near 2); errors that keep their shape relative to the
        travel do not (``gamma`` near 0). 0: the free per-axis factors of
        ``axis_kappa_spread`` instead (volcal <= session 11: two free factors, which
        step diagonals alone could not inform).
    kappa_travel_exponent_bounds : tuple of 2 float
        Bounds of ``gamma`` in the evidence search [1].
    axis_scale_spread : float
        Spread (a factor) of each axis' amplitude scale around its group's (positioning,
        straightness, tilts; the roll follows its axis' tilts), chosen by the evidence; 0:
        one scale per group [1].
    travel_exponent_spread : float
        Spread (one standard deviation) of the travel exponents ``beta`` [1]: the
        amplitude scale of each function in a group of :attr:`travel_exponent_groups` is
        its group's times ``(L_k / L_mean)^beta`` (``L_k`` the axis' travel, ``L_mean``
        their geometric mean), ``beta`` chosen by the evidence within
        :attr:`travel_exponent_bounds`; 0: one scale per group whatever the travels.
        A straightness is the integral of its guideway's slope, so on a 3 m X beside a
        0.8 m Y the same slopes give about 4 times the straightness deviation.
    travel_exponent_centre : float
        Centre of the exponents' hyperprior [1] (0: no growth expected).
    travel_exponent_groups : tuple of tuple of int
        The groups (indices into :data:`volcal.identify.prior.GROUPS`: 0 positioning,
        1 straightness, 2 roll, 3 tilts) sharing each exponent; with another number of
        sets, :attr:`travel_exponent_bounds` changes with them (one pair for all, or one
        per set).
    travel_exponent_bounds : tuple of 2 float, or one such pair per set of groups
        Bounds of each exponent in the evidence search [1]: one pair for every set of
        :attr:`travel_exponent_groups`, or one pair per set. The angular exponent's lower
        bound is 0: the rolls share it, the readings hardly see them, and a negative
        exponent learned from a long axis' well-seen tilts shrank its unseen roll (the
        long design of ``benchmarks/families.py``: one machine covered 0.58 of the grid,
        benchmarks/README.md, lab notebook ``travel_exponent_bounds``).
    nugget : bool
        Estimate a short-wavelength ("nugget") part of the positioning errors' prior,
        independent at every point (a lead screw's cyclic error shorter than the node
        spacing).
    nugget_centre_um : float
        Centre of the nugget scale's hyperprior [um RMS].
    nugget_spread : float
        Spread of the nugget scale's hyperprior (a factor) [1].
    roll_factor : float
        The rolls' prior scale over the tilts' (applied after the evidence, which cannot
        see the rolls): ``exp(w^2)`` for a function scale varying by ``exp(w) = 1.9``
        around its group's [1].
    roll_mixture_absent : float
        Prior probability of a machine without roll errors in the two-model average of
        the estimate (Bayes factor of :func:`volcal.identify.solver.roll_log_bayes_factor`,
        Kass & Raftery 1995; model average, Hoeting et al. 1999); 0: no average [1].
    roll_mixture_covariance : str
        Covariance of that average: ``'cautious'`` (default) its mean square error over
        the two models weighted as the readings weigh them at the prior probability of no
        roll :attr:`roll_covariance_absent`, ``P' (C + (1 - P)^2 d d') + (1 - P') (C0 + P^2
        d d')`` with ``P'`` that weight (the rolls' uncertainty is dropped only where the
        readings are decisive against rolls); ``'roll'`` the fit with rolls' plus the shift
        of the mean, ``C + (1 - P)^2 d d'`` (``P' = 1``: keeps the rolls' full uncertainty
        on a machine without roll); ``'mixture'`` the mixture's own, ``P C + (1 - P) C0 + P
        (1 - P) d d'`` (``P' = P``).
    roll_covariance_absent : float
        Prior probability of no roll in the weight ``P'`` of ``'cautious'`` [1]: 0.01 holds
        the rolls' uncertainty until the readings favour no roll by a Bayes factor of about
        100 (``P' = 0.5`` at ``log`` factor -4.6); refusing the rolls' presence on weaker
        evidence let a machine with rolls the readings did not see (log factor -3.5) cover
        0.32 of its grid (benchmarks/README.md, ``roll_covariance_absent``).
    group_kappa : tuple of 4 float
        Fixed curvature factor of each prior group (positioning, straightness, roll,
        tilt) over ``kappa`` [1]: 0.6 makes the rolls smoother (the twist of a pair of
        guideways is a long-wavelength error).
    boundary : str
        How a function's prior meets the gauge zeros (``docs/identification.md``,
        section 3): ``'difference'`` the law of ``f(s) - f(0)`` (straightness: the
        end-point line removed) of a function drawn on all the nodes; ``'conditional'``
        the prior conditioned on the zeros; ``'start'`` the difference form where only
        the start is held.
    evidence_tol : float
        The evidence optimiser stops when three iterations improve ``-2 log evidence`` by
        less than this, its simplex fallback when ``2 n`` iterations do (``n``
        hyperparameters searched) [1].
    sigma_fixed_point_steps : int
        MacKay fixed-point updates of the noise before the quasi-Newton search.
    dense_qr_limit : int
        Unknowns up to which the final solve is a QR of the stacked system (noise-free
        data fitted to numerical precision) ...
    dense_qr_entries : int
        ... when that stacked matrix has at most this many entries (2e6: 16 MB); beyond
        either, Cholesky with iterative refinement.
    dense_covariance_limit : int
        Unknowns up to which the dense posterior covariance is formed on the Cholesky
        path.
    nodes_at_readings : bool
        When the refined grid would exceed ``max_nodes`` but the visited positions fit,
        keep every visited position as a node and spend the rest of the budget on the
        longest intervals, instead of a uniform grid between the readings.
    visited_nodes_factor : float
        With ``nodes_at_readings``, the visited positions alone are the nodes when they
        number up to this factor times ``max_nodes`` [1].
    hyper_max_nodes : int
        Nodes per axis of the grid on which the hyperparameters are chosen (at least the
        visited positions with ``nodes_at_readings``).
    analysis_max_nodes : int
        Nodes per axis of the identifiability analysis.
    robust_iterations : int
        Re-weighted fits of ``IdentifyOptions.robust`` at most.
    default_repeatability_um : float
        Repeatability assumed when the readings have too little redundancy to show their
        own noise [um].
    no_roll_note_factor : float
        Bayes factor in favour of "no roll errors" over rolls of the prior's size above
        which `identify` says that the readings look like a machine without roll [1].
    between_readings_factor : float
        Variance added at each node no reading touches, as a multiple of the fitted
        prior's conditional variance of that node given its neighbours
        (:mod:`volcal.identify.between`): readings at one spacing cannot show wiggles
        shorter than twice it, and guideways are often rougher between the readings than
        a cubic spline's prior assumes. The estimate is unchanged; 0: the prior's own
        interpolation uncertainty (volcal <= session 13) [1].
    """

    typical_scales: tuple[float, float, float, float] = (10.0, 5.0, 15.0, 15.0)
    hyper_centre: tuple[float, float, float, float] = (10.0, 2.0, 15.0, 15.0)
    kappa_centre: float = 6.0
    hyper_spread: float = 3.0
    tilt_centre_urad: float = 50.0
    tilt_spread: float = 2.0
    trend_centre_um: float = 20.0
    trend_spread: float = 3.0
    trend_per_metre: bool = True
    trend_centre_um_per_m: float = 25.0
    tilt_trend_centre_urad: float = 15.0
    tilt_trend_spread: float = 3.0
    axis_kappa_spread: float = 6.0
    kappa_travel_exponent_spread: float = 1.0
    kappa_travel_exponent_bounds: tuple[float, float] = (-2.0, 4.0)
    axis_scale_spread: float = 0.0
    travel_exponent_spread: float = 1.0
    travel_exponent_centre: float = 0.0
    travel_exponent_groups: tuple[tuple[int, ...], ...] = ((0, 1), (2, 3))
    travel_exponent_bounds: tuple = ((-1.0, 2.0), (0.0, 2.0))
    nugget: bool = True
    nugget_centre_um: float = 0.2
    nugget_spread: float = 10.0
    roll_factor: float = 1.5
    roll_mixture_absent: float = 0.5
    roll_mixture_covariance: str = "cautious"
    roll_covariance_absent: float = 0.01
    group_kappa: tuple[float, float, float, float] = (1.0, 1.0, 0.6, 1.0)
    boundary: str = "difference"
    evidence_tol: float = 0.05
    sigma_fixed_point_steps: int = 2
    dense_qr_limit: int = 2000
    dense_qr_entries: int = 2_000_000
    dense_covariance_limit: int = 6000
    nodes_at_readings: bool = True
    visited_nodes_factor: float = 1.5
    hyper_max_nodes: int = 21
    analysis_max_nodes: int = 41
    robust_iterations: int = 5
    default_repeatability_um: float = 0.5
    no_roll_note_factor: float = 100.0
    between_readings_factor: float = 2.0

    def __post_init__(self) -> None:
        from math import inf
        from numbers import Integral, Real

        from volcal.errors import VolcalInputError

        if self.roll_mixture_covariance not in ("roll", "mixture", "cautious"):
            raise VolcalInputError("EstimatorSettings.roll_mixture_covariance must be 'roll', "
                                   f"'mixture' or 'cautious', got "
                                   f"{self.roll_mixture_covariance!r}")
        if self.boundary not in ("difference", "conditional", "start"):
            raise VolcalInputError("EstimatorSettings.boundary must be 'difference', "
                                   f"'conditional' or 'start', got {self.boundary!r}")
        if not float(self.tilt_trend_centre_urad) >= 0:
            raise VolcalInputError("EstimatorSettings.tilt_trend_centre_urad must be 0 (off) "
                                   f"or positive, got {self.tilt_trend_centre_urad!r}")
        for name in ("axis_kappa_spread", "axis_scale_spread"):
            v = float(getattr(self, name))
            if not (v == 0.0 or v > 1.0):
                raise VolcalInputError(f"EstimatorSettings.{name} must be 0 (off) or a factor "
                                       f"above 1, got {v!r}")
        if not float(self.travel_exponent_spread) >= 0:
            raise VolcalInputError("EstimatorSettings.travel_exponent_spread must be 0 (off) "
                                   f"or positive, got {self.travel_exponent_spread!r}")
        if not float(self.kappa_travel_exponent_spread) >= 0:
            raise VolcalInputError("EstimatorSettings.kappa_travel_exponent_spread must be 0 "
                                   f"(off) or positive, got {self.kappa_travel_exponent_spread!r}")
        if not all(len(gs) and all(int(g) in (0, 1, 2, 3) for g in gs)
                   for gs in self.travel_exponent_groups):
            raise VolcalInputError("EstimatorSettings.travel_exponent_groups must be sets of "
                                   "group indices 0-3 (positioning, straightness, roll, tilt), "
                                   f"got {self.travel_exponent_groups!r}")
        pairs = {"kappa_travel_exponent_bounds": [self.kappa_travel_exponent_bounds]}
        try:
            pairs["travel_exponent_bounds"] = self.travel_exponent_bound_pairs()
        except (TypeError, ValueError):
            pairs["travel_exponent_bounds"] = [(1.0, 0.0)]  # reported below
        for name, bounds in pairs.items():
            for pair in bounds:
                try:
                    lo, hi = (float(v) for v in pair)
                except (TypeError, ValueError):
                    lo, hi = 1.0, 0.0
                if not lo < hi:
                    raise VolcalInputError(
                        f"EstimatorSettings.{name} must be (low, high) with low < high"
                        + (", or one such pair per set of travel_exponent_groups"
                           if name == "travel_exponent_bounds" else "")
                        + f", got {getattr(self, name)!r}")
        if not 0.0 <= self.roll_covariance_absent < 1.0:
            raise VolcalInputError("EstimatorSettings.roll_covariance_absent must be in [0, 1), "
                                   f"got {self.roll_covariance_absent!r}")
        if not 0.0 <= self.roll_mixture_absent < 1.0:
            raise VolcalInputError("EstimatorSettings.roll_mixture_absent must be in [0, 1), "
                                   f"got {self.roll_mixture_absent!r}")
        for name in ("typical_scales", "hyper_centre", "group_kappa"):
            v = getattr(self, name)
            if len(v) != 4 or not all(float(x) > 0 for x in v):
                raise VolcalInputError(f"EstimatorSettings.{name} must be 4 positive numbers, "
                                       f"got {v!r}")
        v = self.between_readings_factor
        if isinstance(v, bool) or not isinstance(v, Real) or not 0.0 <= float(v) < inf:
            raise VolcalInputError("EstimatorSettings.between_readings_factor must be 0 (off) "
                                   f"or a positive number, got {v!r}")
        for name, low in (("hyper_max_nodes", 3), ("analysis_max_nodes", 3),
                          ("robust_iterations", 1), ("sigma_fixed_point_steps", 0),
                          ("dense_qr_limit", 0), ("dense_qr_entries", 0),
                          ("dense_covariance_limit", 0)):
            w = getattr(self, name)
            if isinstance(w, bool) or not isinstance(w, Integral) or w < low:
                raise VolcalInputError(f"EstimatorSettings.{name} must be a whole number "
                                       f">= {low}, got {w!r}")
        for name in ("kappa_centre", "hyper_spread", "tilt_centre_urad", "tilt_spread",
                     "trend_centre_um", "trend_spread", "trend_centre_um_per_m",
                     "tilt_trend_spread", "nugget_centre_um", "nugget_spread",
                     "roll_factor", "evidence_tol", "visited_nodes_factor",
                     "default_repeatability_um", "no_roll_note_factor"):
            if not float(getattr(self, name)) > 0:
                raise VolcalInputError(f"EstimatorSettings.{name} must be positive, got "
                                       f"{getattr(self, name)!r}")

    def travel_exponent_bound_pairs(self) -> list[tuple[float, float]]:
        """The bounds of each travel exponent, one ``(low, high)`` per set of groups.

        Returns
        -------
        list of tuple of 2 float
            :attr:`travel_exponent_bounds` repeated for every set of
            :attr:`travel_exponent_groups` when it is one pair, else its pairs.

        Raises
        ------
        ValueError
            Pairs whose number differs from that of the sets, or not pairs of numbers.
        """
        from numbers import Real

        b = self.travel_exponent_bounds
        if len(b) == 2 and all(isinstance(v, Real) for v in b):
            return [(float(b[0]), float(b[1]))] * len(self.travel_exponent_groups)
        pairs = [(float(lo), float(hi)) for lo, hi in b]
        if len(pairs) != len(self.travel_exponent_groups):
            raise ValueError("one pair of bounds per set of travel_exponent_groups")
        return pairs
