"""Smoothness prior of the error functions: a sparse Gaussian precision per function.

Geometric errors of machine guideways, scales and lead screws are smooth over the
travel. Each function ``f`` on its nodes gets the prior density

.. math:: -2 \\log p(f) = \\frac{1}{a_g^2} \\left[ \\frac{1}{\\kappa^2}\\int_0^1 f''(s)^2\\,ds
          + \\int_0^1 f(s)^2\\,ds \\right] + \\text{const},

with ``s`` the position normalised to the travel, ``a_g`` the amplitude scale of its group
(positioning, straightness, roll, tilt: separate, so that an undetermined roll cannot
borrow the amplitude the well-determined tilts need) and ``kappa`` the curvature scale.
The curvature term is the penalty of a cubic smoothing spline (Wahba, *Spline Models for
Observational Data*, SIAM 1990); the amplitude term makes the prior proper so that undetermined
combinations are reported with a finite, honest uncertainty. The precision is banded,
so the posterior stays sparse (Rue & Held, *Gaussian Markov Random Fields*, 2005).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from volcal.identify.settings import EstimatorSettings
from volcal.model.parameters import ParameterLayout

_DEFAULT = EstimatorSettings()

GROUPS: tuple[str, ...] = ("positioning", "straightness", "roll", "tilt")
"""Prior amplitude groups: positioning [um], straightness [um], roll [urad] (EAX, EBY,
ECZ), the other angular errors (tilts: pitch and yaw) [urad]."""

TREND_FUNCTIONS: tuple[int, ...] = (0, 7, 14)
"""Functions (``6 * axis + component``) with a linear trend of their own in the prior: the
positioning errors EXX, EYY, EZZ. A machine's positioning error is mostly a linear scale
error (thermal expansion of scale or screw, pitch of the screw: 11.5 um/m/K on steel)
plus smaller periodic and local errors, so the trend gets its own scale instead of the
amplitude of the wiggles (ISO 230-2 reports and compensates the slope separately)."""

TILT_GROUP = 3
"""Index of the tilts (pitch and yaw) in :data:`GROUPS`."""

__all__ = ["GROUPS", "TILT_GROUP", "TREND_FUNCTIONS", "PriorStructure", "function_group",
           "function_scales", "unit_parts", "unit_precision"]


def function_group(axis: int, component: int) -> int:
    """Group index of a component error: 0 positioning, 1 straightness, 2 roll, 3 tilt.

    Parameters
    ----------
    axis : int
        Axis the error belongs to (0, 1, 2 = X, Y, Z).
    component : int
        Component index in ``EX, EY, EZ, EA, EB, EC`` order (0..5).

    Returns
    -------
    int
        0 for the positioning error (``component == axis``), 1 for a straightness error,
        2 for the roll (rotation about the moving axis itself: EAX, EBY, ECZ), 3 for the
        two tilts.
    """
    if component >= 3:
        return 2 if component - 3 == axis else 3
    return 0 if component == axis else 1


def function_scales(scales: NDArray[np.float64]) -> NDArray[np.float64]:
    """Amplitude scale of each of the 18 component functions.

    Parameters
    ----------
    scales : array_like, shape (4,) or (18,) or (3, 6)
        Either one scale per group of :data:`GROUPS` [um, um, urad, urad], or one per
        function, axis-major in ``EX, EY, EZ, EA, EB, EC`` order (``6 * axis + component``).

    Returns
    -------
    ndarray, shape (18,)
        Scale of function ``6 * axis + component`` [um or urad].
    """
    s = np.asarray(scales, dtype=float).ravel()
    if s.size == 18:
        return s
    if s.size == len(GROUPS):
        return s[[function_group(k, c) for k in range(3) for c in range(6)]]
    raise ValueError(f"scales: expected {len(GROUPS)} group scales or 18 function scales, "
                     f"got {s.size}")


def unit_parts(nodes: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Curvature and amplitude parts of the prior precision of one function on its nodes.

    Parameters
    ----------
    nodes : ndarray, shape (n,)
        Node positions [mm].

    Returns
    -------
    C : ndarray, shape (n, n)
        Discretised ``int f''(s)^2 ds`` (pentadiagonal), ``s`` normalised to [0, 1].
    W : ndarray, shape (n, n)
        Discretised ``int f(s)^2 ds`` (trapezoid weights, diagonal).
    """
    x = np.asarray(nodes, dtype=float)
    n = x.size
    if n == 1:
        return np.zeros((1, 1)), np.ones((1, 1))
    s = (x - x[0]) / (x[-1] - x[0])
    h = np.diff(s)
    w = np.zeros(n)
    w[:-1] += h / 2
    w[1:] += h / 2
    C = np.zeros((n, n))
    if n >= 3:
        D = np.zeros((n - 2, n))
        for i in range(1, n - 1):
            hl, hr = h[i - 1], h[i]
            c = 2.0 / (hl + hr)
            D[i - 1, i - 1] = c / hl
            D[i - 1, i] = -c * (1 / hl + 1 / hr)
            D[i - 1, i + 1] = c / hr
        wd = (h[:-1] + h[1:]) / 2
        C = D.T @ (wd[:, None] * D)
    return C, np.diag(w)


