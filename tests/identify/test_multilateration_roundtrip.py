"""identify(simulate(truth)) with a tracking interferometer (multilateration)."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from identify_helpers import TRAVEL, exact_fill, grid, seeds_session

from volcal.identify import IdentifyOptions, identify
from volcal.identify.design import build_design, choose_nodes
from volcal.measure.multilateration import TrackerOptions, reading_first_order
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import ErrorRanges, random_machine
from volcal.model.kinematics import volumetric_error
from volcal.model.names import COMPONENT_NAMES
from volcal.model.rigid import remove_rigid_body
from volcal.plan.multilateration import multilateration_tests
from volcal.session.format import Session

GRID = (5, 4, 4)
OFFSETS = ((0.0, 0.0, 0.0), (100.0, 100.0, 0.0))
OFFSETS3 = (*OFFSETS, (-100.0, 100.0, -150.0))
QUIET = TrackerOptions(station_error_mm=0.0, length_noise_um=0.0, length_noise_um_per_m=0.0)


def tracker_session(offsets=OFFSETS, grid_=GRID, stations=None, chain="XYFZ"):
    return Session("trk", chain, TRAVEL, multilateration_tests(TRAVEL, grid_, stations, offsets))


def moved(session, shift_mm):
    """The same readings with every station_mm written down wrong by ``shift_mm``."""
    from volcal.session.multilateration import deviation_from_length, length_from_deviation

    for m in session.measurements:
        S = np.asarray(m.meta["station_mm"])
        L = length_from_deviation(m.deviation, m.positions, m.tool_offset, S)
        m.meta["station_mm"] = [float(v) for v in S + shift_mm]
        m.deviation = deviation_from_length(L, m.positions, m.tool_offset, m.meta["station_mm"])


def test_noise_free_identifiable_part_is_exact():
    """First-order readings, stations exact: readings reproduced and every function the report
    calls determined equals the truth to numerical precision, roll included."""
    s = tracker_session(OFFSETS3)
    truth = random_machine(TRAVEL, "XYFZ", seed=21)
    for m in s.measurements:
        m.deviation = reading_first_order(truth, m)
    # a stated noise far below the errors: the prior only fills what the data do not see
    r = identify(s, IdentifyOptions(suggest=False, scales=(10.0, 5.0, 15.0, 15.0), noise_um=1e-4))
    assert max(np.abs(v).max() for v in r.residuals.values()) < 1e-8
    nodes = choose_nodes(s, refine=1)
    determined = [n for n, f in r.report.determined_fraction.items() if f > 1 - 1e-9]
    assert set(COMPONENT_NAMES) <= set(determined)  # 3 offsets: all 18 functions, roll too
    for name in COMPONENT_NAMES:
        k = COMPONENT_NAMES.index(name) // 6
        np.testing.assert_allclose(r.errors.function(name, nodes[k]),
                                   truth.function(name, nodes[k]), atol=1e-6, err_msg=name)
    for st in r.fit["multilateration"]["stations"]:
        np.testing.assert_allclose(st["fitted_mm"], st["nominal_mm"], atol=1e-6)


def test_stations_off_by_5_mm_converge_to_the_same_result():
    """Exact simulation without noise; the same readings with station_mm 5 mm off."""
    truth = random_machine(TRAVEL, "XYFZ", seed=22)
    s = tracker_session(grid_=(4, 3, 3))
    simulate_session(s, truth, SimulationOptions(noise_um=0.0), QUIET)
    r0 = identify(s, IdentifyOptions(suggest=False, scales=(10.0, 5.0, 15.0, 15.0), noise_um=0.3))
    s5 = tracker_session(grid_=(4, 3, 3))
    simulate_session(s5, truth, SimulationOptions(noise_um=0.0), QUIET)
    moved(s5, np.array([5.0, -5.0, 5.0]))
    r5 = identify(s5, IdentifyOptions(suggest=False, scales=(10.0, 5.0, 15.0, 15.0), noise_um=0.3))
    assert r5.fit["multilateration"]["converged"]
    q = grid(choose_nodes(s, refine=1))
    np.testing.assert_allclose(r5.predict(q)[0], r0.predict(q)[0], atol=1e-3)
    for a, b in zip(r0.fit["multilateration"]["stations"], r5.fit["multilateration"]["stations"],
                    strict=True):
        np.testing.assert_allclose(a["fitted_mm"], b["fitted_mm"], atol=1e-5)
        np.testing.assert_allclose(a["fitted_mm"], a["nominal_mm"], atol=2e-4)  # true stations


def test_every_relinearisation_runs_the_users_estimator(monkeypatch):
    """Free hyperparameters, noisy readings, station_mm 5 mm off, and the fast first phase
    (fixed typical scales) switched off, so that the user's estimator itself re-linearises
    several times: the final fit is the one of the same readings with the stations written
    down right, hyperparameters and all (the re-linearisations used to fix the four group
    scales of the first run, which dropped the trends, the nugget and the axes' curvature
    factors from the final fit)."""
    from volcal.identify import multilateration as ml

    truth = random_machine(TRAVEL, "XYFZ", seed=23)
    s = tracker_session(grid_=(4, 3, 3))
    simulate_session(s, truth, SimulationOptions(noise_um=0.3, seed=5), QUIET)
    s5 = tracker_session(grid_=(4, 3, 3))
    simulate_session(s5, truth, SimulationOptions(noise_um=0.3, seed=5), QUIET)
    moved(s5, np.array([5.0, -5.0, 5.0]))
    o = IdentifyOptions(suggest=False)
    r0 = identify(s, o)
    monkeypatch.setattr(ml, "_fast_step", lambda session, options: {})
    r5 = identify(s5, o)
    assert r5.fit["multilateration"]["converged"]
    assert r5.fit["multilateration"]["iterations"] >= 4  # 1 empty fast step, 3+ full runs
    p0, p5 = r0.fit["prior_scales"], r5.fit["prior_scales"]
    for key in ("positioning_um", "tilt_urad", "kappa", "positioning_trend_um_per_m",
                "tilt_trend_urad", "positioning_nugget_um"):
        assert p0[key] is not None, key
        assert p5[key] == pytest.approx(p0[key], rel=1e-2), key
    assert p5["kappa_axis"] == pytest.approx(p0["kappa_axis"], rel=1e-2)
    q = grid(choose_nodes(s, refine=1))
    np.testing.assert_allclose(r5.predict(q)[0], r0.predict(q)[0], atol=0.01)


def test_gauge_by_rank():
    """With 3 tool offsets every unknown (functions, stations, initial distances) is determined:
    the estimator's gauge on the functions also fixes the rigid motion of the stations with the
    work zone. With 2 offsets exactly the tilt of the tool-side axis about the offset
    difference is lost, one combination per measured Z level after the first."""
    for offsets, deficit in ((OFFSETS3, 0), (OFFSETS, GRID[2] - 1)):
        s = tracker_session(offsets)
        for m in s.measurements:
            m.deviation = np.zeros(m.n)
        d = build_design(s, choose_nodes(s, refine=1))
        A = d.A.toarray()
        assert np.linalg.matrix_rank(A) == A.shape[1] - deficit
        assert d.n_nuisance == 4 * 3 + len(s.measurements)  # shared stations + distances


@functools.lru_cache(maxsize=1)
def _noisy_case():
    """Exact simulation, stations known to ~1 mm, two tool offsets, tracker noise 0.2 um +
    0.3 um/m, machine repeatability 0.2 um; a machine with large roll errors."""
    ranges = ErrorRanges(angular_urad=(15.0, 40.0))
    truth = random_machine(TRAVEL, "XYFZ", seed=23, ranges=ranges)
    s = tracker_session()
    simulate_session(s, truth, SimulationOptions(noise_um=0.2, seed=5),
                     TrackerOptions(station_error_mm=1.0))
    return truth, s, identify(s, IdentifyOptions(suggest=False))


def test_noisy_round_trip_within_uncertainty_and_roll_recovered():
    truth, s, r = _noisy_case()
    q = grid(choose_nodes(s, refine=1))
    e, u = r.predict(q)
    diff = e - volumetric_error(truth, q)
    assert np.mean(np.abs(diff) <= 1.96 * u) > 0.9
    rms = np.sqrt(np.mean(remove_rigid_body(q, diff) ** 2))
    truth_rms = np.sqrt(np.mean(remove_rigid_body(q, volumetric_error(truth, q)) ** 2))
    assert rms < 0.1 * truth_rms
    # roll of X and Y (workpiece side) and of Z (tool side, seen through the offset)
    for name in ("EAX", "EBY", "ECZ"):
        k, c = divmod(COMPONENT_NAMES.index(name), 6)
        n = r.layout.nodes[k]
        err = np.abs(r.errors.function(name, n) - truth.function(name, n))
        assert err.max() < 0.15 * np.ptp(truth.function(name, n)), name
        assert np.all(err <= 3 * r.std[k][:, c] + 0.05), name
    # the fitted stations are the true ones (1 mm set-up error) within their uncertainty
    assert r.fit["multilateration"]["converged"]


def test_noisy_round_trip_beats_the_seeds_test_set():
    """The same machine measured with the seeds' full test set (lines, diagonals, step
    diagonals, laser noise 0.5 um): the tracker's volumetric error is much closer."""
    truth, s, r = _noisy_case()
    q = grid(choose_nodes(s, refine=1))
    rms = np.sqrt(np.mean(remove_rigid_body(q, r.predict(q)[0] - volumetric_error(truth, q))
                          ** 2))
    seeds = seeds_session("XYFZ", steps=4, runs=1)
    exact_fill(seeds, truth, seed=5, noise_um=0.5)
    rs = identify(seeds, IdentifyOptions(suggest=False))
    rms_seeds = np.sqrt(np.mean(remove_rigid_body(q, rs.predict(q)[0]
                                                  - volumetric_error(truth, q)) ** 2))
    assert rms < 0.5 * rms_seeds, (rms, rms_seeds)


