"""Machine families for the estimator's robustness study (issue 19, item 1).

volcal's own study (``benchmarks/study.py``) draws its machines from one family,
:func:`volcal.measure.virtual.random_machine` (sine modes, rolls always present,
straightness zero at both ends). A prior tuned on one family can fail on another, so this
module writes several families of machines from a *physical description* each, in small
generators of their own (analytic functions of the axis position, tabulated finely for
the exact simulator), and measures the default estimator on every family against

* minimum-norm least squares on the same data (``prior='none'``), and
* **the limit**: the best linear estimator that knows the family's generator, i.e. the
  Bayesian linear posterior mean with the family's prior mean and covariance of the
  error-function parameters (estimated from :data:`N_DRAWS` draws of the family, mapped
  into volcal's gauge and sampled at the estimator's nodes), the true reading noise
  (0.5 um), the true prior of the set-up tilts (20 urad per component: 20 urad of mirror
  and 20 urad of beam misalignment in random directions) and flat priors on the other
  nuisances (offsets, reversals), on the same design matrix as volcal.

Families (:data:`FAMILIES`; magnitudes are peak to valley over the travel unless said
otherwise, "um/m" terms grow with the travel):

``a`` -- today's
    :func:`volcal.measure.virtual.random_machine`: positioning 5-20 um, straightness
    3-10 um (zero at both ends), angular 5-30 urad, squareness +-50 urad.
``b`` -- polynomial, no roll
    Legendre polynomials of degree 2-4 (positioning, straightness) and 1-3 (pitch, yaw):
    positioning 2-8 um on top of a scale error of +-10 um/m, straightness 2-10 um and
    free at both ends, with the squareness as a linear term of the straightness of the
    second axis of each pair (+-40 um/m, i.e. urad; squareness parameters zero), pitch and
    yaw 5-30 urad, no roll (EAX = EBY = ECZ = 0).
``c`` -- polynomial with roll
    ``b`` plus rolls of degree 1-3, 5-30 urad.
``d`` -- ball-screw cyclic error
    ``c`` with a smooth positioning (degree 2-3, 2-6 um, scale error +-10 um/m) plus the
    screw's cyclic error ``A sin(2 pi x / p + phi)``: period ``p`` 5-20 mm (the lead),
    amplitude ``A`` 0.5-2 um, per axis. At increments that are no multiple of the period
    it looks like noise to every estimator; what matters is that coverage stays honest.
``e`` -- guideway joint
    ``c`` plus, on one straightness or one tilt (pitch or yaw) of one axis, a change of
    slope at a random position (20-80 % of the travel): 10-40 um/m for a straightness,
    10-40 urad per travel for a tilt (two rail segments meeting at an angle).
``f`` -- large thermal scale error
    ``c`` with the positioning scale errors 10-30 um/m of one sign on all three axes
    (a machine 1-3 K warmer than its scales, uncompensated).

Each generator returns an :class:`AnalyticMachine` (analytic functions; :meth:`tabulate`
gives volcal's :class:`~volcal.model.errorfunctions.MachineErrors` on any nodes, finely
for the exact simulator, at the estimator's nodes for the limit's prior).

Gauge: the families do not follow volcal's gauge (every function zero at the start of
travel, straightness also at the end). :func:`gauge_map` maps a machine into it by adding
the combination of constants and linear terms (and squareness) that changes no reading
(it only moves the volumetric error field by a rigid-body motion) and makes the gauge's
zeros hold; the residuals are compared with the rigid-body motion removed anyway.

Command line::

    python benchmarks/families.py --machines 20 --markdown
    python benchmarks/families.py --family b,d --design full --machines 4

References
----------
Issue 19 of the project. Slocum, A.H., *Precision Machine Design*, Prentice Hall 1992
(ball-screw lead errors, guideway joints); ISO 230-2:2014 (scale errors, thermal
expansion 11.5 um/m/K of steel).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import scipy.linalg as sla
from numpy.polynomial import legendre
from numpy.typing import NDArray

from volcal.identify import IdentifyOptions, identify
from volcal.identify.design import build_design, choose_nodes
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.chain import parse_chain
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import pose_jacobian, volumetric_error
from volcal.model.names import COMPONENT_NAMES
from volcal.model.parameters import ParameterLayout
from volcal.model.rigid import remove_rigid_body
from volcal.plan.planner import plan_session
from volcal.standards.volumetric import work_zone_grid

__all__ = ["FAMILIES", "AnalyticMachine", "Family", "FamilyResult", "Limit", "gauge_map",
           "run_family", "summarise"]

MASTER_SEED = 20261124
"""Seed of the study's machine sequence (chains, machine and simulation seeds)."""
PRIOR_SEED = 777_019
"""Seed of the draws that estimate the limit's prior (independent of the machines)."""
N_DRAWS = 4000
"""Draws of a family for the limit's prior mean and covariance."""
NOISE_UM = 0.5
TILT_URAD = 20.0
"""Standard deviation of each set-up tilt component the study simulates [urad]: 20 urad
of flat-mirror and 20 urad of beam misalignment, each in a random direction
perpendicular to the beam (variance 20^2 / 2 per component each)."""
CHAINS: tuple[str, ...] = ("XYFZ", "FXYZ", "XFYZ", "YFXZ")
TRAVELS = {"full": ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0)),
           "long": ((0.0, 3000.0), (0.0, 800.0), (0.0, 600.0))}
