"""Expanded uncertainty of an identified model's volumetric, straightness, squareness indices.

The identified model carries the covariance of its parameters as two factors
(:class:`volcal.identify.result.IdentificationResult`): the noise and prior part
(``cov_factor``) and, when it was identified with ``--budget``, the systematic part of the
laser budget propagated through the fit's linear gain (``sys_factor``,
:mod:`volcal.identify.systematic`). The covariance is ``G G^T`` with ``G`` either factor
or both side by side; the posterior of the parameters is normal, ``theta + G z`` with
``z ~ N(0, I)``.

* **Squareness** is a parameter of the model: its ``u`` is exact (linear),
  ``u^2 = u_noise^2 + u_sys^2``.
* **Volumetric indices** (ISO 230-1: ``E_VX``, ``E_VY``, ``E_VZ`` ranges of a component,
  ``E_VXYZ`` largest length, ``E_VXYZ_range`` largest distance between two error vectors,
  :mod:`volcal.standards.volumetric`) and **straightness** (range of a straightness
  function about its least-squares line, ISO 230-1, :mod:`volcal.standards.straightness`)
  are maxima over a grid: not linear in the parameters. Their uncertainty is evaluated
  by propagating the posterior distribution (JCGM 101:2008, GUM Supplement 1, the Monte
  Carlo method): ``draws`` samples of the error field, the index of each, ``u`` the
  standard deviation of the sampled index, ``U = k u`` with ``k = 2`` (the posterior is
  normal with many degrees of freedom); the probabilistically symmetric 95 % interval of
  the draws and their mean are reported too (the mean of a maximum of uncertain values
  exceeds the maximum of the estimates: that bias is stated, not corrected). The seed is
  fixed, so that a result is reproducible. The noise and the systematic parts are
  sampled apart as well, and with a systematic part ``u`` is their quadrature sum
  ``sqrt(u_noise^2 + u_sys^2)`` (GUM 5.1.2, the parts independent): the standard
  deviation of the joint draws of a maximum is not monotone in the parts (adding the
  budget's systematic part lowered the joint draws' ``u`` of ``E_VXYZ`` by 0.2 % on the
  machine of ``tests/report/test_certificate_number.py``, whose systematic part alone is
  6 % of the noise part), and a certificate's U must not fall when a source is added; the
  joint draws give the interval and the mean. The first-order (linear) propagation at
  the grid points where the estimate has its extremes is given beside it (``u_linear``):
  it ignores that the extreme may move to another point.

References
----------
.. [1] JCGM 101:2008, Evaluation of measurement data - Supplement 1 to the GUM -
   Propagation of distributions using a Monte Carlo method, 7 (the Monte Carlo method),
   7.7 (the probabilistically symmetric coverage interval).
.. [2] JCGM 100:2008 (GUM), 5.1 (the law of propagation of uncertainty).
.. [3] ISO 230-1:2012, straightness, squareness and volumetric performance.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.model.names import AXES, COMPONENT_NAMES, SQUARENESS_NAMES

__all__ = ["IndexUncertainty", "ModelUncertainty", "VOLUMETRIC_KEYS", "function_parts",
           "describe_inputs", "has_covariance", "largest_length", "model_uncertainty"]

#: The volumetric indices that carry a U (``U_<key>``).
VOLUMETRIC_KEYS: tuple[str, ...] = ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range")

#: Coverage factor of the indices (normal posterior, large degrees of freedom).
K_INDEX = 2.0

#: Draws whose error fields are evaluated together (:func:`model_uncertainty`).
DRAW_BLOCK = 100


@dataclass(frozen=True)
class IndexUncertainty:
    """Uncertainty of one index of the model.

    Attributes
    ----------
    value : float
        The index of the identified model [um or urad].
    u : float
        Standard uncertainty, noise and systematic parts together (in quadrature when
        there is a systematic part).
    u_noise, u_sys : float
        Standard uncertainty of each part alone (``u_sys`` is 0 without a systematic part).
    U : float
        Expanded uncertainty ``k u`` (k = 2).
    k : float
        Coverage factor.
    method : str
        ``'monte-carlo'`` (sampled posterior) or ``'linear'`` (exact for a parameter).
    u_linear : float or None
        First-order propagation at the estimate's extreme points (sampled indices only).
    mean_draws : float or None
        Mean of the sampled index (sampled indices only).
    interval : tuple of float or None
        Probabilistically symmetric 95 % interval of the sampled index.
    """

    value: float
    u: float
    u_noise: float
    u_sys: float
    U: float
    k: float = K_INDEX
    method: str = "monte-carlo"
    u_linear: float | None = None
    mean_draws: float | None = None
    interval: tuple[float, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict."""
        return {"value": self.value, "u": self.u, "u_noise": self.u_noise,
                "u_sys": self.u_sys, "U": self.U, "k": self.k, "method": self.method,
                "u_linear": self.u_linear, "mean_draws": self.mean_draws,
                "interval_95": None if self.interval is None else list(self.interval)}