def _boundary_map(s: NDArray[np.float64], sel: NDArray[np.bool_], C: NDArray[np.float64],
                  W: NDArray[np.float64], mode: str = "difference"):
    """``(D, C, W)`` of the difference prior of one function, or None.

    ``D`` maps the values at all nodes to the free ones in the gauge: ``f_i - f_0`` when
    only the first node is held, ``f_i - f_0 - s_i (f_n - f_0)`` when the last one is held
    too (straightness; with ``mode='start'`` the conditional prior is kept there); None
    for any other pattern and for ``mode='conditional'`` (the conditional prior is used).
    """
    n = s.size
    if mode == "conditional" or n < 2 or sel[0]:
        return None
    first_only = np.all(sel[1:])
    both = n > 2 and not sel[-1] and np.all(sel[1:-1]) and mode == "difference"
    if not (first_only or both):
        return None
    D = np.eye(n)[sel]
    if first_only:
        D[:, 0] -= 1.0
    else:
        D[:, 0] -= 1.0 - s[sel]
        D[:, -1] -= s[sel]
    return D, C, W


def unit_precision(nodes: NDArray[np.float64], kappa: float) -> NDArray[np.float64]:
    """Prior precision of one function on its nodes for unit amplitude scale.

    Parameters
    ----------
    nodes : ndarray, shape (n,)
        Node positions [mm].
    kappa : float
        Curvature scale (dimensionless, per normalised travel).

    Returns
    -------
    ndarray, shape (n, n)
        Banded precision (pentadiagonal).
    """
    C, W = unit_parts(nodes)
    return C / kappa**2 + W