"""The seeds' full test set on the 800 x 600 x 500 machine and on the long machine."""
TESTS = ("step-diagonal", "diagonal", "linear")
ROLLS = (3, 10, 17)
CACHE: Path | None = None
"""Directory where the limit's prior (mean and covariance per family, design and chain) is
kept between runs (``--cache``); None: computed every time."""
"""``6 * axis + component`` of EAX, EBY, ECZ."""


# ----------------------------------------------------------------------------- machines
Func = Callable[[NDArray[np.float64]], NDArray[np.float64]]


@dataclass
class AnalyticMachine:
    """A machine given by analytic error functions of the axis positions.

    Attributes
    ----------
    chain : str
        Chain code.
    travel : ndarray, shape (3, 2)
        Travel limits [mm].
    functions : dict of int to callable
        ``6 * axis + component`` -> ``f(x_mm) -> values`` [um or urad]; absent: zero.
    squareness : ndarray, shape (3,)
        EC0Y, EB0Z, EA0Z [urad].
    spacing_mm : float
        Node spacing of :meth:`tabulate` for the simulator [mm] (fine enough for linear
        interpolation to follow the shortest wavelength).
    """

    chain: str
    travel: NDArray[np.float64]
    functions: dict[int, Func]
    squareness: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    spacing_mm: float = 2.0

    def tabulate(self, nodes: Sequence[NDArray[np.float64]] | None = None) -> MachineErrors:
        """The machine as volcal's tabulated error functions.

        Parameters
        ----------
        nodes : list of 3 arrays, optional
            Node positions per axis [mm]; default a uniform grid of :attr:`spacing_mm`.

        Returns
        -------
        MachineErrors
        """
        t = np.asarray(self.travel, dtype=float)
        if nodes is None:
            nodes = [np.linspace(t[k, 0], t[k, 1],
                                 int(np.ceil((t[k, 1] - t[k, 0]) / self.spacing_mm)) + 1)
                     for k in range(3)]
        values = []
        for k in range(3):
            x = np.asarray(nodes[k], dtype=float)
            v = np.zeros((x.size, 6))
            for c in range(6):
                f = self.functions.get(6 * k + c)
                if f is not None:
                    v[:, c] = f(x)
            values.append(v)
        return MachineErrors(self.chain, [np.asarray(n, float) for n in nodes], values,
                             self.squareness.copy(), name="family machine")


def _poly(rng: np.random.Generator, lo: float, span: float, degrees: tuple[int, int],
          ptp: float) -> Func:
    """Random Legendre polynomial on ``[lo, lo + span]`` with peak to valley ``ptp``.

    Degree drawn in ``degrees`` (inclusive); coefficients N(0, 1/j) for j >= 1 (higher
    orders smaller), scaled to the peak to valley, plus a constant uniform in
    ``+-ptp / 2`` (the function is free at both ends, its offset of the same size as its
    variation).
    """
    deg = int(rng.integers(degrees[0], degrees[1] + 1))
    coef = np.zeros(deg + 1)
    coef[1:] = rng.normal(size=deg) / np.arange(1, deg + 1)
    s = np.linspace(-1, 1, 201)
    p = np.ptp(legendre.legval(s, coef))
    coef = coef * (ptp / p if p > 0 else 0.0)
    coef[0] = rng.uniform(-0.5, 0.5) * ptp
    return lambda x: legendre.legval(2 * (np.asarray(x) - lo) / span - 1, coef)


def _linear(lo: float, slope: float) -> Func:
    """``slope * (x - lo)`` with ``slope`` in [um or urad per mm]."""
    return lambda x: slope * (np.asarray(x) - lo)


def _sum(*fs: Func) -> Func:
    return lambda x: sum(f(x) for f in fs)


def _tilt_names(k: int) -> tuple[int, int]:
    """The two tilts (pitch and yaw) of axis ``k`` as component indices."""
    return tuple(c for c in (3, 4, 5) if c - 3 != k)  # type: ignore[return-value]


def _straight_names(k: int) -> tuple[int, int]:
    return tuple(c for c in (0, 1, 2) if c != k)  # type: ignore[return-value]