@dataclass
class ModelUncertainty:
    """Uncertainty of the volumetric, straightness and squareness indices of a model.

    Attributes
    ----------
    volumetric : dict of str to IndexUncertainty
        ``E_VX`` ... ``E_VXYZ_range`` [um].
    straightness : dict of str to IndexUncertainty
        Straightness (range about the least-squares line over the travel) of each
        straightness function ``EYX``, ``EZX``, ``EXY``, ``EZY``, ``EXZ``, ``EYZ`` [um].
    squareness : dict of str to IndexUncertainty
        ``EC0Y``, ``EB0Z``, ``EA0Z`` [urad].
    draws : int
        Monte Carlo draws.
    systematic : bool
        Whether the model carries a systematic part.
    systematic_inputs : list of str
        Its inputs.
    notes : list of str
        What was done, in words.
    """

    volumetric: dict[str, IndexUncertainty]
    straightness: dict[str, IndexUncertainty]
    squareness: dict[str, IndexUncertainty]
    draws: int
    systematic: bool
    systematic_inputs: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def volumetric_keys(self) -> dict[str, float]:
        """``U_E_VX`` ... ``U_E_VXYZ_range`` [um] and ``k_volumetric``."""
        out: dict[str, float] = {f"U_{k}": v.U for k, v in self.volumetric.items()}
        out["k_volumetric"] = K_INDEX
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict (values [um], squareness [urad])."""
        return {"method": "GUM Supplement 1 (Monte Carlo) on the model's posterior; "
                          "squareness linear",
                "draws": self.draws, "k": K_INDEX, "systematic": self.systematic,
                "systematic_inputs": list(self.systematic_inputs),
                "volumetric": {k: v.to_dict() for k, v in self.volumetric.items()},
                "straightness": {k: {**v.to_dict(), "unit": "um"}
                                 for k, v in self.straightness.items()},
                "squareness": {k: {**v.to_dict(), "unit": "urad"}
                               for k, v in self.squareness.items()},
                "notes": list(self.notes)}


def has_covariance(result: Any) -> bool:
    """Whether a result carries what the U of its indices need (layout, free, factor).

    Parameters
    ----------
    result : object
        An identification result (or a stand-in without covariance).

    Returns
    -------
    bool
    """
    return all(getattr(result, a, None) is not None for a in ("layout", "free",
                                                                "cov_factor", "errors"))


def _full_factor(result: Any, part: str) -> NDArray[np.float64]:
    """Covariance factor of one part over the full parameter vector (fixed rows zero)."""
    free = np.asarray(result.free, dtype=np.intp)
    if part == "noise":  # the fit's statistical part: with the part between the readings
        g = np.asarray(result.statistical_factor(), dtype=float)
    else:
        sf = getattr(result, "sys_factor", None)
        g = np.zeros((free.size, 0)) if sf is None else np.asarray(sf, dtype=float)
    out = np.zeros((result.layout.size, g.shape[1]))
    out[free] = g
    return out


def _volumetric_of(e: NDArray[np.float64]) -> NDArray[np.float64]:
    """The five volumetric indices of each of ``k`` error fields, shape (m, 3, k) [um].

    ``e[:, :, t]`` is field ``t``. Returns an array of shape (k, 5): ``E_VX``, ``E_VY``,
    ``E_VZ``, ``E_VXYZ``, ``E_VXYZ_range`` of each field, the numbers
    :func:`volcal.standards.volumetric.volumetric_indices` gives for one (the lengths
    summed x, y, z in that order, as ``numpy.linalg.norm`` of a vector does).
    """
    from volcal.standards.volumetric import vector_ranges

    out = np.empty((e.shape[2], 5))
    out[:, :3] = np.ptp(e, axis=0).T
    sq = e * e
    out[:, 3] = np.sqrt(sq[:, 0] + sq[:, 1] + sq[:, 2]).max(axis=0)
    out[:, 4] = vector_ranges(e, draws_last=True)
    return out


def _straightness_of(d: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Range about the least-squares line of each column of deviations ``d`` at ``s``.

    ``d`` has shape (n, k) [um], ``s`` shape (n,) [mm]; the line of each column is
    ``numpy.polyfit(s, d[:, j], 1)`` (:func:`volcal.standards.linefit.line_fits`).
    """
    from volcal.standards.linefit import line_fits

    slope, icpt = line_fits(s, d)
    return np.asarray(np.ptp(d - (icpt[None, :] + slope[None, :] * s[:, None]), axis=0))