@pytest.mark.parametrize("chain,seed", [("FXYZ", 24), ("YFXZ", 25)])
def test_other_chain_round_trip(chain, seed):
    truth = random_machine(TRAVEL, chain, seed=seed)
    s = tracker_session(chain=chain)
    simulate_session(s, truth, SimulationOptions(noise_um=0.2, seed=6),
                     TrackerOptions(station_error_mm=1.0))
    r = identify(s, IdentifyOptions(suggest=False))
    q = grid(choose_nodes(s, refine=1))
    e, u = r.predict(q)
    diff = e - volumetric_error(truth, q)
    assert np.mean(np.abs(diff) <= 1.96 * u) > 0.9
    truth_rms = np.sqrt(np.mean(remove_rigid_body(q, volumetric_error(truth, q)) ** 2))
    assert np.sqrt(np.mean(remove_rigid_body(q, diff) ** 2)) < 0.1 * truth_rms


def test_mixed_session_lines_diagonals_and_tracker():
    """Multilateration mixed with laser lines and diagonals: one fit, stations found."""
    from volcal.plan.planner import plan_session

    s = plan_session(TRAVEL, "XYFZ", 4, tests=("diagonal", "linear", "multilateration"),
                     runs=1, multilateration={"grid": (4, 3, 3)})
    truth = random_machine(TRAVEL, "XYFZ", seed=26)
    setups = simulate_session(s, truth, SimulationOptions(noise_um=0.2, seed=7),
                              TrackerOptions(station_error_mm=3.0))
    r = identify(s, IdentifyOptions(suggest=False, scales=(10.0, 5.0, 15.0, 15.0)))
    assert r.fit["multilateration"]["converged"]
    assert {m.kind for m in r.design.measurements} == {"diagonal", "linear", "multilateration"}
    by_key = {st["station"]: st for st in r.fit["multilateration"]["stations"]}
    from volcal.measure.multilateration import station_key

    for m in s.measurements:
        if m.kind == "multilateration":
            st = by_key[station_key(m)]
            err = np.abs(np.subtract(st["fitted_mm"], setups[m.id].station_mm)) * 1e3
            assert np.all(err < 5 * np.array(st["u_um"]) + 0.5), (err, st["u_um"])


