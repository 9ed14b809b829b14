"""Multilateration readings in the unified estimator: rows, station nuisances, Gauss-Newton.

Rows (:func:`row_block`, the rows of the kind :mod:`volcal.kinds.multilateration`): a
tracker reading ``L_i`` (change of the station-to-reflector distance) linearised at the
current station estimate ``S`` is

.. math:: 10^3 (L_i + d_0 - d_i) = u_i \\cdot J_e(q_i)\\,\\theta - u_i \\cdot \\delta S + c

with ``d_i = |Pn_i - S|`` the distance to the nominal tool point, ``u_i`` its direction,
``J_e`` the first-order volumetric Jacobian of the tool point (the one every laser reading
uses) and two kinds of set-up nuisance: the station displacement ``delta S`` [um] (3
columns named ``station(x,y,z):station_x|y|z``, shared by every measurement taken from the
same ``station_mm``) and the unknown distance at the first reading, ``c`` [um] (the
measurement's ``offset`` column).

The station enters non-linearly (a 5 mm set-up error bends the distances by tens of um),
so :func:`identify_iterated` re-linearises: it solves, moves the stations by their
estimated displacement and solves again until no station moves by more than
:data:`STATION_TOLERANCE_UM`; the machine errors stay first order throughout (their
second-order terms are below 1 nm). Gauge: multilateration cannot see a rigid motion of
the stations together with the work zone; the estimator's gauge on the error functions
(zero at the start of travel, straightness also at the end) removes the rigid motions of
the work zone, and with them this one (checked by rank in the tests).
"""

from __future__ import annotations

from copy import copy

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.measure.multilateration import station_key, station_of, tracker_jacobian
from volcal.session.format import Session
from volcal.session.multilateration import length_from_deviation, nominal_distances

__all__ = ["STATION_TOLERANCE_UM", "identify_iterated", "linearised", "needs_linearisation",
           "row_block", "station_table"]

STATION_TOLERANCE_UM = 1.0
"""The Gauss-Newton loop stops when no station moves by more than this [um]."""

MAX_ITERATIONS = 12
FIT_KEY = "_station_fit_mm"
"""Working metadata key of a measurement: the station estimate the rows are linearised at."""


def row_block(chain_order, nodes, meas, drift: bool = False):
    """Rows and nuisance columns of one multilateration measurement.

    Parameters
    ----------
    chain_order : sequence of int
        ``Chain.order``.
    nodes : list of 3 arrays
        Node positions per axis [mm].
    meas : Measurement
        A multilateration measurement with deviations.
    drift : bool
        Add a linear drift column (needs ``time_s``).

    Returns
    -------
    J : scipy.sparse.csr_matrix, shape (n, P)
        Rows on the full parameter layout [um per um or urad].
    y : ndarray, shape (n,)
        Observations at the linearisation point [um].
    N : ndarray, shape (n, k)
        Nuisance columns: reading offset, station x, y, z, optionally drift.
    names : list of str
        Nuisance names; the station's are shared by measurements from the same station.
    """
    S = np.asarray(meas.meta.get(FIT_KEY, station_of(meas)), dtype=float)
    J, U = tracker_jacobian(chain_order, nodes, meas, S)
    L = length_from_deviation(meas.deviation, meas.positions, meas.tool_offset,
                              station_of(meas))
    d = nominal_distances(meas.positions, meas.tool_offset, S)
    y = (L - L[0] + d[0] - d) * 1e3
    key = station_key(meas)
    cols = [np.ones(meas.n), U[:, 0], U[:, 1], U[:, 2]]
    names = [f"{meas.id}:offset", f"{key}:station_x", f"{key}:station_y", f"{key}:station_z"]
    if drift and "time_s" in meas.columns and np.ptp(meas.columns["time_s"]) > 0:
        cols.append(meas.columns["time_s"] / 3600.0)
        names.append(f"{meas.id}:drift")
    return J, y, np.stack(cols, 1), names