def _summary(value: float, total: NDArray[np.float64], noise: NDArray[np.float64],
             sys: NDArray[np.float64] | None, u_lin: float | None) -> IndexUncertainty:
    u_noise = float(np.std(noise, ddof=1))
    u_sys = 0.0 if sys is None else float(np.std(sys, ddof=1))
    # the parts in quadrature (GUM 5.1.2, independent parts): the joint draws' spread of
    # a maximum can fall when a part is added (module docstring); without a systematic
    # part ``total`` is the noise part's draws and this is their standard deviation
    u = float(np.std(total, ddof=1)) if sys is None else math.hypot(u_noise, u_sys)
    lo, hi = np.percentile(total, [2.5, 97.5])
    return IndexUncertainty(float(value), u, u_noise, u_sys, K_INDEX * u,
                            K_INDEX, "monte-carlo", u_lin, float(np.mean(total)),
                            (float(lo), float(hi)))


def straightness_functions() -> list[tuple[int, int, str]]:
    """(axis, component, name) of the six straightness functions (EYX, EZX, EXY, ...)."""
    return [(k, c, COMPONENT_NAMES[6 * k + c]) for k in range(3) for c in range(3) if c != k]


def model_uncertainty(result: Any, tool_offset: ArrayLike = (0.0, 0.0, 0.0), n: int = 11,
                      draws: int = 400, seed: int = 0) -> ModelUncertainty:
    """U of the volumetric indices, straightness and squareness of an identified model.

    Parameters
    ----------
    result : IdentificationResult
        Identified model (``errors``, ``layout``, ``free``, ``cov_factor`` and optionally
        ``sys_factor``).
    tool_offset : array_like, shape (3,)
        Tool point offset [mm] of the volumetric indices.
    n : int
        Grid points per axis of the volumetric indices (as
        :func:`volcal.standards.volumetric.volumetric_indices`).
    draws : int
        Monte Carlo draws of the posterior (at least 20).
    seed : int
        Seed of the draws (fixed: reproducible U).

    Returns
    -------
    ModelUncertainty

    Raises
    ------
    VolcalInputError
        The model has no uncertainty (a model file loaded without its binary part: the
        message names that file and why).

    Notes
    -----
    Straightness is evaluated at 101 points over the axis travel (the functions are
    linear between their nodes), with the least-squares reference line (ISO 230-1).
    """
    if hasattr(result, "require_uncertainty"):  # a model file without its binary part
        result.require_uncertainty("evaluating the model's volumetric indices, straightness "
                                   "and squareness with their U")
    key = _cache_key(result, tool_offset, n, draws, seed)
    hit = _CACHE.get(key[0])
    if hit is not None and hit[0]() is result and hit[1] == key[1:]:
        return hit[2]
    out = _model_uncertainty(result, tool_offset, n, draws, seed)
    if len(_CACHE) >= 4:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key[0]] = (weakref.ref(result), key[1:], out)
    return out


#: The last few evaluations, by result: the report, its certificate and the verdicts ask
#: for the same model's U; the draws are seeded, so a repeat gives the same numbers.
_CACHE: dict[int, tuple[Any, tuple[Any, ...], ModelUncertainty]] = {}