SQUARENESS_AS_STRAIGHTNESS = {0: (1, 0), 1: (0, 2), 2: (1, 2)}
"""Which straightness carries each squareness as a linear term: EC0Y -> EXY (axis Y,
component X), EB0Z -> EXZ, EA0Z -> EYZ (``(axis, component)``)."""


def draw_polynomial(rng: np.random.Generator, travel, chain: str, rolls: bool = True,
                    scale_um_per_m: tuple[float, float] = (-10.0, 10.0),
                    positioning_ptp: tuple[float, float] = (2.0, 8.0),
                    positioning_degrees: tuple[int, int] = (2, 4)) -> AnalyticMachine:
    """Families ``b`` (``rolls=False``) and ``c``: polynomial error functions.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    chain : str
        Chain code.
    rolls : bool
        Draw the rolls (5-30 urad); False: EAX = EBY = ECZ = 0.
    scale_um_per_m : (float, float)
        Range of each axis' positioning scale error [um/m], uniform.
    positioning_ptp : (float, float)
        Peak to valley of the positioning polynomial on top of the scale error [um].
    positioning_degrees : (int, int)
        Degrees of the positioning polynomial.

    Returns
    -------
    AnalyticMachine
        Positioning = scale error + polynomial; straightness 2-10 um, degree 2-4, free at
        both ends, the squareness errors (+-40 urad) as linear terms of the straightness
        of :data:`SQUARENESS_AS_STRAIGHTNESS`; pitch and yaw 5-30 urad, degree 1-3.
    """
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    fs: dict[int, Func] = {}
    for k in range(3):
        lo, span = t[k, 0], t[k, 1] - t[k, 0]
        fs[6 * k + k] = _sum(_linear(lo, rng.uniform(*scale_um_per_m) * 1e-3),
                             _poly(rng, lo, span, positioning_degrees,
                                   rng.uniform(*positioning_ptp)))
        for c in _straight_names(k):
            fs[6 * k + c] = _poly(rng, lo, span, (2, 4), rng.uniform(2.0, 10.0))
        for c in _tilt_names(k):
            fs[6 * k + c] = _poly(rng, lo, span, (1, 3), rng.uniform(5.0, 30.0))
        if rolls:
            fs[6 * k + 3 + k] = _poly(rng, lo, span, (1, 3), rng.uniform(5.0, 30.0))
    for k, c in SQUARENESS_AS_STRAIGHTNESS.values():
        fs[6 * k + c] = _sum(fs[6 * k + c], _linear(t[k, 0], rng.uniform(-40, 40) * 1e-3))
    return AnalyticMachine(chain, t, fs)


def draw_today(rng: np.random.Generator, travel, chain: str) -> AnalyticMachine:
    """Family ``a``: :func:`volcal.measure.virtual.random_machine` (41 nodes per axis)."""
    m = random_machine(travel, chain, seed=int(rng.integers(2**31)))
    fs = {6 * k + c: (lambda x, k=k, c=c: m.component(k, x)[:, c])
          for k in range(3) for c in range(6)}
    return AnalyticMachine(chain, np.asarray(travel, float), fs, m.squareness.copy(),
                           spacing_mm=float(np.min([np.diff(n).min() for n in m.nodes])))


def draw_cyclic(rng: np.random.Generator, travel, chain: str) -> AnalyticMachine:
    """Family ``d``: smooth positioning plus the ball screw's cyclic error.

    Positioning: scale error +-10 um/m, polynomial of degree 2-3 (2-6 um), plus
    ``A sin(2 pi (x - x0) / p + phi)`` with lead ``p`` 5-20 mm and amplitude ``A``
    0.5-2 um per axis; the other functions as family ``c``. Tabulated at a twentieth of
    the shortest period.
    """
    m = draw_polynomial(rng, travel, chain, rolls=True, positioning_ptp=(2.0, 6.0),
                        positioning_degrees=(2, 3))
    t = m.travel
    shortest = np.inf
    for k in range(3):
        p = rng.uniform(5.0, 20.0)
        a = rng.uniform(0.5, 2.0)
        phi = rng.uniform(0, 2 * np.pi)
        lo = t[k, 0]
        m.functions[7 * k] = _sum(m.functions[7 * k],
                                  lambda x, p=p, a=a, phi=phi, lo=lo:
                                  a * np.sin(2 * np.pi * (np.asarray(x) - lo) / p + phi))
        shortest = min(shortest, p)
    m.spacing_mm = shortest / 20.0
    return m