def station_priors(meas) -> dict[str, tuple[float, float]]:
    """Prior of the station nuisances: the station as set up, to ``station_u_mm``.

    The nuisance is the station's move from the linearisation point ``S`` [um]; the user's
    ``station_mm`` with standard uncertainty ``station_u_mm`` (default
    :data:`volcal.session.multilateration.DEFAULT_STATION_U_MM`) gives it the mean
    ``(station_mm - S)`` and that standard deviation, per coordinate.

    Parameters
    ----------
    meas : Measurement
        A multilateration measurement.

    Returns
    -------
    dict of str to (float, float)
        Nuisance name -> (mean [um], standard deviation [um]).
    """
    from volcal.session.multilateration import DEFAULT_STATION_U_MM

    nominal = station_of(meas)
    S = np.asarray(meas.meta.get(FIT_KEY, nominal), dtype=float)
    u_um = float(meas.meta.get("station_u_mm", DEFAULT_STATION_U_MM)) * 1e3
    key = station_key(meas)
    return {f"{key}:station_{ax}": (float((nominal[c] - S[c]) * 1e3), u_um)
            for c, ax in enumerate("xyz")}


def needs_linearisation(session: Session) -> bool:
    """True when the session has multilateration measurements not yet linearised.

    Parameters
    ----------
    session : Session
        A session.

    Returns
    -------
    bool
    """
    return any(m.kind == "multilateration" and FIT_KEY not in m.meta
               for m in session.measurements)


def linearised(session: Session, stations: dict[str, NDArray[np.float64]]) -> Session:
    """A copy of the session whose multilateration rows are linearised at ``stations``.

    Parameters
    ----------
    session : Session
        The session (not modified).
    stations : dict of str to ndarray
        Station estimate [mm] by :func:`volcal.measure.multilateration.station_key`.

    Returns
    -------
    Session
    """
    s = copy(session)
    s.measurements = []
    for m in session.measurements:
        if m.kind == "multilateration":
            m = copy(m)
            m.meta = dict(m.meta)
            m.meta[FIT_KEY] = [float(v) for v in stations[station_key(m)]]
        s.measurements.append(m)
    return s


def _updates(result) -> dict[str, NDArray[np.float64]]:
    out: dict[str, list[float]] = {}
    for name, (v, _) in result.nuisances.items():
        key, _, kind = name.rpartition(":")
        if kind.startswith("station_"):
            out.setdefault(key, [0.0, 0.0, 0.0])["xyz".index(kind[-1])] = v
    return {k: np.array(v) for k, v in out.items()}


def station_table(result, stations: dict[str, NDArray[np.float64]],
                  nominal: dict[str, NDArray[np.float64]]) -> list[dict]:
    """Fitted stations with their uncertainties, for the model file and the report.

    Parameters
    ----------
    result : IdentificationResult
        The final identification (rows linearised at ``stations``).
    stations : dict of str to ndarray
        Linearisation points [mm].
    nominal : dict of str to ndarray
        Stations as set up (``station_mm``) [mm].

    Returns
    -------
    list of dict
        ``station``, ``nominal_mm``, ``fitted_mm``, ``u_um`` (standard uncertainty per
        coordinate), ``measurements``.
    """
    rows = []
    meas_of: dict[str, list[str]] = {}
    for m in result.design.measurements if result.design is not None else []:
        if m.kind == "multilateration":
            meas_of.setdefault(station_key(m), []).append(m.id)
    for key, S in stations.items():
        if key not in meas_of:  # not among the measurements used
            continue
        v = np.zeros(3)
        u = np.zeros(3)
        for j, c in enumerate("xyz"):
            v[j], u[j] = result.nuisances.get(f"{key}:station_{c}", (0.0, float("nan")))
        rows.append({"station": key, "nominal_mm": [float(x) for x in nominal[key]],
                     "fitted_mm": [float(x) for x in S + v * 1e-3],
                     "u_um": [float(x) for x in u], "measurements": meas_of.get(key, [])})
    return rows


def _fast_step(session: Session, options) -> dict[str, NDArray[np.float64]]:
    """Station updates [um] of one Bayesian solve with fixed hyperparameters, no covariance."""
    from volcal.identify.design import build_design, choose_nodes, known_functions
    from volcal.identify.prior import PriorStructure
    from volcal.identify.solver import solve_bayes

    st = options.settings
    nodes = choose_nodes(session, refine=1, max_nodes=min(options.max_nodes, 41), settings=st)
    d = build_design(session, nodes, known_functions(options), options.drift,
                     options.measurement_ids, options.tilts)
    prior = PriorStructure.build(d.layout, d.free, options.kappa, settings=st)
    scales = np.array(options.scales if options.scales is not None else st.typical_scales)
    noise = options.noise_um if options.noise_um is not None else 1.0
    sol = solve_bayes(d, prior, scales, noise, options.squareness_std_urad, covariance=False,
                      settings=st)
    out: dict[str, list[float]] = {}
    for j, name in enumerate(d.nuisance_names):
        key, _, kind = name.rpartition(":")
        if kind.startswith("station_"):
            out.setdefault(key, [0.0, 0.0, 0.0])["xyz".index(kind[-1])] = sol.x[d.n_free + j]
    return {k: np.array(v) for k, v in out.items()}