def _cache_key(result: Any, tool_offset: ArrayLike, n: int, draws: int, seed: int
               ) -> tuple[Any, ...]:
    """Identity of an evaluation: the result object and its arrays, the options."""
    arrays = (result.cov_factor, getattr(result, "sys_factor", None),
              getattr(result, "between_factor", None), result.free)
    return (id(result), *(id(a) for a in arrays),
            tuple(float(v) for v in np.asarray(tool_offset, dtype=float).ravel()),
            int(n), int(draws), int(seed))


def _model_uncertainty(result: Any, tool_offset: ArrayLike, n: int, draws: int, seed: int
                       ) -> ModelUncertainty:
    """:func:`model_uncertainty` without the cache."""
    from volcal.errors import VolcalInputError
    from volcal.model.errorfunctions import interp_weights
    from volcal.model.kinematics import pose_jacobian
    from volcal.standards.volumetric import volumetric_indices, work_zone_grid

    draws = int(draws)
    if draws < 20:
        raise VolcalInputError("model uncertainty: at least 20 Monte Carlo draws",
                               column="draws")
    rng = np.random.default_rng(seed)
    theta = np.asarray(result.theta, dtype=float)
    gn, gs = _full_factor(result, "noise"), _full_factor(result, "sys")
    has_sys = gs.shape[1] > 0
    zn = rng.standard_normal((gn.shape[1], draws))
    zs = rng.standard_normal((gs.shape[1], draws))
    dn = gn @ zn                                   # parameter draws, noise part
    ds = gs @ zs if has_sys else np.zeros_like(dn)  # systematic part
    errors = result.errors

    # ---- volumetric indices
    t = np.asarray(tool_offset, dtype=float)
    q = work_zone_grid(errors.travel, int(n))
    Je, _ = pose_jacobian(errors.chain_obj.order, result.layout.nodes, q, t)
    e0 = (Je @ theta).reshape(-1, 3)
    ind = volumetric_indices(errors, t, n)
    values = [ind.E_VX, ind.E_VY, ind.E_VZ, ind.E_VXYZ, ind.E_VXYZ_range]
    En, Es = np.asarray(Je @ dn), np.asarray(Je @ ds)

    def indices(*parts: NDArray[np.float64]) -> NDArray[np.float64]:
        """The five indices of every draw of ``e0 + sum(parts)``, shape (draws, 5) [um].

        The draws' error fields, (m, 3, draws) arrays, in blocks of ``DRAW_BLOCK`` draws
        (memory bounded by the block, not by the draws).
        """
        out = np.empty((draws, 5))
        for j in range(0, draws, DRAW_BLOCK):
            d = parts[0][:, j:j + DRAW_BLOCK]
            if len(parts) == 2:
                d = d + parts[1][:, j:j + DRAW_BLOCK]
            out[j:j + DRAW_BLOCK] = _volumetric_of((e0.reshape(-1, 1) + d).reshape(
                e0.shape[0], 3, -1))
        return out

    tot_a = indices(En, Es)
    # without a systematic part the draw is the noise part's (``Es`` is zero): the
    # same indices, not computed twice (half the time of ``history add``'s U)
    non_a = indices(En) if has_sys else tot_a
    sys_a = indices(Es) if has_sys else None
    lin = _linear_volumetric(e0, Je, np.hstack([gn, gs]))
    vol = {k: _summary(values[i], tot_a[:, i], non_a[:, i],
                       None if sys_a is None else sys_a[:, i], lin[i])
           for i, k in enumerate(VOLUMETRIC_KEYS)}

    # ---- straightness of each straightness function over its travel
    straight: dict[str, IndexUncertainty] = {}
    for k, c, name in straightness_functions():
        lo, hi = errors.travel[k]
        s = np.linspace(lo, hi, 101)
        i0, i1, w = interp_weights(result.layout.nodes[k], s)
        idx = result.layout.indices(k, c)

        def along(vec: NDArray[np.float64], idx: Any = idx, i0: Any = i0, i1: Any = i1,
                  w: Any = w) -> NDArray[np.float64]:
            v = vec[idx]
            return (1 - w)[:, None] * v[i0] + w[:, None] * v[i1] if v.ndim == 2 else \
                (1 - w) * v[i0] + w * v[i1]

        d0 = along(theta)
        dN, dS = along(dn), along(ds)
        val = float(_straightness_of(d0[:, None], s)[0])
        st = _straightness_of(d0[:, None] + dN + dS, s)
        sn = _straightness_of(d0[:, None] + dN, s)
        ss = _straightness_of(d0[:, None] + dS, s) if has_sys else None
        slope, icpt = np.polyfit(s, d0, 1)
        r = d0 - (icpt + slope * s)
        a, b = int(np.argmax(r)), int(np.argmin(r))
        # first order: residual of the extremes; the LS projector is linear
        X = np.stack([np.ones_like(s), s], axis=1)
        P = np.eye(s.size) - X @ np.linalg.pinv(X)
        gl = (P[a] - P[b]) @ along(np.hstack([gn, gs]))
        straight[name] = _summary(val, st, sn, ss, float(np.linalg.norm(gl)))

    # ---- squareness: a parameter, exact
    square: dict[str, IndexUncertainty] = {}
    sq_idx = result.layout.squareness_indices()
    for i, name in enumerate(SQUARENESS_NAMES):
        un = float(np.linalg.norm(gn[sq_idx[i]]))
        us = float(np.linalg.norm(gs[sq_idx[i]])) if has_sys else 0.0
        u = math.hypot(un, us)
        square[name] = IndexUncertainty(float(errors.squareness[i]), u, un, us, K_INDEX * u,
                                        K_INDEX, "linear")

    labels = list(getattr(result, "sys_labels", []) or [])
    notes = [f"volumetric indices and straightness: {draws} draws of the model's posterior "
             "(GUM Supplement 1), U = 2 u; squareness: linear, U = 2 u"]
    if has_sys:
        notes.append(f"the model's systematic part ({describe_inputs(labels)}) is included")
    else:
        notes.append("the model carries no systematic part: U is the identification's "
                     "noise and prior part only (identify with --budget to include the "
                     "laser, air and material inputs)")
    return ModelUncertainty(vol, straight, square, draws, has_sys, labels, notes)