def draw_joint(rng: np.random.Generator, travel, chain: str) -> AnalyticMachine:
    """Family ``e``: family ``c`` plus a guideway joint.

    On one function drawn among the straightness and tilt functions of one axis, a change
    of slope at a random position (20-80 % of the travel): 10-40 um/m for a straightness,
    10-40 urad over the rest of the travel for a tilt, either sign.
    """
    m = draw_polynomial(rng, travel, chain, rolls=True)
    t = m.travel
    k = int(rng.integers(3))
    c = int(rng.choice([*_straight_names(k), *_tilt_names(k)]))
    lo, span = t[k, 0], t[k, 1] - t[k, 0]
    xj = lo + rng.uniform(0.2, 0.8) * span
    size = rng.uniform(10.0, 40.0) * rng.choice([-1.0, 1.0])
    slope = size * 1e-3 if c < 3 else size / (lo + span - xj)
    m.functions[6 * k + c] = _sum(m.functions[6 * k + c],
                                  lambda x: slope * np.maximum(np.asarray(x) - xj, 0.0))
    m.spacing_mm = 1.0
    return m


def draw_thermal(rng: np.random.Generator, travel, chain: str) -> AnalyticMachine:
    """Family ``f``: family ``c`` with scale errors of 10-30 um/m of one sign on every axis."""
    sign = float(rng.choice([-1.0, 1.0]))
    lo, hi = (10.0, 30.0) if sign > 0 else (-30.0, -10.0)
    return draw_polynomial(rng, travel, chain, rolls=True, scale_um_per_m=(lo, hi))


@dataclass(frozen=True)
class Family:
    """A family of machines.

    Attributes
    ----------
    name : str
        One letter (issue 19's list).
    description : str
        One line for tables.
    draw : callable
        ``draw(rng, travel, chain) -> AnalyticMachine``.
    """

    name: str
    description: str
    draw: Callable[..., AnalyticMachine]


FAMILIES: dict[str, Family] = {f.name: f for f in (
    Family("a", "today's (random_machine: sine modes, rolls, straightness 0 at the ends)",
           draw_today),
    Family("b", "polynomials, no roll, straightness free, squareness in straightness, "
           "scale +-10 um/m", lambda rng, t, ch: draw_polynomial(rng, t, ch, rolls=False)),
    Family("c", "b with rolls", draw_polynomial),
    Family("d", "c with ball-screw cyclic errors (5-20 mm, 0.5-2 um)", draw_cyclic),
    Family("e", "c with a guideway joint (change of slope)", draw_joint),
    Family("f", "c with thermal scale errors 10-30 um/m, one sign", draw_thermal),
)}


# ----------------------------------------------------------------------------- gauge
def _gauge_basis(chain: str, travel: NDArray[np.float64]):
    """Null directions of the readings among constants, linear terms and squareness.

    On a two-node layout per axis (start and end of travel) every direction is a constant
    or linear term of one function (or a squareness); the directions that change the
    volumetric error only by a rigid-body motion and the orientation error only by a
    constant are invisible to every relative reading (a constant orientation error moves
    the target of a tool offset by a constant within each test, which the test's reading
    offset absorbs; the flat mirror sees orientation differences only). Returns the
    layout and a basis of those directions (columns).
    """
    layout = ParameterLayout(tuple(np.asarray(travel[k], dtype=float) for k in range(3)))
    g = np.stack(np.meshgrid(*[np.linspace(travel[k, 0], travel[k, 1], 4) for k in range(3)],
                             indexing="ij"), -1).reshape(-1, 3)
    order = parse_chain(chain).order
    from volcal.model.rigid import _design as rigid_design

    Je, Jo = pose_jacobian(order, list(layout.nodes), g)
    E, O3 = Je.toarray(), Jo.toarray()
    R = rigid_design(g)
    C = np.zeros((O3.shape[0], 3))
    for c in range(3):
        C[c::3, c] = 1.0
    # e = t + W x q (rigid), w = any constant: a constant orientation error moves the tool
    # point of a tool offset by a constant, which each test's reading offset absorbs
    M = np.vstack([np.hstack([E, -R, np.zeros((E.shape[0], 3))]),
                   np.hstack([O3, np.zeros((O3.shape[0], 6)), -C])])
    _, s, vt = np.linalg.svd(M)
    tol = s.max() * 1e-10
    null = vt[np.sum(s > tol):].T
    return layout, null[:layout.size]


_GAUGE_CACHE: dict = {}


