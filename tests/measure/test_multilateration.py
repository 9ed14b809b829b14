"""Tracking-interferometer reading model: exact vs first order, Jacobian, simulation, format."""

from __future__ import annotations

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.measure.multilateration import (
    TrackerOptions,
    length_exact,
    reading_first_order,
    station_key,
    tracker_jacobian,
)
from volcal.measure.simulate import SimulationOptions, simulate_session, truth_files
from volcal.measure.virtual import random_machine
from volcal.model.chain import parse_chain
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import first_order_pose, volumetric_error_exact
from volcal.model.parameters import ParameterLayout
from volcal.plan.multilateration import default_stations, multilateration_tests, serpentine_grid
from volcal.session.format import Measurement, Session, read_session, write_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def _meas(q, station, offset=(0, 0, 0), mid="t"):
    return Measurement(mid, "multilateration", "cat_eye", q, None, [1, 0, 0], offset,
                       meta={"station_mm": list(station)})


def test_perfect_machine_reads_the_nominal_distance_change():
    """3-4-5 triangles: station at the origin, points at distance 500 and 1000 mm."""
    m = _meas([[300, 400, 0], [600, 800, 0], [0, 0, 130]], (0, 0, 0))
    L = length_exact(MachineErrors.zero("XYFZ", [[0, 800], [0, 800], [0, 500]]), m)
    np.testing.assert_allclose(L, [0.0, 500.0, -370.0], atol=1e-12)


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ", "YFXZ"])
def test_exact_reading_matches_first_order(chain):
    """Second-order terms stay at the nm level for a realistic machine: the largest is
    ``|e_perp|^2 / (2 d)``, about 10 nm for errors of 40 um seen from 100 mm."""
    vm = random_machine(TRAVEL, chain, seed=4)
    q = serpentine_grid(TRAVEL, (5, 4, 3))
    for st, off in (((-100, -50, -200), (0, 0, -100)), ((900, 700, -150), (100, 100, -100))):
        m = _meas(q, st, off)
        from volcal.session.multilateration import deviation_from_length

        exact = deviation_from_length(length_exact(vm, m), q, off, st)
        e = volumetric_error_exact(vm, q, off)
        d = np.linalg.norm(q + off - st, axis=1)
        bound = (e**2).sum(1) * 1e-3 / d  # |e|^2 / d in um, twice the curvature term
        bound = bound + bound[0] + 2e-3    # both ends of the change; angle^2 x lever ~ 1 nm
        assert np.all(np.abs(exact - reading_first_order(vm, m)) <= bound)
        assert np.abs(exact).max() > 1.0  # the errors really show


def test_jacobian_is_the_projected_point_error_and_station_derivative():
    vm = random_machine(TRAVEL, "XYFZ", seed=2)
    q = serpentine_grid(TRAVEL, (4, 3, 3))
    off = np.array([50.0, -20.0, -100.0])
    S = np.array([-80.0, 40.0, -250.0])
    m = _meas(q, S, off)
    layout = ParameterLayout(tuple(vm.nodes))
    J, U = tracker_jacobian(parse_chain("XYFZ").order, layout.nodes, m, S)
    e, _ = first_order_pose(vm, q, off)
    u = (q + off - S) / np.linalg.norm(q + off - S, axis=1)[:, None]
    np.testing.assert_allclose(J @ layout.pack(vm), np.einsum("mi,mi->m", u, e), atol=1e-9)
    # station derivative by central differences of the exact distance [um per um]
    h = 1e-3
    for k in range(3):
        dS = np.zeros(3)
        dS[k] = h
        dp = np.linalg.norm(q + off - (S + dS), axis=1)
        dm = np.linalg.norm(q + off - (S - dS), axis=1)
        np.testing.assert_allclose((dp - dm) / (2 * h), U[:, k], atol=1e-9)


def test_simulation_shares_station_errors_and_writes_truth(tmp_path):
    ms = multilateration_tests(TRAVEL, (4, 3, 3))
    s = Session("m", "XYFZ", TRAVEL, ms)
    vm = random_machine(TRAVEL, "XYFZ", seed=1)
    opts = SimulationOptions(noise_um=0.0, seed=3)
    setups = simulate_session(s, vm, opts, TrackerOptions(station_error_mm=2.0,
                                                          length_noise_um=0.0,
                                                          length_noise_um_per_m=0.0))
    by_station: dict[str, list] = {}
    for m in s.measurements:
        by_station.setdefault(station_key(m), []).append(setups[m.id].station_mm)
        assert m.deviation[0] == 0.0
        # the exact reading at the actual station, stored as deviation from the nominal one
        from volcal.session.multilateration import length_from_deviation

        L = length_from_deviation(m.deviation, m.positions, m.tool_offset, m.meta["station_mm"])
        np.testing.assert_allclose(L, length_exact(vm, m, setups[m.id].station_mm), atol=1e-12)
    assert len(by_station) == 4
    for v in by_station.values():
        assert len(v) == 2 and np.array_equal(v[0], v[1])
    files = truth_files(vm, setups, opts)
    assert "station_mm" in files["truth/setup.toml"]