@dataclass
class PriorStructure:
    """Prior blocks of the free parameters, grouped for fast rescaling.

    Attributes
    ----------
    blocks : list of (indices into the free vector, curvature part, amplitude part, group,
            function)
        One block per function (free nodes only: conditioning on the gauge zeros keeps the
        sub-matrix of the precision); ``function`` is ``6 * axis + component``.
    squareness : ndarray of int
        Free-vector indices of the squareness parameters.
    kappa : float
        Curvature scale; the block precision is ``(C / kappa^2 + W) / a_g^2``.
    coords : list of ndarray
        Per block, the free nodes' positions normalised to the travel (0 at the start).
    kappa_factor : tuple of 4 float
        Curvature scale of each group of :data:`GROUPS` relative to ``kappa``: a
        straightness wiggles more over its travel than a positioning error or a tilt.
    trend_um : float
        Prior standard deviation of the linear trend of the functions of
        :data:`TREND_FUNCTIONS` at the end of travel [um], times the axis' factor of
        :attr:`trend_length`; 0: no separate trend. With it the block covariance is
        ``a^2 (C / kappa^2 + W)^-1 + t_k^2 s s'``, ``t_k = trend_um * trend_length[k]``
        (:meth:`block_trend`).
    tilt_trend_urad : float
        Prior standard deviation of the linear part of each tilt (pitch and yaw) at the
        end of travel [urad] (:attr:`EstimatorSettings.tilt_trend_centre_urad`); 0: none.
        Step diagonals hardly see a tilt's linear part (each line's set-up tilts take
        it), so without a scale of its own the evidence set it with the wiggles' scale,
        which the readings can shrink to nothing.
    trend_length : tuple of 3 float
        Factor of each axis' trend over :attr:`trend_um`: the axis' travel in metres when
        the trend is a scale error per length
        (:attr:`EstimatorSettings.trend_per_metre`: ``trend_um`` is then in um/m, the
        same thermal or pitch error growing with the travel), 1 for one trend at the end
        of every travel.
    maps : list
        Per block, None (the prior conditioned on the gauge zeros: ``C``, ``W`` are the
        free nodes' sub-matrices) or ``(D, C_full, W_full)`` with the boundary
        ``'difference'`` (:attr:`EstimatorSettings.boundary`): the block covariance is
        ``a^2 D (C_full / kappa^2 + W_full)^-1 D'``, ``D`` mapping all the function's
        nodes to the gauge-fixed free ones (``f_i - f_0``, or the end-point line removed
        for a straightness).
    nugget_um : float
        Short-wavelength part of the positioning errors [um]; 0: none.
    group_kappa : tuple of 4 float
        Fixed curvature factor of each group of :data:`GROUPS` over ``kappa``
        (:attr:`EstimatorSettings.group_kappa`).
    axis_kappa : tuple of 3 float
        Curvature factor of each axis' functions over ``kappa`` (evidence-chosen with
        :attr:`EstimatorSettings.axis_kappa_spread`; 1 otherwise): a 6 m axis whose errors
        keep their wavelengths in millimetres undulates more over its normalised travel
        than the 1 m axis beside it.
    axis_length : tuple of 3 float
        Travel of each axis [m] (the span of its nodes; 1 for an axis with one node),
        for the amplitudes that grow with the travel (:meth:`travel_columns`).
    shapes : list of int
        Per block, the first block of the same axis with the same free nodes: their
        curvature and amplitude parts, positions and boundary maps are the same, so are
        their unit blocks (:meth:`unit_block`), computed once (empty: every block its own).
    """

    blocks: list[tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], int, int]]
    squareness: NDArray[np.intp]
    n_free: int
    kappa: float = 40.0
    coords: list[NDArray[np.float64]] = field(default_factory=list)
    trend_um: float = 0.0
    trend_length: tuple[float, ...] = (1.0, 1.0, 1.0)
    tilt_trend_urad: float = 0.0
    kappa_factor: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0)
    maps: list = field(default_factory=list)
    nugget_um: float = 0.0
    group_kappa: tuple[float, ...] = _DEFAULT.group_kappa
    axis_kappa: tuple[float, ...] = (1.0, 1.0, 1.0)
    axis_length: tuple[float, ...] = (1.0, 1.0, 1.0)
    shapes: list[int] = field(default_factory=list)
    _unit: dict = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def build(cls, layout: ParameterLayout, free: NDArray[np.intp], kappa: float = 40.0,
              settings: EstimatorSettings | None = None) -> PriorStructure:
        """Prior blocks for the free parameters of a layout.

        Parameters
        ----------
        layout : ParameterLayout
            Full layout.
        free : ndarray of int
            Free parameter indices (into the layout).
        kappa : float
            Curvature scale (may be re-estimated, see :meth:`with_kappa`).
        settings : EstimatorSettings, optional
            Its ``boundary`` (how the prior meets the gauge zeros) and ``group_kappa``;
            default ``EstimatorSettings()``.
        """
        st = settings if settings is not None else _DEFAULT
        pos_in_free = -np.ones(layout.size, dtype=np.intp)
        pos_in_free[free] = np.arange(free.size)
        blocks, coords, maps, shapes = [], [], [], []
        first: dict[tuple[int, bytes], int] = {}
        for k in range(3):
            C, W = unit_parts(layout.nodes[k])
            x = np.asarray(layout.nodes[k], dtype=float)
            span = x[-1] - x[0] if x.size > 1 else 1.0
            s = (x - x[0]) / span
            for c in range(6):
                idx = layout.indices(k, c)
                sel = pos_in_free[idx] >= 0
                if not np.any(sel):
                    continue
                blocks.append((pos_in_free[idx][sel], C[np.ix_(sel, sel)], W[np.ix_(sel, sel)],
                               function_group(k, c), 6 * k + c))
                coords.append(s[sel])
                maps.append(_boundary_map(s, sel, C, W, st.boundary))
                shapes.append(first.setdefault((k, sel.tobytes()), len(blocks) - 1))
        sq = pos_in_free[layout.squareness_indices()]
        travel_m = tuple(float(np.ptp(layout.nodes[k])) / 1000.0 if len(layout.nodes[k]) > 1
                         else 1.0 for k in range(3))
        lengths = travel_m if st.trend_per_metre else (1.0, 1.0, 1.0)
        return cls(blocks, sq[sq >= 0], int(free.size), kappa, coords, maps=maps,
                   group_kappa=tuple(st.group_kappa), trend_length=lengths,
                   axis_length=travel_m, shapes=shapes)

    def axes_with_functions(self) -> list[int]:
        """The axes (0, 1, 2 = X, Y, Z) with free function nodes, in order."""
        return sorted({f // 6 for *_, f in self.blocks})

    def log_travel_ratios(self) -> NDArray[np.float64]:
        """``log(L_k / L_mean)`` of each axis [1], the travel exponents' lever.

        ``L_k`` is the axis' travel (:attr:`axis_length`), ``L_mean`` the geometric mean
        over :meth:`axes_with_functions`; zero for an axis without functions (it keeps
        its group's scale and curvature, the mean unmoved).

        Returns
        -------
        ndarray, shape (3,)
        """
        axes = self.axes_with_functions()
        logl = np.zeros(3)
        if axes:
            logl[axes] = np.log(np.asarray(self.axis_length, dtype=float)[axes])
            logl[axes] -= float(np.mean(logl[axes]))
        return logl

    def travel_columns(self, group_sets) -> NDArray[np.float64]:
        """How the function scales' logarithms move with each travel exponent.

        The amplitude scale of a function of axis ``k`` in a group of ``group_sets[i]``
        is its group's times ``(L_k / L_mean)^beta_i`` (``L_k`` the axis' travel,
        :attr:`axis_length`; ``L_mean`` the geometric mean over the axes with
        functions, so that the group's scale keeps the mean of the three). Column ``i``
        holds ``log(L_k / L_mean)`` in the rows of those functions and zero elsewhere
        (also for an axis without functions).

        Parameters
        ----------
        group_sets : sequence of sequence of int
            Indices into :data:`GROUPS`, one set per exponent.

        Returns
        -------
        ndarray, shape (18, len(group_sets))
            ``d log a_f / d beta_i`` [1].
        """
        logl = self.log_travel_ratios()
        out = np.zeros((18, len(group_sets)))
        for i, gs in enumerate(group_sets):
            for k in range(3):
                for c in range(6):
                    if function_group(k, c) in tuple(gs):
                        out[6 * k + c, i] = logl[k]
        return out

    def with_kappa(self, kappa: float) -> PriorStructure:
        """The same prior with another curvature scale.

        Parameters
        ----------
        kappa : float
            New curvature scale (dimensionless: positions are normalised to [0, 1]).

        Returns
        -------
        PriorStructure
            A copy sharing the blocks, with ``kappa`` replaced.
        """
        return replace(self, kappa=float(kappa))

    def with_trend(self, trend_um: float | None) -> PriorStructure:
        """The same prior with another trend scale.

        Parameters
        ----------
        trend_um : float or None
            New :attr:`trend_um` [um at the end of travel, or um/m with
            :attr:`trend_length` in metres]; None or 0: no trend.

        Returns
        -------
        PriorStructure
            A copy sharing the blocks.
        """
        return replace(self, trend_um=float(trend_um or 0.0))

    def with_tilt_trend(self, tilt_trend_urad: float | None) -> PriorStructure:
        """The same prior with another scale of the tilts' linear part.

        Parameters
        ----------
        tilt_trend_urad : float or None
            New :attr:`tilt_trend_urad` [urad at the end of travel]; None or 0: none.

        Returns
        -------
        PriorStructure
            A copy sharing the blocks.
        """
        return replace(self, tilt_trend_urad=float(tilt_trend_urad or 0.0))

    def with_nugget(self, nugget_um: float | None) -> PriorStructure:
        """The same prior with another short-wavelength (nugget) scale.

        Parameters
        ----------
        nugget_um : float or None
            New :attr:`nugget_um` [um]; None or 0: no nugget.

        Returns
        -------
        PriorStructure
            A copy sharing the blocks.
        """
        return replace(self, nugget_um=float(nugget_um or 0.0))

    def has_nugget(self, b: int) -> bool:
        """True when block ``b`` carries the short-wavelength part (:attr:`nugget_um`).

        Parameters
        ----------
        b : int
            Block index.

        Returns
        -------
        bool
        """
        return self.nugget_um > 0 and self.blocks[b][4] in TREND_FUNCTIONS

    def nugget_shape(self, b: int) -> NDArray[np.float64]:
        """Covariance of block ``b``'s short-wavelength part for a unit nugget.

        ``I + 1 1'`` in the difference form (``e_i - e_0``, the first
        node held by the gauge), ``I`` when conditioned on the gauge zeros.

        Parameters
        ----------
        b : int
            Block index.

        Returns
        -------
        ndarray, shape (n, n)
        """
        n = self.blocks[b][0].size
        mp = self.maps[b] if b < len(self.maps) else None
        return np.eye(n) + (np.ones((n, n)) if mp is not None else 0.0)

    def block_covariance_parts(self, b: int, fscales: NDArray[np.float64]):
        """Parts of the covariance of a nugget block: ``S = a^2 P^-1 + t^2 s s' + n^2 N``.

        Parameters
        ----------
        b : int
            Block index (with :meth:`has_nugget`).
        fscales : ndarray, shape (18,)
            Function scales.

        Returns
        -------
        (Pinv, K, s, N)
            Unit smooth covariance ``P^-1``, the curvature part ``K`` of
            :meth:`unit_block`, the normalised positions ``s`` times the axis' trend length
            (:attr:`trend_length`; zero when there is no trend)
            and :meth:`nugget_shape`.
        """
        P, K = self.unit_block(b)
        key = ("inv", self._shape(b), self.block_kappa(b))
        Pinv = self._unit.get(key)
        if Pinv is None:
            Pinv = np.linalg.inv(P)
            Pinv = (Pinv + Pinv.T) / 2
            self._unit[key] = Pinv
        s = (self.coords[b] * self.trend_length[self.blocks[b][4] // 6] if self.has_trend(b)
             else np.zeros(P.shape[0]))
        return Pinv, K, s, self.nugget_shape(b)

    def with_kappa_factor(self, factor) -> PriorStructure:
        """The same prior with other per-group curvature factors.

        Parameters
        ----------
        factor : sequence of 4 float
            New :attr:`kappa_factor` (one per group of :data:`GROUPS`).

        Returns
        -------
        PriorStructure
            A copy sharing the blocks.
        """
        return replace(self, kappa_factor=tuple(float(v) for v in factor))

    def with_axis_kappa(self, factor) -> PriorStructure:
        """The same prior with other per-axis curvature factors.

        Parameters
        ----------
        factor : sequence of 3 float
            New :attr:`axis_kappa` (X, Y, Z).

        Returns
        -------
        PriorStructure
            A copy sharing the blocks.
        """
        return replace(self, axis_kappa=tuple(float(v) for v in factor))

    def block_kappa(self, b: int) -> float:
        """Curvature scale of block ``b``: ``kappa`` times its group's two factors.

        :attr:`kappa_factor` (evidence-chosen, 1 by default) and :attr:`group_kappa`
        (fixed, :attr:`EstimatorSettings.group_kappa`).

        Parameters
        ----------
        b : int
            Block index.

        Returns
        -------
        float
        """
        g = self.blocks[b][3]
        return (self.kappa * self.kappa_factor[g] * self.group_kappa[g]
                * self.axis_kappa[self.blocks[b][4] // 6])

    def has_trend(self, b: int) -> bool:
        """True when block ``b`` carries the separate linear trend.

        Parameters
        ----------
        b : int
            Block index.

        Returns
        -------
        bool
        """
        if self.blocks[b][3] == TILT_GROUP:
            return self.tilt_trend_urad > 0
        return self.trend_um > 0 and self.blocks[b][4] in TREND_FUNCTIONS

    def block_trend(self, b: int) -> float:
        """Prior standard deviation of block ``b``'s trend at the end of travel [um].

        ``trend_um`` times the axis' :attr:`trend_length`; 0 without a trend.

        Parameters
        ----------
        b : int
            Block index.

        Returns
        -------
        float
        """
        if not self.has_trend(b):
            return 0.0
        if self.blocks[b][3] == TILT_GROUP:
            return self.tilt_trend_urad
        return self.trend_um * self.trend_length[self.blocks[b][4] // 6]

    def unit_block(self, b: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Block ``b``'s precision for a unit amplitude scale and its curvature derivative.

        Parameters
        ----------
        b : int
            Block index.

        Returns
        -------
        P : ndarray
            Precision of the block's free nodes for ``a = 1``, without the trend.
        K : ndarray
            ``-dP / dlog kappa / 2``: ``C / kappa^2`` when conditioned on the gauge zeros,
            ``T' (C_full / kappa^2) T`` with ``T = P_full^-1 D' P`` for the difference
            prior (:attr:`EstimatorSettings.boundary`).
        """
        kb = self.block_kappa(b)
        key = (self._shape(b), kb)
        hit = self._unit.get(key)
        if hit is not None:
            return hit
        _, C, W, _, _ = self.blocks[b]
        mp = self.maps[b] if b < len(self.maps) else None
        if mp is None:
            out = (C / kb**2 + W, C / kb**2)
        else:
            D, Cf, Wf = mp
            Pf = Cf / kb**2 + Wf
            T = np.linalg.solve(Pf, D.T)  # P_full^-1 D'
            P = np.linalg.inv(D @ T)
            P = (P + P.T) / 2
            T = T @ P
            K = T.T @ (Cf / kb**2) @ T
            out = (P, (K + K.T) / 2)
        if len(self._unit) > 256:
            self._unit.clear()
        self._unit[key] = out
        return out

    def _shape(self, b: int) -> int:
        """The first block with block ``b``'s axis and free nodes (:attr:`shapes`)."""
        return self.shapes[b] if b < len(self.shapes) else b

    def block_key(self, b: int, fscales: NDArray[np.float64]) -> tuple:
        """What block ``b``'s precision depends on: blocks with equal keys have equal ones.

        Parameters
        ----------
        b : int
            Block index.
        fscales : ndarray, shape (18,)
            Function scales.

        Returns
        -------
        tuple
            Its shape (:attr:`shapes`), curvature scale, amplitude scale, trend and
            whether it has the short-wavelength part.
        """
        return (self._shape(b), self.block_kappa(b), float(fscales[self.blocks[b][4]]),
                self.block_trend(b), self.has_nugget(b))

    def block_precision(self, b: int, fscales: NDArray[np.float64]) -> NDArray[np.float64]:
        """Prior precision of block ``b`` (dense, its free nodes).

        Parameters
        ----------
        b : int
            Block index.
        fscales : ndarray, shape (18,)
            Function scales (:func:`function_scales`).

        Returns
        -------
        ndarray
            ``(C / kappa^2 + W) / a^2`` (boundary ``'conditional'``) or ``(D (C_full /
            kappa^2 + W_full)^-1 D')^-1 / a^2`` (``'difference'``, :attr:`maps`), or with
            the trend the inverse of that covariance plus ``trend^2 s s'``
            (Sherman-Morrison).
        """
        f = self.blocks[b][4]
        if self.has_nugget(b):
            Pinv, _, s, N = self.block_covariance_parts(b, fscales)
            S = (fscales[f] ** 2 * Pinv + self.trend_um**2 * np.outer(s, s)
                 + self.nugget_um**2 * N)
            Q = np.linalg.inv(S)
            return (Q + Q.T) / 2
        Q0 = self.unit_block(b)[0] / fscales[f] ** 2
        if not self.has_trend(b):
            return Q0
        u = Q0 @ self.coords[b]
        return Q0 - np.outer(u, u) / (1.0 / self.block_trend(b)**2 + float(self.coords[b] @ u))

    def precision(self, scales: NDArray[np.float64], squareness_std: float,
                  n_total: int, nuisance_precision: NDArray[np.float64]) -> sp.csc_matrix:
        """Sparse prior precision of all unknowns (free parameters then nuisances).

        Parameters
        ----------
        scales : ndarray, shape (4,) or (18,)
            Amplitude scales of the groups [um, um, urad, urad] (:data:`GROUPS`) or of each
            function (:func:`function_scales`).
        squareness_std : float
            Prior standard deviation of the squareness errors [urad].
        n_total : int
            Number of unknowns (free + nuisance).
        nuisance_precision : ndarray
            Precision of each nuisance parameter (weak).
        """
        rows, cols, vals = [], [], []
        fs = function_scales(scales)
        for b, (idx, *_) in enumerate(self.blocks):
            Qf = self.block_precision(b, fs)
            r, c = np.nonzero(Qf)
            rows.append(idx[r])
            cols.append(idx[c])
            vals.append(Qf[r, c])
        rows.append(self.squareness)
        cols.append(self.squareness)
        vals.append(np.full(self.squareness.size, 1.0 / squareness_std**2))
        nu = np.arange(self.n_free, n_total)
        rows.append(nu)
        cols.append(nu)
        vals.append(nuisance_precision)
        return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(n_total, n_total))

    def logdet(self, scales: NDArray[np.float64], squareness_std: float,
               nuisance_precision: NDArray[np.float64]) -> float:
        """Log-determinant of :meth:`precision` (for the evidence).

        Parameters
        ----------
        scales : ndarray, shape (4,) or (18,)
            Amplitude scales of the groups [um, um, urad, urad] (:data:`GROUPS`) or of each
            function (:func:`function_scales`).
        squareness_std : float
            Prior standard deviation of the squareness errors [urad].
        nuisance_precision : ndarray
            Precision of each nuisance parameter (weak), all > 0.

        Returns
        -------
        float
            ``log det`` of the prior precision of all unknowns.
        """
        fs = function_scales(scales)
        total = 0.0
        for b in range(len(self.blocks)):
            total += np.linalg.slogdet(self.block_precision(b, fs))[1]
        return float(total - 2 * self.squareness.size * np.log(squareness_std)
                     + np.sum(np.log(nuisance_precision)))