def gauge_map(m: MachineErrors) -> MachineErrors:
    """The same machine in volcal's gauge (no reading changes; volumetric error up to a
    rigid-body motion).

    Adds the invisible combination of constants, linear terms and squareness (see
    :func:`_gauge_basis`) for which every function is zero at the start of its travel and
    each straightness also at the end (``docs/identification.md``, section 2).

    Parameters
    ----------
    m : MachineErrors
        Any machine.

    Returns
    -------
    MachineErrors
        Same nodes, gauge-fixed values and squareness.
    """
    travel = m.travel
    key = (m.chain_obj.code, tuple(travel.ravel()))
    if key not in _GAUGE_CACHE:
        _GAUGE_CACHE[key] = _gauge_basis(m.chain_obj.code, travel)
    layout, N = _GAUGE_CACHE[key]
    # constraint rows on the two-node layout: start of every function, end of straightness
    rows, target = [], []
    for k in range(3):
        for c in range(6):
            idx = layout.indices(k, c)
            rows.append(idx[0])
            target.append(-m.values[k][0, c])
            if c < 3 and c != k:
                rows.append(idx[1])
                target.append(-m.values[k][-1, c])
    z, *_ = np.linalg.lstsq(N[rows], np.array(target), rcond=None)
    d = N @ z
    values = []
    for k in range(3):
        x = m.nodes[k]
        s = (x - x[0]) / (x[-1] - x[0])
        v = m.values[k].copy()
        for c in range(6):
            a, b = d[layout.indices(k, c)]
            v[:, c] += a + (b - a) * s
        values.append(v)
    return MachineErrors(m.chain, [n.copy() for n in m.nodes], values,
                         m.squareness + d[layout.squareness_indices()], m.reversal.copy(),
                         m.name)


# ----------------------------------------------------------------------------- the limit
@dataclass
class Limit:
    """The best linear estimator knowing a family's generator, on one design.

    Attributes
    ----------
    design : Design
        volcal's observation system of the planned session (same nodes as the estimator).
    mean : ndarray
        Prior mean of the free parameters (gauge-mapped draws at the nodes).
    gain : ndarray
        ``S A_f' U (U' (A_f S A_f' + tau^2 A_t A_t' + s^2 I) U)^-1 U'``: the posterior
        mean is ``mean + gain (y - A_f mean)``; ``U`` spans the complement of the flat
        nuisances' columns (offsets, reversals), ``A_t`` the set-up tilts' columns.
    """

    design: object
    mean: NDArray[np.float64]
    gain: NDArray[np.float64]

    def estimate(self, y: NDArray[np.float64]) -> MachineErrors:
        """Posterior mean of the functions for readings ``y`` (design order) [um]."""
        d = self.design
        Af = d.A[:, :d.n_free]
        x = self.mean + self.gain @ (y - Af @ self.mean)
        return d.layout.unpack(d.full_parameters(x), d.chain)


def build_limit(family: Family, travel, chain: str, session, n_draws: int = N_DRAWS,
                seed: int = PRIOR_SEED) -> Limit:
    """Estimate the family's prior at the estimator's nodes and form the limit's gain.

    Parameters
    ----------
    family : Family
        The generator.
    travel : array_like, shape (3, 2)
        Travel [mm].
    chain : str
        Chain code.
    session : Session
        Planned session (positions; deviations not used).
    n_draws : int
        Draws of the family.
    seed : int
        Seed of the draws.

    Returns
    -------
    Limit
    """
    from copy import copy

    s = copy(session)
    s.measurements = [copy(m) for m in session.measurements]
    for m in s.measurements:
        m.deviation = np.zeros(m.n)
    nodes = choose_nodes(s, refine=IdentifyOptions().refine, max_nodes=IdentifyOptions().max_nodes)
    design = build_design(s, nodes)
    import hashlib

    where = hashlib.sha256(np.concatenate(nodes).round(6).tobytes()).hexdigest()[:10]
    key = (f"{family.name}-{chain}-{'x'.join(f'{v:g}' for v in np.ravel(travel))}-"
           f"{'x'.join(str(len(n)) for n in nodes)}-{where}-{n_draws}-{seed}")
    path = CACHE / f"prior-{key}.npz" if CACHE is not None else None
    if path is not None and path.exists():
        with np.load(path) as z:
            mean, S = z["mean"], z["cov"]
    else:
        rng = np.random.default_rng(seed)
        X = np.empty((n_draws, design.n_free))
        for i in range(n_draws):
            am = family.draw(rng, travel, chain)
            X[i] = design.layout.pack(gauge_map(am.tabulate(nodes)))[design.free]
        mean = X.mean(0)
        S = np.cov(X, rowvar=False)
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            np.savez(path, mean=mean, cov=S)
    nf = design.n_free
    A = design.A.toarray()
    Af, An = A[:, :nf], A[:, nf:]
    kinds = [n.rsplit(":", 1)[1] for n in design.nuisance_names]
    tilt = np.array([k.startswith("tilt") for k in kinds])
    Aflat = An[:, ~tilt]
    qf, _ = np.linalg.qr(Aflat, mode="complete")
    U = qf[:, np.linalg.matrix_rank(Aflat):]
    At = An[:, tilt]
    C = Af @ S @ Af.T + TILT_URAD**2 * (At @ At.T) + NOISE_UM**2 * np.eye(A.shape[0])
    Cu = U.T @ C @ U
    cf = sla.cho_factor(Cu)
    gain = (S @ Af.T @ U) @ sla.cho_solve(cf, U.T)
    return Limit(design, mean, gain)