def identify_iterated(session: Session, options, identify_fn):
    """Gauss-Newton on the station nuisances around the first-order estimator.

    Parameters
    ----------
    session : Session
        Measured session with multilateration measurements (others may be mixed in).
    options : IdentifyOptions
        Estimator options.
    identify_fn : callable
        :func:`volcal.identify.api.identify` (called on linearised copies).

    Returns
    -------
    IdentificationResult
        The final solution, linearised at the converged stations: the user's estimator
        there, as :func:`volcal.identify.api.identify` of a session whose stations were
        written down right; ``fit['multilateration']`` holds the fitted stations
        (:func:`station_table`) and the iterations.
    """
    nominal: dict[str, NDArray[np.float64]] = {}
    for m in session.measurements:
        if m.kind == "multilateration":
            nominal.setdefault(station_key(m), station_of(m))
    stations = {k: v.copy() for k, v in nominal.items()}
    # 1) converge the stations with fixed hyperparameters on the measured positions (the
    #    first linearisation can be tens of um off, which would spoil an evidence estimate)
    history = []
    for _ in range(MAX_ITERATIONS):
        step = _fast_step(linearised(session, stations), options)
        for k, dv in step.items():
            stations[k] = stations[k] + dv * 1e-3
        history.append(max((float(np.abs(dv).max()) for dv in step.values()), default=0.0))
        if history[-1] < STATION_TOLERANCE_UM:
            break
    # 2) the user's estimator at the converged stations; re-linearise if it still moves them.
    #    Each re-linearisation runs it whole (its hyperparameters chosen again by the
    #    evidence): fixing the four group scales of the first run dropped the trends, the
    #    nugget, the axes' curvature factors and the travel exponents from the final fit
    for _ in range(MAX_ITERATIONS):
        r = identify_fn(linearised(session, stations), options)
        step = _updates(r)
        move = max((float(np.abs(dv).max()) for dv in step.values()), default=0.0)
        history.append(move)
        if move < STATION_TOLERANCE_UM:
            break
        for k, dv in step.items():
            stations[k] = stations[k] + dv * 1e-3
    converged = history[-1] < STATION_TOLERANCE_UM
    r.report.messages += design_notes(session)
    r.fit["multilateration"] = {
        "stations": station_table(r, stations, nominal),
        "iterations": len(history),
        "last_station_update_um": history[-1],
        "converged": converged,
    }
    if not converged:
        r.report.messages.append(
            f"Multilateration: the station positions did not settle within {MAX_ITERATIONS} "
            f"re-linearisations (last move {history[-1]:.3g} um): check station_mm and the "
            "tool offsets.")
    return r


# ----------------------------------------------------------------------------- advice

def design_notes(session: Session) -> list[str]:
    """Plain-word notes on what a multilateration layout can and cannot determine.

    Parameters
    ----------
    session : Session
        A session with multilateration measurements.

    Returns
    -------
    list of str
    """
    ms = [m for m in session.measurements if m.kind == "multilateration"]
    if not ms:
        return []
    stations = np.unique(np.array([station_of(m) for m in ms]), axis=0)
    offsets = np.unique(np.array([m.tool_offset for m in ms]), axis=0)
    notes = []
    if stations.shape[0] < 3:
        notes.append(f"Multilateration: {stations.shape[0]} tracker station(s); at least 3 "
                     "(better 4, not in one plane) are needed to locate the tool point in space.")
    elif np.linalg.matrix_rank(stations[1:] - stations[0], tol=1.0) < 3:
        notes.append("Multilateration: the tracker stations lie in one plane, so the direction "
                     "out of that plane is seen only at a grazing angle near the plane: place "
                     "one station higher or lower than the others.")
    if offsets.shape[0] == 1:
        notes.append("Multilateration: one tool offset. The tilts of the axis that carries the "
                     "tool (and the roll of the machine axes about the tool's line) cannot be "
                     "told from straightness: measure again with the reflector off the spindle "
                     "axis (a second tool offset) to see them.")
    else:
        diffs = offsets[1:] - offsets[0]
        if np.linalg.matrix_rank(diffs, tol=1.0) == 1:
            d = diffs[0] / np.linalg.norm(diffs[0])
            dtxt = ", ".join(f"{v:+.2f}" for v in d)
            notes.append("Multilateration: the tool offsets lie on one line (direction "
                         f"[{dtxt}]): the tilt of the axis that carries the tool about that "
                         "line is not seen (the prior keeps it finite); it changes the "
                         "volumetric error only for tools off that line. A third offset off "
                         "the line determines it.")
        if np.all(np.abs(offsets[:, :2]) < 1e-9):
            notes.append("Multilateration: every tool offset is on the spindle axis, so the "
                         "roll of the axis that carries the tool is not seen: put one "
                         "reflector off the axis.")
    return notes