def test_station_u_mm_is_the_prior_of_the_station():
    """``station_u_mm`` is the standard uncertainty of the station as set up: with a
    station 2 mm off and the default (5 mm) the data move it back to the truth; stated as
    1 nm, the prior holds it where the user put it (the Gauss-Newton loop keeps linearising
    around it) and its fitted uncertainty is at most that."""
    truth = random_machine(TRAVEL, "XYFZ", seed=22)
    shift = np.array([2.0, 0.0, -2.0])
    out = {}
    for u in (None, 1e-6):
        s = tracker_session(grid_=(4, 3, 3))
        simulate_session(s, truth, SimulationOptions(noise_um=0.0), QUIET)
        moved(s, shift)
        if u is not None:
            for m in s.measurements:
                m.meta["station_u_mm"] = u
        out[u] = identify(s, IdentifyOptions(suggest=False, scales=(10.0, 5.0, 15.0, 15.0),
                                             noise_um=0.3)).fit["multilateration"]["stations"]
    for free, held in zip(out[None], out[1e-6], strict=True):
        nominal = np.asarray(free["nominal_mm"])
        np.testing.assert_allclose(free["fitted_mm"], nominal - shift, atol=2e-4)
        # 2 mm of disagreement with thousands of readings pull a 1 nm prior by ~60 nm
        np.testing.assert_allclose(held["fitted_mm"], nominal, atol=1e-4)
        assert max(held["u_um"]) <= 1e-3 + 1e-9