# ----------------------------------------------------------------------------- study
@dataclass(frozen=True)
class Case:
    """One machine of a family: index, chain, machine seed, simulation seed."""

    index: int
    chain: str
    machine_seed: int
    sim_seed: int


def cases(n: int, master_seed: int = MASTER_SEED) -> list[Case]:
    """The first ``n`` machines of the study (chains and seeds from a fixed generator)."""
    rng = np.random.default_rng(master_seed)
    return [Case(i, str(CHAINS[int(rng.integers(len(CHAINS)))]), int(rng.integers(2**31)),
                 int(rng.integers(2**31))) for i in range(n)]


@dataclass
class FamilyResult:
    """Figures of one machine of one family on one design (see :func:`run_case`)."""

    family: str
    design: str
    case: Case
    truth_rms_um: float
    bayes: dict = field(default_factory=dict)
    min_norm: dict = field(default_factory=dict)
    limit_rms_um: float = float("nan")

    @property
    def ratio_ls(self) -> float:
        """Volcal's residual over minimum-norm least squares'."""
        return self.bayes["rms_um"] / max(self.min_norm["rms_um"], 1e-12)

    @property
    def ratio_limit(self) -> float:
        """Volcal's residual over the limit's."""
        return self.bayes["rms_um"] / max(self.limit_rms_um, 1e-12)


def evaluate(result, truth_g: MachineErrors, q: NDArray[np.float64], rigid: bool = True
             ) -> dict:
    """Compare an identification with the gauge-mapped truth.

    Returns ``rms_um``, ``max_um`` (rigid-body motion removed), ``coverage`` (95 %
    intervals of ``predict`` against the truth in volcal's gauge), ``coverage_rigid``
    (gauge-invariant: the rigid-body motion removed from the difference *and* from the
    uncertainty, i.e. ``u`` of the projected prediction), and the edge figures: per
    function node, whether the truth lies within 2 standard uncertainties, pooled over
    the interior nodes (``inner_in``, ``inner_n``) and over the last node of each function
    the gauge does not pin (positioning, rolls, tilts: ``edge_in``, ``edge_n``).
    """
    e, u = result.predict(q)
    et = volumetric_error(truth_g, q)
    d = e - et
    dr = remove_rigid_body(q, d)
    length = np.linalg.norm(dr, axis=1)
    out = {"rms_um": float(np.sqrt(np.mean(length**2))), "max_um": float(length.max()),
           "coverage": float(np.mean(np.abs(d) <= 1.96 * u))}
    if rigid:
        _, ur = result.predict(q, rigid_removed=True)
        out["coverage_rigid"] = float(np.mean(np.abs(dr) <= 1.96 * ur))
    inner_in = inner_n = edge_in = edge_n = 0
    worst = (0.0, "")
    for j, name in enumerate(COMPONENT_NAMES):
        k, c = divmod(j, 6)
        x = result.layout.nodes[k]
        est = result.errors.function(name, x)
        tru = truth_g.function(name, x)
        sd = result.function_std(name, x)
        ok = np.abs(est - tru) <= 2.0 * sd
        inner_in += int(ok[1:-1].sum())
        inner_n += ok[1:-1].size
        if not (c < 3 and c != k):
            edge_in += int(ok[-1])
            edge_n += 1
            z = abs(est[-1] - tru[-1]) / max(sd[-1], 1e-12)
            if z > worst[0]:
                worst = (float(z), name)
    out.update(inner_in=inner_in, inner_n=inner_n, edge_in=edge_in, edge_n=edge_n,
               edge_worst_z=worst[0], edge_worst=worst[1])
    return out


def _sim_options(seed: int) -> SimulationOptions:
    return SimulationOptions(noise_um=NOISE_UM, mirror_misalignment_urad=20.0,
                             beam_misalignment_urad=20.0, dwell_s=4.0, seed=seed)