def _path_time_s(q: NDArray[np.float64], dwell_s: float, feed_mm_min: float) -> float:
    return float(q.shape[0] * dwell_s + np.linalg.norm(np.diff(q, axis=0), axis=1).sum()
                 / feed_mm_min * 60.0)


def _variant(session: Session, stations, offsets, q) -> Session:
    from volcal.plan.multilateration import multilateration_tests

    others = [m for m in session.measurements if m.kind != "multilateration"]
    ms = multilateration_tests(session.travel, (2, 2, 2), stations, offsets)
    for m in ms:
        m.positions = q.copy()
        m.deviation = np.zeros(m.n)
    s = copy(session)
    s.measurements = others + ms
    return s


def _figures(s: Session, options, noise_um: float, dwell_s: float, feed_mm_min: float,
             q: NDArray[np.float64]) -> dict:
    from volcal.identify.design import build_design, choose_nodes, known_functions
    from volcal.identify.prior import PriorStructure
    from volcal.identify.solver import solve_bayes
    from volcal.model.chain import parse_chain
    from volcal.model.kinematics import pose_jacobian

    for m in s.measurements:
        if m.deviation is None:
            m.deviation = np.zeros(m.n)
    st = options.settings
    nodes = choose_nodes(s, refine=1, max_nodes=min(options.max_nodes, 41), settings=st)
    d = build_design(s, nodes, known_functions(options), options.drift, None, options.tilts)
    prior = PriorStructure.build(d.layout, d.free, st.kappa_centre, settings=st)
    sol = solve_bayes(d, prior, np.array(st.typical_scales), noise_um,
                      options.squareness_std_urad, settings=st)
    Je, _ = pose_jacobian(parse_chain(s.chain).order, d.layout.nodes, q)
    G = Je[:, d.free].toarray()
    if sol.covariance is None:
        raise VolcalInputError("problem too large for the dense covariance: reduce --max-nodes "
                               "or the number of measurements")
    cov = sol.covariance[: d.n_free, : d.n_free]
    var = np.einsum("ij,jk,ik->i", G, cov, G).reshape(-1, 3)
    u = np.sqrt(np.clip(var.sum(1), 0, None))
    hours = sum(_path_time_s(m.positions, dwell_s, feed_mm_min) for m in s.measurements) / 3600
    return {"u_max_um": float(u.max()), "u_rms_um": float(np.sqrt(np.mean(u**2))),
            "machine_time_h": hours, "readings": int(sum(m.n for m in s.measurements))}


