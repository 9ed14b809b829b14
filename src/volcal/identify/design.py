"""The observation system of the unified estimator: one linear model for every reading.

Every reading of every test is, to first order, linear in the node values of the error
functions (``volcal.measure.readings.reading_jacobian``) plus set-up nuisances of its own
measurement (reading offset, beam/mirror tilt, reversal, drift). This module assembles
the sparse observation matrix ``A`` with columns ``[free function parameters | nuisances]``.

The gauge is explicit: every function is zero at the first node (start of travel) and
the six straightness functions also at the last node. These constraints remove the 6
rigid-body motions of the work zone (invisible to relative readings), the redundancy
between straightness slopes and squareness, and the redundancy between constant angular
offsets and squareness / tool orientation (``docs/identification.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.identify.settings import EstimatorSettings
from volcal.measure.readings import perpendicular_basis, reading_jacobian, tilt_columns
from volcal.model.chain import parse_chain
from volcal.model.kinematics import UM, URAD, pose_jacobian
from volcal.model.names import COMPONENT_NAMES, ROLL_NAMES
from volcal.model.parameters import ParameterLayout
from volcal.session.format import Measurement, Session
from volcal.session.kinds import kind_of

__all__ = ["UNTOUCHED_TOL", "Design", "build_design", "choose_nodes", "laser_rows",
           "read_functions", "untouched_parameters"]

# The rows of each kind of measurement, and the priors of its nuisances, come from the
# registry of kinds (volcal.kinds: Kind.rows, Kind.nuisance_priors); the laser readings'
# rows are :func:`laser_rows`.


def known_functions(options: Any) -> dict:
    """The functions held known by the identify options: ``known``, ``zero`` and the rolls.

    Parameters
    ----------
    options : IdentifyOptions
        ``known`` (name -> (positions [mm], values [um or urad])), ``zero`` (names held at
        zero) and ``roll`` (``'estimate'``, or ``'zero'``: EAX, EBY, ECZ held at zero).

    Returns
    -------
    dict
        Name -> (positions, values); ``(None, None)`` for a function held at zero.

    Raises
    ------
    VolcalInputError
        ``roll`` is neither ``'estimate'`` nor ``'zero'``.
    """
    known = dict(options.known)
    for n in options.zero:
        known.setdefault(n.upper(), (None, None))
    if options.roll == "zero":
        for n in ROLL_NAMES:  # EAX, EBY, ECZ: each axis about its own direction
            known.setdefault(n, (None, None))
    elif options.roll != "estimate":
        raise VolcalInputError(f"roll must be 'estimate' or 'zero', got {options.roll!r}")
    return known


def visited_positions(session: Session) -> list[int]:
    """Number of distinct visited positions per axis, the travel's ends included.

    Parameters
    ----------
    session : Session
        The session.

    Returns
    -------
    list of 3 int
    """
    return [choose_nodes(session, refine=1, max_nodes=10**9)[k].size for k in range(3)]


def _fill_intervals(v: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """``v`` (sorted, at most ``n`` values) with nodes added in its longest intervals.

    The ``n - v.size`` added nodes go one at a time to the interval whose parts would
    otherwise be longest, each interval split evenly.

    Parameters
    ----------
    v : ndarray
        Sorted node positions [mm].
    n : int
        Number of nodes wanted.

    Returns
    -------
    ndarray, shape (n,)
    """
    gaps = np.diff(v)
    parts = np.ones(gaps.size, dtype=int)
    for _ in range(n - v.size):
        parts[int(np.argmax(gaps / parts))] += 1
    out = [v[:1]]
    for a, g, m in zip(v[:-1], gaps, parts, strict=True):
        out.append(a + g * np.arange(1, m + 1) / m)
    w = np.concatenate(out)
    w[np.cumsum(np.concatenate([[0], parts]))] = v  # the visited positions exactly
    return w


def choose_nodes(session: Session, refine: int = 2, max_nodes: int = 201,
                 settings: EstimatorSettings | None = None) -> list[NDArray[np.float64]]:
    """Node positions per axis: the visited positions and travel ends, refined.

    Parameters
    ----------
    session : Session
        The session (its measured positions and travel).
    refine : int
        Each interval between visited positions is split into ``refine`` parts, so that
        the smoothness prior interpolates smoothly between readings.
    max_nodes : int
        Upper bound per axis of the refined grid; beyond it the visited positions
        (:attr:`EstimatorSettings.nodes_at_readings`: filled up to ``max_nodes`` in the
        longest intervals, or alone up to :attr:`EstimatorSettings.visited_nodes_factor`
        times ``max_nodes``), else a uniform grid (keeps the problem size independent of
        the number of increments).
    settings : EstimatorSettings, optional
        Default ``EstimatorSettings()``.

    Returns
    -------
    list of 3 ndarray
    """
    st = settings if settings is not None else EstimatorSettings()
    at_readings = st.nodes_at_readings
    out = []
    for k in range(3):
        vals = [session.travel[k]]
        vals += [m.positions[:, k] for m in session.measurements
                 if kind_of(m.kind).linear_nodes]  # not a probe_sphere's sphere centres
        v = np.unique(np.round(np.concatenate(vals), 6))
        lo, hi = session.travel[k]
        v = v[(v >= lo - 1e-9) & (v <= hi + 1e-9)]
        v = np.unique(np.concatenate([[lo, hi], v]))
        span = hi - lo
        keep = [v[0]]
        for x in v[1:]:
            if x - keep[-1] > 1e-6 * span:
                keep.append(x)
        v = np.array(keep)
        if (v.size - 1) * max(refine, 1) + 1 > max_nodes:
            if at_readings and v.size <= max_nodes:
                v = _fill_intervals(v, max_nodes)
            elif not (at_readings and v.size <= st.visited_nodes_factor * max_nodes):
                v = np.linspace(lo, hi, max_nodes)
            # else: the visited positions alone, a few more than max_nodes
        elif refine > 1:
            t = np.arange(1, refine + 1) / refine  # each interval split into refine parts
            inner = v[:-1, None] + (v[1:] - v[:-1])[:, None] * t
            inner[:, -1] = v[1:]  # the visited positions exactly
            v = np.concatenate([v[:1], inner.ravel()])
        out.append(v)
    return out


@dataclass
class Design:
    """Assembled observation system.

    Attributes
    ----------
    layout : ParameterLayout
        Full parameter layout (all node values + squareness).
    free : ndarray of int
        Indices (into the full layout) of the estimated function/squareness parameters.
    fixed_values : ndarray
        Full parameter vector of the values held fixed (gauge zeros, known errors).
    A : scipy.sparse.csr_matrix, shape (n, p_free + p_nuis)
        Observation matrix [um per um or urad].
    y : ndarray, shape (n,)
        Deviations minus the contribution of the fixed values [um].
    nuisance_names : list of str
        ``'<measurement id>:<offset|tilt1|tilt2|reversal|drift>'``.
    rows : dict of str to slice
        Rows of each measurement.
    measurements : list of Measurement
    row_scale : ndarray or None
        Square root of each reading's weight, applied to ``A`` and ``y`` (robust
        fitting); None when all readings weigh the same.
    """

    layout: ParameterLayout
    chain: str
    travel: NDArray[np.float64]
    free: NDArray[np.intp]
    fixed_values: NDArray[np.float64]
    A: sp.csr_matrix
    y: NDArray[np.float64]
    nuisance_names: list[str]
    rows: dict[str, slice]
    measurements: list[Measurement] = field(repr=False, default_factory=list)
    fixed_names: list[str] = field(default_factory=list)
    prior_mean: NDArray[np.float64] | None = None
    extra_precision: NDArray[np.float64] | None = None
    row_scale: NDArray[np.float64] | None = None

    def reading_matrix(self) -> sp.csr_matrix:
        """``A`` of the readings themselves: the robust weights (``row_scale``) taken out."""
        if self.row_scale is None:
            return self.A.tocsr()
        return (sp.diags(1.0 / self.row_scale) @ self.A).tocsr()

    @property
    def n_free(self) -> int:
        """Number of estimated function and squareness parameters."""
        return int(self.free.size)

    @property
    def n_nuisance(self) -> int:
        """Number of set-up nuisance parameters."""
        return len(self.nuisance_names)

    def full_parameters(self, x_free: NDArray[np.float64]) -> NDArray[np.float64]:
        """Full layout vector from the estimated free parameters.

        Parameters
        ----------
        x_free : ndarray, shape (p_free,) or (p_free + p_nuis,)
            Estimated free function/squareness values ([um] for translations, [urad] for
            rotations and squareness), optionally followed by the nuisance parameters,
            which are ignored.

        Returns
        -------
        ndarray, shape (layout.size,)
            The fixed values with the free entries replaced by ``x_free``.
        """
        theta = self.fixed_values.copy()
        theta[self.free] = x_free[: self.n_free]
        return theta


def _gauge_mask(layout: ParameterLayout) -> NDArray[np.bool_]:
    """True for parameters fixed to zero by the gauge."""
    fixed = np.zeros(layout.size, dtype=bool)
    for k in range(3):
        n = len(layout.nodes[k])
        for c in range(6):
            idx = layout.indices(k, c)
            fixed[idx[0]] = True
            if c < 3 and c != k and n > 1:
                fixed[idx[-1]] = True
    return fixed


def coarsen(design: Design, nodes: list[NDArray[np.float64]]) -> Design | None:
    """The same observation system on other (coarser) nodes, by interpolation.

    The functions are piecewise linear on their nodes; a function on ``nodes`` is, at the
    design's nodes, its linear interpolant, so the coarse system is ``A P`` with ``P`` the
    interpolation matrix (exact when the coarse nodes are a subset of the fine ones, as
    :func:`choose_nodes` makes them; a close approximation otherwise, which is all the
    choice of hyperparameters needs). It saves rebuilding the readings' Jacobians, the
    cost that grows with the number of readings.

    Parameters
    ----------
    design : Design
        Observation system on its nodes.
    nodes : list of 3 arrays
        The other nodes [mm], spanning the same travel.

    Returns
    -------
    Design or None
        None when the design holds anything but gauge zeros fixed (known errors, priors
        with a mean): rebuild it with :func:`build_design` then.
    """
    if (np.any(design.fixed_values) or design.prior_mean is not None and np.any(design.prior_mean)
            or design.extra_precision is not None and np.any(design.extra_precision)):
        return None
    fine = design.layout
    layout = ParameterLayout.of_nodes(nodes)
    rows, cols, vals = [], [], []
    for k in range(3):
        xf, xc = np.asarray(fine.nodes[k]), np.asarray(layout.nodes[k])
        if xc.size == 1:
            W = np.ones((xf.size, 1))
        else:
            W = np.column_stack([np.interp(xf, xc, e) for e in np.eye(xc.size)])
        r, c = np.nonzero(W)
        for comp in range(6):
            rows.append(fine.indices(k, comp)[r])
            cols.append(layout.indices(k, comp)[c])
            vals.append(W[r, c])
    rows.append(fine.squareness_indices())
    cols.append(layout.squareness_indices())
    vals.append(np.ones(3))
    P = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(fine.size, layout.size))
    free = np.flatnonzero(~_gauge_mask(layout))
    nf = design.n_free
    A_funcs = design.A[:, :nf] @ P[design.free][:, free]
    A = sp.hstack([A_funcs, design.A[:, nf:]]).tocsr()
    return Design(layout, design.chain, design.travel, free, np.zeros(layout.size), A,
                  design.y, design.nuisance_names, design.rows, design.measurements,
                  list(design.fixed_names), None, None, design.row_scale)


def drift_separable(m: Measurement, tol_mm: float = 1e-3) -> bool:
    """True when a linear drift of a measurement can be told apart from the geometry.

    A drift is a function of time; the geometric errors are functions of position. In a
    single pass every position is read once, so a drift linear in time is a function of
    position too and is absorbed by the errors (or absorbs them: squareness, slopes). Only
    positions read more than once at different times (repeated runs, bidirectional runs,
    repeated reference readings) separate the two.

    Parameters
    ----------
    m : Measurement
        A measurement with a ``time_s`` column.
    tol_mm : float
        Positions closer than this are the same position [mm].

    Returns
    -------
    bool
    """
    if "time_s" not in m.columns or not np.ptp(m.columns["time_s"]) > 0:
        return False
    key = np.round(np.asarray(m.positions, dtype=float) / tol_mm).astype(np.int64)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    t = np.asarray(m.columns["time_s"], dtype=float)
    for g in np.flatnonzero(counts > 1):
        if np.ptp(t[inv.ravel() == g]) > 0:
            return True
    return False


TILT_VISIBLE_UM_PER_URAD = 1e-9
"""A set-up tilt is a nuisance of a test only where it moves a reading by more than this
per urad (1e-6 mm of lateral travel): on a body diagonal the target stays on the beam line
and the tilt columns are rounding noise."""


def _visible_tilts(m: Measurement) -> tuple[NDArray[np.float64], list[int]]:
    """Tilt columns of a test [um/urad] and the basis directions that are visible."""
    T = tilt_columns(m) * (URAD / UM)
    if not T.size or np.abs(T).max() <= TILT_VISIBLE_UM_PER_URAD:
        return T, []
    s = np.linalg.svd(T, compute_uv=False)
    return T, [j for j in range(2) if s[j] > 1e-6 * s[0]]


def _alignment_rows(Je: sp.csr_matrix, m: Measurement, T: NDArray[np.float64],
                    visible: list[int]) -> sp.csr_matrix:
    """Readings' dependence on the errors through the beam alignment [um per parameter].

    The beam is aligned to the machine's actual motion from the first to the farthest
    point of the test (and a flat mirror to the beam), so its direction deviates from
    the nominal one by ``B (e(q_far) - e(q_0)) / L`` [rad], ``B`` the basis perpendicular
    to the beam: the readings gain ``T B (e_far - e_0) / L``, the tilt columns ``T`` acting
    on that direction. With this term the tilt nuisances are the residual misalignment of
    the set-up, independent of the machine, which their prior describes. ``Je`` is the
    test's pose Jacobian (:func:`volcal.model.kinematics.pose_jacobian` at its positions).
    """
    q = m.positions
    far = int(np.argmax(np.linalg.norm(q - q[0], axis=1)))
    L = float(np.linalg.norm(q[far] - q[0]))
    de = sp.csr_matrix(Je[3 * far:3 * far + 3] - Je[0:3])  # [um per parameter]
    B = perpendicular_basis(m.beam_direction)[visible] * (UM / URAD) / L
    G = sp.csr_matrix(B) @ de  # [urad per parameter]
    return (sp.csr_matrix(T[:, visible]) @ G).tocsr()


def _nuisance_columns(m: Measurement, drift: bool, tilts: bool, T: NDArray[np.float64],
                      visible: list[int]):
    """Set-up nuisance columns of a test; ``T, visible`` from :func:`_visible_tilts`."""
    cols, names = [np.ones(m.n)], [f"{m.id}:offset"]
    if tilts:
        for j in visible:
            cols.append(T[:, j])
            names.append(f"{m.id}:tilt{j + 1}")
    d = m.direction
    if (d is not None and kind_of(m.kind).bidirectional and np.any(d == "+")
            and np.any(d == "-")):
        cols.append(np.where(d == "+", 0.5, -0.5))
        names.append(f"{m.id}:reversal")
    if drift and drift_separable(m):
        cols.append(m.columns["time_s"] / 3600.0)
        names.append(f"{m.id}:drift")
    return np.stack(cols, 1), names


def laser_rows(chain_order, nodes, m: Measurement, drift: bool = False, tilts: bool = True):
    """Rows of a laser reading along a beam (linear, diagonal, step diagonal).

    Parameters
    ----------
    chain_order : sequence of int
        ``Chain.order``.
    nodes : list of 3 arrays
        Node positions per axis [mm].
    m : Measurement
        The measurement (with readings).
    drift : bool
        Add a linear drift nuisance where it is separable (:func:`drift_separable`).
    tilts : bool
        Add the set-up tilt nuisances where visible, with the beam alignment's dependence
        on the errors (:func:`_alignment_rows`).

    Returns
    -------
    J : scipy.sparse.csr_matrix, shape (n, P)
        Rows on the full parameter layout [um per parameter].
    y : ndarray, shape (n,)
        The deviations [um].
    N : ndarray, shape (n, k)
        Nuisance columns: offset, tilts, reversal, drift.
    names : list of str
    """
    jacobians = pose_jacobian(chain_order, nodes, m.positions, m.tool_offset)
    J = reading_jacobian(chain_order, nodes, m, jacobians)
    T, visible = _visible_tilts(m)
    N, names = _nuisance_columns(m, drift, tilts, T, visible)
    if tilts and visible:
        J = (J + _alignment_rows(jacobians[0], m, T, visible)).tocsr()
    return J, m.deviation, N, names


def build_design(session: Session, nodes: list[NDArray[np.float64]] | None = None,
                 known: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None,
                 drift: bool = False, measurement_ids: list[str] | None = None,
                 tilts: bool = True,
                 weights: dict[str, NDArray[np.float64]] | None = None) -> Design:
    """Assemble the observation matrix of a session.

    Parameters
    ----------
    session : Session
        Measured session.
    nodes : list of 3 arrays, optional
        Node positions per axis [mm]; default :func:`choose_nodes`.
    known : dict, optional
        Errors measured separately: ISO name (``'EAX'``...) -> ``(positions [mm], values
        [um or urad])`` held fixed, or ``(positions, values, std)`` used as a prior with
        that standard uncertainty [um or urad]; a squareness name maps to
        ``(None, value[, std])``; positions None means zero.
    drift : bool
        Add a linear drift nuisance to each measurement whose drift can be separated from
        the geometry (:func:`drift_separable`: ``time_s`` and positions read more than once).
    measurement_ids : list of str, optional
        Use only these measurements.
    tilts : bool
        Add the set-up tilt nuisances (beam and mirror alignment) where they are visible.
    weights : dict of str to ndarray, optional
        Weight of each reading of a measurement (by id; 1 = a normal reading, 1/k^2 = a
        reading whose noise is k times the others'): the rows are scaled by the square
        root, and ``Design.row_scale`` keeps it (robust fitting).

    Returns
    -------
    Design
    """
    if nodes is None:
        nodes = choose_nodes(session)
    layout = ParameterLayout.of_nodes(nodes)
    chain = parse_chain(session.chain)
    meas = [m for m in session.measurements
            if (measurement_ids is None or m.id in measurement_ids)
            and kind_of(m.kind).in_design]  # a rotary test is evaluated on its own
    if not meas:
        raise VolcalInputError("no measurements selected for identification (rotary tests "
                               "are evaluated per axis: volcal evaluate; probe_sphere tests "
                               "locate the rotary axes: volcal locate; so do r_test tests)",
                               session.path / "session.toml" if session.path else None)
    for m in meas:
        if m.deviation is None:
            raise VolcalInputError("measurement has no deviations (run it or simulate it first)",
                                   (session.path / m.file) if session.path else m.file)
    from volcal.session.optics import annotate_references

    annotate_references(session.measurements, session.references)  # direct optics' groups
    fixed = _gauge_mask(layout)
    fixed_values = np.zeros(layout.size)
    fixed_names = []
    from volcal.model.names import SQUARENESS_NAMES

    soft: list[tuple[NDArray[np.intp], NDArray[np.float64], float]] = []
    for name, spec in (known or {}).items():
        pos, val = spec[0], spec[1]
        std = spec[2] if len(spec) > 2 else None
        uname = name.upper()
        if uname in SQUARENESS_NAMES:
            idx = layout.squareness_indices()[[SQUARENESS_NAMES.index(uname)]]
            v = np.array([0.0 if val is None else float(np.asarray(val).reshape(-1)[0])])
        elif uname in COMPONENT_NAMES:
            j = COMPONENT_NAMES.index(uname)
            k, c = divmod(j, 6)
            idx = layout.indices(k, c)
            if pos is None:
                v = np.zeros(idx.size)
            else:
                order = np.argsort(pos)
                v = np.interp(layout.nodes[k], np.asarray(pos)[order], np.asarray(val)[order])
            # bring the known function into the gauge (zero at start; straightness also at end)
            v = v - v[0]
            if c < 3 and c != k and v.size > 1:
                v = v - (layout.nodes[k] - layout.nodes[k][0]) / np.ptp(layout.nodes[k]) * v[-1]
        else:
            raise VolcalInputError(f"unknown error name {name!r} in the known errors")
        if std is None:
            fixed[idx] = True
            fixed_values[idx] = v
            fixed_names.append(uname)
        else:
            if not std > 0:
                raise VolcalInputError(f"the uncertainty of known {uname} must be positive")
            soft.append((idx, v, float(std)))
            fixed_names.append(f"{uname} (prior, u = {std:g})")
    free = np.flatnonzero(~fixed)
    blocks, nblocks, ys, rows, nnames = [], [], [], {}, []
    r0 = 0
    for m in meas:
        J, y_m, N, names = kind_of(m.kind).rows(chain.order, layout.nodes, m, drift=drift,
                                                tilts=tilts)  # the kind's rows (volcal.kinds)
        ys.append(y_m - J @ fixed_values)
        blocks.append(J[:, free])
        nblocks.append((N, r0, names))
        rows[m.id] = slice(r0, r0 + m.n)
        r0 += m.n
    column: dict[str, int] = {}  # a name seen twice is one shared column
    for _, _, names in nblocks:
        for nm in names:
            column.setdefault(nm, len(column))
    nnames = list(column)
    n_nuis = len(nnames)
    data, ri, ci = [], [], []
    for N, start, names in nblocks:
        rr, cc = np.nonzero(N)
        data.append(N[rr, cc])
        ri.append(rr + start)
        ci.append(np.array([column[nm] for nm in names], dtype=int)[cc])
    Nmat = sp.csr_matrix((np.concatenate(data), (np.concatenate(ri), np.concatenate(ci))),
                         shape=(r0, n_nuis))
    A = sp.hstack([sp.vstack(blocks), Nmat]).tocsr()
    pos_in_free = -np.ones(layout.size, dtype=np.intp)
    pos_in_free[free] = np.arange(free.size)
    mean = np.zeros(A.shape[1])
    extra = np.zeros(A.shape[1])
    for idx, v, std in soft:
        p = pos_in_free[idx]
        ok = p >= 0
        mean[p[ok]] = v[ok]
        extra[p[ok]] = 1.0 / std**2
    for m in meas:
        for nm, (mu, sd) in kind_of(m.kind).nuisance_priors(m).items():
            if nm in column:
                mean[free.size + column[nm]] = mu
                extra[free.size + column[nm]] = 1.0 / sd**2
    y = np.concatenate(ys)
    if np.any(mean):
        y = y - A @ mean  # solve for the departure from the prior mean
    row_scale = None
    if weights:
        row_scale = np.ones(r0)
        for m in meas:
            if m.id in weights:
                row_scale[rows[m.id]] = np.sqrt(np.asarray(weights[m.id], dtype=float))
        A = sp.diags(row_scale) @ A
        y = row_scale * y
    return Design(layout, chain.code, session.travel.copy(), free, fixed_values, A.tocsr(),
                  y, nnames, rows, meas, fixed_names, prior_mean=mean, extra_precision=extra,
                  row_scale=row_scale)


UNTOUCHED_TOL = 1e-6
"""A column of the design below this share of its largest entry is untouched [1]."""


def untouched_parameters(design: Design) -> NDArray[np.bool_]:
    """Free parameters no reading depends on (nodes between the readings).

    Parameters
    ----------
    design : Design
        Assembled observation system.

    Returns
    -------
    ndarray of bool, shape (design.n_free,)
        True where the column of ``A`` is zero, or below :data:`UNTOUCHED_TOL` times the
        design's largest entry: a reading within a millionth of the node spacing of the
        neighbouring node (a position computed in floating point, 133.3333333 mm, beside
        the node it was rounded to, 133.333333 mm) touches that node as a reading read
        back from its file does, not at all.
    """
    a = design.A.tocsc()[:, :design.n_free]
    col = np.asarray(abs(a).max(axis=0).toarray().ravel())
    return col <= UNTOUCHED_TOL * (col.max() if col.size else 0.0)


def read_functions(layout: ParameterLayout, free: NDArray[np.intp],
                   untouched: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The free parameters of the functions some reading moves.

    A function none of whose free nodes a reading touches (a straightness of a session of
    linear tests) is not measured at all: the whole function is the prior's, which the
    identifiability report states, and denser readings would not change it. The part
    between the readings is that of the functions the readings do move.

    Parameters
    ----------
    layout : ParameterLayout
        The parameter layout.
    free : ndarray of int
        Free parameters of ``layout``.
    untouched : ndarray of bool, shape (free.size,)
        Free parameters no reading moves.

    Returns
    -------
    ndarray of bool, shape (free.size,)
        True at the free parameters of a function with at least one touched free node.
    """
    out = np.zeros(free.size, dtype=bool)
    for k in range(3):
        for c in range(6):
            m = np.isin(free, layout.indices(k, c))
            if m.any() and not untouched[m].all():
                out |= m
    return out