def run_case(family: Family, design: str, case: Case, limit: Limit | None, steps: int = 10,
             runs: int = 5, n_grid: int = 9, options: IdentifyOptions | None = None,
             least_squares: bool = True) -> FamilyResult:
    """Draw one machine of a family, simulate the full test set, identify and compare.

    Parameters
    ----------
    family : Family
        The family.
    design : str
        ``'full'`` or ``'long'`` (:data:`TRAVELS`).
    case : Case
        The machine.
    limit : Limit or None
        The family's limit on this design and chain (None: not computed).
    steps, runs, n_grid : int
        Increments per test, bidirectional runs per line, grid points per axis.
    options : IdentifyOptions, optional
        Options of the default estimator.
    least_squares : bool
        Identify with minimum-norm least squares too (``min_norm``; False: left empty).

    Returns
    -------
    FamilyResult
    """
    travel = np.array(TRAVELS[design])
    am = family.draw(np.random.default_rng(case.machine_seed), travel, case.chain)
    truth = am.tabulate()
    session = plan_session(travel, case.chain, steps, TESTS, runs=runs)
    simulate_session(session, truth, _sim_options(case.sim_seed))
    q = work_zone_grid(travel, n_grid)
    truth_g = gauge_map(truth)
    truth_rms = float(np.sqrt(np.mean(np.sum(
        remove_rigid_body(q, volumetric_error(truth, q)) ** 2, axis=1))))
    o = options or IdentifyOptions(suggest=False)
    out = FamilyResult(family.name, design, case, truth_rms)
    t0 = time.perf_counter()
    rb = identify(session, o)
    out.bayes = evaluate(rb, truth_g, q)
    out.bayes.update(seconds=time.perf_counter() - t0, sigma_um=float(rb.fit["sigma_um"]))
    if least_squares:
        rm = identify(session, replace(o, prior="none"))
        out.min_norm = evaluate(rm, truth_g, q, rigid=False)
    if limit is not None:
        y = np.concatenate([m.deviation for m in session.measurements])
        el = limit.estimate(y)
        dl = remove_rigid_body(q, volumetric_error(el, q) - volumetric_error(truth_g, q))
        out.limit_rms_um = float(np.sqrt(np.mean(np.sum(dl**2, axis=1))))
    return out


def run_family(family: str, design: str = "full", n_machines: int = 20, steps: int = 10,
               runs: int = 5, n_grid: int = 9, limit: bool = True, n_draws: int = N_DRAWS,
               options: IdentifyOptions | None = None, progress=None,
               least_squares: bool = True) -> list[FamilyResult]:
    """The study of one family on one design.

    Parameters
    ----------
    family : str
        Key of :data:`FAMILIES`.
    design : str
        ``'full'`` or ``'long'``.
    n_machines : int
        Machines (the first of :func:`cases`).
    steps, runs, n_grid : int
        Increments per test, bidirectional runs per line, grid points per axis.
    limit : bool
        Compute the limit (its prior costs ``n_draws`` draws per chain).
    n_draws : int
        Draws of the limit's prior.
    options : IdentifyOptions, optional
        Options of the default estimator.
    progress : callable, optional
        Called with each :class:`FamilyResult`.
    least_squares : bool
        Identify with minimum-norm least squares too (:func:`run_case`).

    Returns
    -------
    list of FamilyResult
    """
    fam = FAMILIES[family]
    travel = np.array(TRAVELS[design])
    limits: dict[str, Limit] = {}
    out = []
    for case in cases(n_machines):
        lim = None
        if limit:
            if case.chain not in limits:
                sess = plan_session(travel, case.chain, steps, TESTS, runs=runs)
                limits[case.chain] = build_limit(fam, travel, case.chain, sess, n_draws)
            lim = limits[case.chain]
        r = run_case(fam, design, case, lim, steps, runs, n_grid, options, least_squares)
        out.append(r)
        if progress is not None:
            progress(r)
    return out


def summarise(results: Sequence[FamilyResult]) -> dict:
    """Figures of one family on one design over its machines."""
    b = [r.bayes for r in results]
    rl = np.array([r.ratio_ls for r in results])
    rlim = np.array([r.ratio_limit for r in results])
    m_rlim = np.array([r.min_norm["rms_um"] / r.limit_rms_um for r in results])

    def rate(key):
        return (sum(x[key + "_in"] for x in b) / max(sum(x[key + "_n"] for x in b), 1))

    return {
        "family": results[0].family, "design": results[0].design, "machines": len(results),
        "truth_rms_um": float(np.median([r.truth_rms_um for r in results])),
        "bayes_rms_um": float(np.median([x["rms_um"] for x in b])),
        "min_norm_rms_um": float(np.median([r.min_norm["rms_um"] for r in results])),
        "limit_rms_um": float(np.median([r.limit_rms_um for r in results])),
        "ratio_ls_median": float(np.median(rl)), "ratio_ls_max": float(rl.max()),
        "above_1_02": int(np.sum(rl > 1.02)),
        "ratio_limit_median": float(np.median(rlim)), "ratio_limit_max": float(rlim.max()),
        "min_norm_ratio_limit_median": float(np.median(m_rlim)),
        "coverage": float(np.mean([x["coverage"] for x in b])),
        "coverage_min": float(np.min([x["coverage"] for x in b])),
        "coverage_rigid": float(np.mean([x.get("coverage_rigid", np.nan) for x in b])),
        "edge_rate": rate("edge"), "inner_rate": rate("inner"),
        "bayes_seconds": float(np.median([x["seconds"] for x in b])),
    }