def compare_layouts(session: Session, options, noise_um: float = 0.4, dwell_s: float = 4.0,
                    feed_mm_min: float = 2000.0) -> list[dict]:
    """Volumetric uncertainty and machine time of the planned layout and of variants.

    Variants: one station fewer and one more, the stations in one plane, one tool offset
    fewer and one more, every other grid point (alone and with one station or offset
    more). The uncertainty is the posterior standard uncertainty of the volumetric error
    (length of the 3-D error vector) at the planned grid points (for every variant),
    for a reading noise ``noise_um`` and the prior scales of a typical machining centre; the
    machine time counts the dwell at every point and the moves at ``feed_mm_min`` (set-up
    time of the tracker and of the tool offsets not included).

    Parameters
    ----------
    session : Session
        Planned session with multilateration measurements.
    options : IdentifyOptions
        Known errors, roll, tilts, as for identification.
    noise_um : float
        Reading noise assumed (tracker + machine repeatability) [um].
    dwell_s : float
        Dwell per point [s].
    feed_mm_min : float
        Feed of the moves between points [mm/min].

    Returns
    -------
    list of dict
        ``design`` (plain words), ``stations``, ``offsets``, ``points``, ``u_max_um``,
        ``u_rms_um``, ``machine_time_h``, ``readings``; the planned layout first.
    """
    from volcal.plan.multilateration import default_stations

    ms = [m for m in session.measurements if m.kind == "multilateration"]
    st = np.unique(np.array([station_of(m) for m in ms]), axis=0)
    offs = np.unique(np.array([m.tool_offset for m in ms]), axis=0)
    q = ms[0].positions
    variants: list[tuple[str, NDArray, NDArray, NDArray]] = [("as planned", st, offs, q)]
    if st.shape[0] > 3:
        variants.append((f"{st.shape[0] - 1} stations", st[:-1], offs, q))
    extra = default_stations(session.travel, list(offs), 8)
    far = extra[np.argmax([np.linalg.norm(st - e, axis=1).min() for e in extra])]
    variants.append((f"{st.shape[0] + 1} stations", np.vstack([st, far]), offs, q))
    flat = st.copy()
    flat[:, 2] = st[:, 2].mean()
    if np.ptp(st[:, 2]) > 1.0:
        variants.append(("stations in one plane (same height)", flat, offs, q))
    if offs.shape[0] > 1:
        variants.append((f"{offs.shape[0] - 1} tool offset(s)", st, offs[:-1], q))
    third = offs[0] + np.array([-100.0, 100.0, -100.0])
    variants.append((f"{offs.shape[0] + 1} tool offsets", st, np.vstack([offs, third]), q))
    axes = [np.unique(np.round(q[:, k], 6)) for k in range(3)]
    keep = np.all([np.isin(np.round(q[:, k], 6), axes[k][::2]) for k in range(3)], axis=0)
    if keep.sum() >= 8 and keep.sum() < q.shape[0]:
        variants.append(("every other grid point", st, offs, q[keep]))
        variants.append((f"{st.shape[0] + 1} stations, every other grid point",
                         np.vstack([st, far]), offs, q[keep]))
        variants.append((f"{offs.shape[0] + 1} tool offsets, every other grid point", st,
                         np.vstack([offs, third]), q[keep]))
    out = []
    for label, s_, o_, q_ in variants:
        fig = _figures(_variant(session, s_, o_, q_), options, noise_um, dwell_s, feed_mm_min,
                       q)
        out.append({"design": label, "stations": int(s_.shape[0]), "offsets": int(o_.shape[0]),
                    "points": int(q_.shape[0]), **fig})
    return out


def layout_messages(rows: list[dict]) -> list[str]:
    """The layout comparison in plain words, with a proposal.

    Parameters
    ----------
    rows : list of dict
        :func:`compare_layouts` output (planned layout first).

    Returns
    -------
    list of str
    """
    base = rows[0]
    lines = ["Multilateration layouts (volumetric standard uncertainty at the grid points, "
             "max / RMS, and machine time without set-up):"]
    for r in rows:
        lines.append(f"  {r['design']}: {r['stations']} stations x {r['offsets']} offsets x "
                     f"{r['points']} points: u = {r['u_max_um']:.2f} / {r['u_rms_um']:.2f} um, "
                     f"{r['machine_time_h']:.1f} h")
    t0, u0 = base["machine_time_h"], base["u_max_um"]
    same_time = [r for r in rows[1:] if r["machine_time_h"] <= 1.05 * t0
                 and r["u_max_um"] < 0.9 * u0]
    cheaper = [r for r in rows[1:] if r["machine_time_h"] < 0.8 * t0
               and r["u_max_um"] <= 1.1 * u0]
    better = [r for r in rows[1:] if r["u_max_um"] < 0.8 * u0]
    if same_time:
        best = min(same_time, key=lambda r: r["u_max_um"])
        lines.append(f"Proposal: {best['design']} lowers the uncertainty to "
                     f"{best['u_max_um']:.2f} um (from {u0:.2f} um) in about the same machine "
                     f"time ({best['machine_time_h']:.1f} h instead of {t0:.1f} h).")
    elif cheaper:
        best = min(cheaper, key=lambda r: r["machine_time_h"])
        lines.append(f"Proposal: {best['design']} gives about the same uncertainty "
                     f"({best['u_max_um']:.2f} um) in {best['machine_time_h']:.1f} h instead of "
                     f"{t0:.1f} h.")
    elif better:
        best = min(better, key=lambda r: r["u_max_um"] * r["machine_time_h"])
        lines.append(f"Proposal: {best['design']} lowers the uncertainty to "
                     f"{best['u_max_um']:.2f} um (from {u0:.2f} um) for "
                     f"{best['machine_time_h']:.1f} h of machine time instead of {t0:.1f} h.")
    else:
        lines.append("The planned layout is a good compromise among these variants.")
    return lines