def test_default_layout_is_not_coplanar_and_outside_the_path():
    st = default_stations(TRAVEL)
    assert st.shape == (4, 3)
    # volume of the tetrahedron: clearly not coplanar
    vol = abs(np.linalg.det(st[1:] - st[0])) / 6
    assert vol > 1e5
    q = serpentine_grid(TRAVEL)
    assert q.shape == (9 * 7 * 6, 3)
    # serpentine: consecutive points one grid step apart
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    assert steps.max() <= max(np.ptp(TRAVEL, axis=1) / np.array([8, 6, 5])) + 1e-9


def test_session_round_trip_keeps_lengths(tmp_path):
    ms = multilateration_tests(TRAVEL, (3, 3, 2), station_u_mm=2.0)
    s = Session("m", "XYFZ", TRAVEL, ms)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=5), SimulationOptions(seed=1))
    write_session(s, tmp_path / "S")
    r = read_session(tmp_path / "S")
    for a, b in zip(s.measurements, r.measurements, strict=True):
        assert b.kind == "multilateration" and b.target == "cat_eye"
        assert b.meta["station_u_mm"] == 2.0
        np.testing.assert_allclose(a.deviation, b.deviation, atol=2e-5)
    text = (tmp_path / "S" / "trk-s1-t1.csv").read_text()
    assert text.splitlines()[0].startswith("x_mm,y_mm,z_mm,length_mm")
    assert float(text.splitlines()[1].split(",")[3]) == 0.0
    assert "beam_direction" not in (tmp_path / "S" / "session.toml").read_text()


SESSION = """format = "volcal-session/1"
[machine]
name = "m"
chain = "XYFZ"
[machine.travel_mm]
x = [0, 800]
y = [0, 600]
z = [0, 500]
[[measurements]]
id = "trk-s1-t1"
kind = "{kind}"
target = "{target}"
{station}
tool_offset_mm = [0, 0, -150]
file = "trk.csv"
"""


@pytest.mark.parametrize("kind,target,station,header,msg", [
    ("multilateration", "cat_eye", "", "length_mm", "station_mm"),
    ("multilateration", "retroreflector", "station_mm = [80, 60, -75]", "length_mm", "cat_eye"),
    ("linear", "cat_eye", "", "deviation_um", "multilateration"),
    ("multilateration", "cat_eye", "station_mm = [80, 60, -75]", "deviation_um", "length_mm"),
    ("multilateration", "cat_eye", "station_mm = [80, 60]", "length_mm", "station_mm"),
    ("multilateration", "cat_eye", "station_mm = [80, 60, -75]\nstation_u_mm = -1", "length_mm",
     "station_u_mm"),
])
def test_reader_errors_name_the_problem(tmp_path, kind, target, station, header, msg):
    (tmp_path / "session.toml").write_text(SESSION.format(kind=kind, target=target,
                                                          station=station))
    (tmp_path / "trk.csv").write_text(f"x_mm,y_mm,z_mm,{header}\n0,0,0,0\n100,0,0,0.1\n")
    with pytest.raises(VolcalInputError, match=msg):
        read_session(tmp_path)


def test_reader_accepts_the_documented_example(tmp_path):
    (tmp_path / "session.toml").write_text(SESSION.format(
        kind="multilateration", target="cat_eye", station="station_mm = [80.2, 60.0, -75.0]"))
    (tmp_path / "trk.csv").write_text("x_mm,y_mm,z_mm,length_mm\n0,0,0,0\n100,0,0,0.5\n")
    m = read_session(tmp_path).measurements[0]
    d = np.linalg.norm(m.positions + [0, 0, -150] - [80.2, 60.0, -75.0], axis=1)
    # deviation = reading minus nominal distance change [um]
    assert m.deviation[1] == pytest.approx((0.5 - (d[1] - d[0])) * 1e3, abs=1e-9)