def _markdown(summaries: Sequence[dict]) -> str:
    rows = ["| family | design | machines | truth RMS | volcal RMS | min-norm RMS | limit RMS "
            "| ratio to LS median / max (> 1.02) | ratio to limit median / max | LS to limit "
            "| coverage pooled (min) | coverage rigid-free | 2u band: last node / interior |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summaries:
        rows.append(
            f"| {s['family']} | {s['design']} | {s['machines']} | {s['truth_rms_um']:.2f} | "
            f"{s['bayes_rms_um']:.2f} | {s['min_norm_rms_um']:.2f} | {s['limit_rms_um']:.2f} | "
            f"{s['ratio_ls_median']:.2f} / {s['ratio_ls_max']:.2f} ({s['above_1_02']}) | "
            f"{s['ratio_limit_median']:.2f} / {s['ratio_limit_max']:.2f} | "
            f"{s['min_norm_ratio_limit_median']:.2f} | "
            f"{s['coverage']:.3f} ({s['coverage_min']:.2f}) | {s['coverage_rigid']:.3f} | "
            f"{s['edge_rate']:.3f} / {s['inner_rate']:.3f} |")
    return "\n".join(rows)


def _print(r: FamilyResult) -> None:
    b = r.bayes
    print(f"  {r.family} {r.design:4s} #{r.case.index:<3d} {r.case.chain} truth "
          f"{r.truth_rms_um:6.2f} volcal {b['rms_um']:6.2f} LS {r.min_norm['rms_um']:6.2f} "
          f"limit {r.limit_rms_um:6.2f} | /LS {r.ratio_ls:5.2f} /lim {r.ratio_limit:5.2f} "
          f"cover {b['coverage']:.3f} ({b.get('coverage_rigid', float('nan')):.3f}) edge "
          f"{b['edge_in']}/{b['edge_n']} worst {b['edge_worst']} {b['edge_worst_z']:.1f} "
          f"{b['seconds']:.1f} s", flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Command line (``python benchmarks/families.py --help``).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status.
    """
    p = argparse.ArgumentParser(description="The estimator on families of machines "
                                            "(issue 19).")
    p.add_argument("--family", default="all", help="comma-separated letters, or all")
    p.add_argument("--design", default="all", choices=[*TRAVELS, "all"])
    p.add_argument("--machines", type=int, default=20)
    p.add_argument("--steps", type=int, default=10)
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--grid", type=int, default=9)
    p.add_argument("--draws", type=int, default=N_DRAWS)
    p.add_argument("--no-limit", action="store_true")
    p.add_argument("--cache", type=Path, help="keep the limits' priors in this directory")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--markdown", action="store_true")
    p.add_argument("--json", type=Path)
    p.add_argument("--from-json", type=Path,
                   help="summarise the machines saved by an earlier --json run (no new runs)")
    a = p.parse_args(argv)
    if a.from_json:
        saved = json.loads(a.from_json.read_text())["machines"]
        groups = dict.fromkeys((m["design"], m["family"]) for m in saved)
        summaries = [summarise([FamilyResult(m["family"], m["design"], Case(**m["case"]),
                                             m["truth_rms_um"], m["bayes"], m["min_norm"],
                                             m["limit_rms_um"])
                                for m in saved if (m["design"], m["family"]) == g])
                     for g in groups]
        print(_markdown(summaries) if a.markdown else json.dumps(summaries, indent=1))
        return 0
    global CACHE
    CACHE = a.cache
    fams = list(FAMILIES) if a.family == "all" else a.family.split(",")
    designs = list(TRAVELS) if a.design == "all" else [a.design]
    summaries, everything = [], []
    for d in designs:
        for f in fams:
            res = run_family(f, d, a.machines, a.steps, a.runs, a.grid, not a.no_limit,
                             a.draws, progress=None if a.quiet else _print)
            summaries.append(summarise(res))
            everything += [{"family": r.family, "design": r.design, "case": r.case.__dict__,
                            "truth_rms_um": r.truth_rms_um, "bayes": r.bayes,
                            "min_norm": r.min_norm, "limit_rms_um": r.limit_rms_um}
                           for r in res]
            if not a.markdown:
                print(json.dumps(summaries[-1]), flush=True)
            if a.json:
                a.json.write_text(json.dumps({"machines": everything, "summary": summaries},
                                             indent=1))
    if a.markdown:
        print(_markdown(summaries))
    return 0


if __name__ == "__main__":
    sys.exit(main())
