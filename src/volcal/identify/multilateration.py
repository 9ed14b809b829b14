"""Multilateration readings in the unified estimator: rows, station nuisances, Gauss-Newton.

Rows (:func:`row_block`, registered in :data:`volcal.identify.design.ROW_BLOCKS`): a
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
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from volcal.measure.multilateration import station_key, station_of, tracker_jacobian
from volcal.session.format import Session
from volcal.session.multilateration import length_from_deviation

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
    d = np.linalg.norm(meas.positions + meas.tool_offset - S, axis=1)
    y = (L - L[0] + d[0] - d) * 1e3
    key = station_key(meas)
    cols = [np.ones(meas.n), U[:, 0], U[:, 1], U[:, 2]]
    names = [f"{meas.id}:offset", f"{key}:station_x", f"{key}:station_y", f"{key}:station_z"]
    if drift and "time_s" in meas.columns and np.ptp(meas.columns["time_s"]) > 0:
        cols.append(meas.columns["time_s"] / 3600.0)
        names.append(f"{meas.id}:drift")
    return J, y, np.stack(cols, 1), names


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
    from volcal.identify.api import _known
    from volcal.identify.design import build_design, choose_nodes
    from volcal.identify.prior import PriorStructure
    from volcal.identify.solver import solve_bayes

    nodes = choose_nodes(session, refine=1, max_nodes=min(options.max_nodes, 41))
    d = build_design(session, nodes, _known(options), options.drift, options.measurement_ids,
                     options.tilts)
    prior = PriorStructure.build(d.layout, d.free, options.kappa)
    scales = np.array(options.scales if options.scales is not None else (10.0, 5.0, 15.0))
    noise = options.noise_um if options.noise_um is not None else 1.0
    sol = solve_bayes(d, prior, scales, noise, options.squareness_std_urad, covariance=False)
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
        The final solution, linearised at the converged stations; ``fit['multilateration']``
        holds the fitted stations (:func:`station_table`) and the iterations.
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
        history.append(max(float(np.abs(dv).max()) for dv in step.values()))
        if history[-1] < STATION_TOLERANCE_UM:
            break
    # 2) the user's estimator at the converged stations; re-linearise if it still moves them
    final = options
    for _ in range(MAX_ITERATIONS):
        r = identify_fn(linearised(session, stations), final)
        step = _updates(r)
        move = max(float(np.abs(dv).max()) for dv in step.values())
        history.append(move)
        if move < STATION_TOLERANCE_UM:
            break
        for k, dv in step.items():
            stations[k] = stations[k] + dv * 1e-3
        ps = r.fit["prior_scales"]
        if options.scales is None and None not in (ps["positioning_um"], ps["straightness_um"],
                                                   ps["angular_urad"]):
            final = replace(options, scales=(ps["positioning_um"], ps["straightness_um"],
                                             ps["angular_urad"]),
                            kappa=ps["kappa"] or options.kappa)
    converged = history[-1] < STATION_TOLERANCE_UM
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