def describe_inputs(labels: list[str]) -> str:
    """Systematic inputs in a few words: ``laser wavelength; air (17 set-ups); material X, Y, Z``.

    Parameters
    ----------
    labels : list of str
        Input labels of the systematic part (``'laser wavelength'``, ``'air, <id>'``,
        ``'material, <axis>'``).

    Returns
    -------
    str
    """
    air = [x for x in labels if x.startswith("air, ")]
    mat = [x.split(", ", 1)[1] for x in labels if x.startswith("material, ")]
    other = [x for x in labels if not x.startswith(("air, ", "material, "))]
    parts = list(other)
    if air:
        parts.append(f"air ({len(air)} set-up{'s' if len(air) > 1 else ''})")
    if mat:
        parts.append("material " + ", ".join(mat))
    return "; ".join(parts)


def _linear_volumetric(e0: NDArray[np.float64], Je: Any, g: NDArray[np.float64]
                       ) -> list[float]:
    """First-order u of each volumetric index at the estimate's extreme points [um]."""
    from volcal.standards.volumetric import vector_range_pair

    out = []
    for c in range(3):
        a, b = int(np.argmax(e0[:, c])), int(np.argmin(e0[:, c]))
        row = Je[3 * a + c] - Je[3 * b + c]
        out.append(float(np.linalg.norm(np.asarray(row @ g).ravel())))
    norms = np.linalg.norm(e0, axis=1)
    k = int(np.argmax(norms))
    if norms[k] > 0:
        dirn = e0[k] / norms[k]
        row = sum(dirn[c] * Je[3 * k + c] for c in range(3))
        out.append(float(np.linalg.norm(np.asarray(row @ g).ravel())))
    else:
        out.append(0.0)
    i, j = vector_range_pair(e0)
    diff = e0[i] - e0[j]
    dl = float(np.linalg.norm(diff))
    if dl > 0:
        dirn = diff / dl
        row = sum(dirn[c] * (Je[3 * i + c] - Je[3 * j + c]) for c in range(3))
        out.append(float(np.linalg.norm(np.asarray(row @ g).ravel())))
    else:
        out.append(0.0)
    return out


def largest_length(result: Any, q: ArrayLike, correction: ArrayLike | None = None,
                   draws: int = 400, seed: int = 0) -> IndexUncertainty:
    """U of the largest length of the modelled volumetric error over points, ``max |e|``.

    The volumetric tolerance of a verdict (``V``) is checked against this quantity,
    before compensation and, with ``correction``, after (the error the tables leave).

    Parameters
    ----------
    result : IdentificationResult
        Identified model.
    q : array_like, shape (m, 3)
        Points [mm] (the work zone grid of the verdict).
    correction : array_like, shape (m, 3), optional
        What compensation tables remove at ``q`` [um]: the value is then
        ``max |e - correction|`` (the tables are fixed numbers, the model is uncertain).
    draws : int
        Monte Carlo draws of the posterior (GUM Supplement 1, as :func:`model_uncertainty`).
    seed : int
        Seed of the draws.

    Returns
    -------
    IndexUncertainty
        ``value`` (of the model), ``u``, ``u_noise``, ``u_sys``, ``U = 2 u`` [um].
    """
    from volcal.model.kinematics import pose_jacobian

    q = np.asarray(q, dtype=float).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    gn, gs = _full_factor(result, "noise"), _full_factor(result, "sys")
    has_sys = gs.shape[1] > 0
    Je, _ = pose_jacobian(result.errors.chain_obj.order, result.layout.nodes, q, None)
    e0 = (Je @ np.asarray(result.theta, dtype=float)).reshape(-1, 3)
    if correction is not None:
        e0 = e0 - np.asarray(correction, dtype=float).reshape(-1, 3)
    En = np.asarray(Je @ (gn @ rng.standard_normal((gn.shape[1], draws))))
    Es = (np.asarray(Je @ (gs @ rng.standard_normal((gs.shape[1], draws)))) if has_sys
          else np.zeros_like(En))

    def lmax(d: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.linalg.norm(e0[:, :, None] + d.reshape(-1, 3, draws), axis=1).max(axis=0)

    value = float(np.linalg.norm(e0, axis=1).max())
    k = int(np.argmax(np.linalg.norm(e0, axis=1)))
    dirn = e0[k] / max(float(np.linalg.norm(e0[k])), 1e-300)
    row = sum(dirn[c] * Je[3 * k + c] for c in range(3))
    u_lin = float(np.linalg.norm(np.asarray(row @ np.hstack([gn, gs])).ravel()))
    return _summary(value, lmax(En + Es), lmax(En), lmax(Es) if has_sys else None, u_lin)


def function_parts(result: Any) -> list[dict[str, Any]]:
    """Noise and systematic parts of the identification's u, per function, at its worst node.

    Parameters
    ----------
    result : IdentificationResult
        Identified model.

    Returns
    -------
    list of dict
        One per error function (and squareness): ``name``, ``unit``, ``node_mm`` (the
        node of the largest total u; None for squareness), ``u_noise``, ``u_sys``,
        ``u_total`` (``sqrt(u_noise^2 + u_sys^2)``) [um or urad].
    """
    from volcal.model.names import info

    rows = []
    for idx, name in enumerate(COMPONENT_NAMES):
        k = idx // 6
        nodes = np.asarray(result.layout.nodes[k], dtype=float)
        ut = np.asarray(result.function_std(name, nodes, systematic=True))
        un = np.asarray(result.function_std(name, nodes, systematic=False))
        j = int(np.argmax(ut))
        rows.append({"name": name, "axis": AXES[k], "unit": info(name).unit_symbol,
                     "node_mm": float(nodes[j]), "u_noise": float(un[j]),
                     "u_sys": float(math.sqrt(max(ut[j] ** 2 - un[j] ** 2, 0.0))),
                     "u_total": float(ut[j])})
    for name in SQUARENESS_NAMES:
        u_total = float(np.asarray(result.function_std(name, [0.0], systematic=True))[0])
        u_noise = float(np.asarray(result.function_std(name, [0.0], systematic=False))[0])
        rows.append({"name": name, "axis": "", "unit": info(name).unit_symbol,
                     "node_mm": None, "u_noise": u_noise,
                     "u_sys": math.sqrt(max(u_total**2 - u_noise**2, 0.0)), "u_total": u_total})
    return rows
