"""Kind probe_sphere and ``volcal locate``: plan, simulate, read, identify; bad input refused."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.identify.location import identify_location
from volcal.kinds import kind_of
from volcal.kinds.probe_sphere import ProbeSetup, five_axis_machine, sphere_readings
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session
from volcal.steps.locate import locate
from volcal_cli_helpers import volcal_process


class _Run:
    def __init__(self, p):
        self.exit_code = p.returncode
        self.output = p.stdout + p.stderr


def run_cli(args):
    return _Run(volcal_process(*args))

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """A planned, simulated probe_sphere session written with its truth (volcal simulate)."""
    folder = tmp_path_factory.mktemp("probe") / "s"
    assert run_cli(["plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ", "--tests",
                    "probe_sphere", "-o", str(folder)]).exit_code == 0
    assert run_cli(["simulate", str(folder), "--seed", "7"]).exit_code == 0
    return folder


def _truth(folder):
    doc = tomllib.loads((folder / "truth" / "setup.toml").read_text())["setup"]["probe_sphere"]
    return doc["location"], np.array(doc["sphere_mm"])


def test_located_errors_within_their_uncertainty(simulated):
    """volcal locate --json on a simulated session: every determined error within 2.5 U/2 of
    what the poses determine of the hidden truth (the fit to its exact readings)."""
    out = simulated.parent / "loc.json"
    r = run_cli(["locate", str(simulated), "--model", str(simulated / "truth" / "machine.csv"),
                 "--json", "-o", str(out)])
    assert r.exit_code == 0, r.output
    doc = json.loads(out.read_text())
    assert doc["format"] == "volcal-location/1" and doc["chain"] == "CAXYFZ"
    assert doc["determined"] == ["EX0C", "EY0C", "EA0C", "EB0C", "EY0A", "EZ0A", "EB0A", "EC0A"]
    assert set(doc["redundant"]) == {"EC0C", "EA0A"}
    assert doc["rms_before_um"] > 100.0 and doc["rms_after_um"] < 1.5
    # the reference: the same fit on the exact readings of the hidden machine
    location, sphere = _truth(simulated)
    s = read_session(simulated)
    m = s.measurements[0]
    from volcal.session.errortable import read_error_table

    linear = read_error_table(simulated / "truth" / "machine.csv")
    exact = kind_of("probe_sphere").exact(linear, m, ProbeSetup("CAXYFZ", location, sphere))
    m.positions = exact
    ref = identify_location(five_axis_machine(m, linear), [sphere_readings(m)]).estimate
    rows = {row["name"]: row for row in doc["location_errors"]}
    for n, v in ref.items():
        assert abs(rows[n]["value"] - v) < 1.25 * rows[n]["U"], n
    # and the named combination of the redundant A zero, against the truth itself
    assert rows["EA0C"]["value"] == pytest.approx(location["EA0C"] - location["EA0A"],
                                                  abs=1.5 * rows["EA0C"]["U"] + 1.0)


def test_round_trip_and_dispersion(simulated, tmp_path):
    s = read_session(simulated)
    m = s.measurements[0]
    assert m.kind == "probe_sphere" and m.target == "touch_probe" and m.n == 30
    assert set(m.columns) >= {"c_deg", "a_deg"}
    # the dispersion of the configured kinematics: the pivots are off by up to 2 mm
    assert 100.0 < np.max(m.deviation) < 10000.0
    write_session(s, tmp_path / "copy")
    back = read_session(tmp_path / "copy")
    np.testing.assert_array_equal(back.measurements[0].positions, m.positions)
    assert back.measurements[0].meta == m.meta


def test_a_perfect_machine_reports_one_centre():
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("probe_sphere:cb",), runs=2)
    m = s.measurements[0]
    assert m.meta["chain"] == "CBXYFZ"
    c = kind_of("probe_sphere").exact(random_machine(TRAVEL, "XYFZ", seed=1).scaled(0.0), m)
    from volcal.kinds.probe_sphere import dispersion_um

    assert np.max(dispersion_um(m, c)) < 1e-6


def _edit(folder, old, new, tmp_path, name="session.toml"):
    import shutil

    dst = tmp_path / "edit"
    shutil.copytree(folder, dst)
    p = dst / name
    text = p.read_text()
    assert old in text, old
    p.write_text(text.replace(old, new, 1))
    return dst


@pytest.mark.parametrize("old,new,key", [
    ('chain = "CAXYFZ"\n', "", "measurements[0].chain"),
    ('chain = "CAXYFZ"', 'chain = "CAXY"', "measurements[0].chain"),
    ('chain = "CAXYFZ"', 'chain = "XYFZ"', "measurements[0].chain"),
    ("a = [400.0, 300.0, 215.353]", "b = [400.0, 300.0, 215.353]", "measurements[0].pivot_mm.b"),
    ("a = [400.0, 300.0, 215.353]", "a = [400.0, 300.0]", "measurements[0].pivot_mm.a"),
    ("sphere_mm = [550.0, 300.0, 375.353]", "sphere_mm = 5", "measurements[0].sphere_mm"),
    ("noise_um = 1.0", "noise_um = -1.0", "measurements[0].noise_um"),
])
def test_bad_keys_are_refused_naming_the_key(simulated, tmp_path, old, new, key):
    folder = _edit(simulated, old, new, tmp_path)
    with pytest.raises(VolcalInputError) as exc:
        read_session(folder)
    assert exc.value.column == key and exc.value.file == str(folder / "session.toml")


@pytest.mark.parametrize("old,new,row,column", [
    ("c_deg,a_deg,x_mm,y_mm,z_mm", "c_deg,a_deg,x_mm,y_mm,zz", None, "z_mm"),
    ("c_deg,a_deg,", "c_deg,b_deg,", None, "a_deg"),
])
def test_bad_csv_is_refused_naming_row_and_column(simulated, tmp_path, old, new, row, column):
    folder = _edit(simulated, old, new, tmp_path, "probe_sphere.csv")
    with pytest.raises(VolcalInputError) as exc:
        read_session(folder)
    assert exc.value.file == str(folder / "probe_sphere.csv") and exc.value.column == column


def test_empty_cell_and_missed_pose(simulated, tmp_path):
    p = simulated / "probe_sphere.csv"
    lines = p.read_text().splitlines()
    f = lines[3].split(",")
    folder = _edit(simulated, lines[3], ",".join(f[:3] + [""] + f[4:]), tmp_path,
                   "probe_sphere.csv")
    with pytest.raises(VolcalInputError) as exc:
        read_session(folder)
    assert (exc.value.row, exc.value.column) == (4, "y_mm")
    (folder / "probe_sphere.csv").write_text(
        p.read_text().replace(lines[3], ",".join(f[:2] + ["missed", "missed", "missed"] + f[5:])))
    s = read_session(folder)
    assert s.measurements[0].n == 29
    assert locate(s).result.identifiability.free[0] == "EX0C"


def test_locate_refusals(simulated, tmp_path):
    r = run_cli(["locate", str(simulated), "--prior-u", "-1"])
    assert r.exit_code == 2 and "--prior-u -1" in r.output
    r = run_cli(["locate", str(simulated), "--measurements", "nope"])
    assert r.exit_code == 2 and "--measurements 'nope'" in r.output
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("linear:x",), runs=2)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=1), SimulationOptions(seed=2))
    write_session(s, tmp_path / "lin")
    r = run_cli(["locate", str(tmp_path / "lin")])
    assert r.exit_code == 2 and "no probe_sphere test" in r.output
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("probe_sphere",), runs=2)
    with pytest.raises(VolcalInputError, match="is not measured"):
        locate(s)


def test_locate_names_each_configuration_of_a_session_that_mixes_them(tmp_path):
    """A CA trunnion's probe test beside a CB trunnion's R-test (one session, two machine
    configurations): refused naming each test's chain and pivots and the option that
    picks one (it said only "another chain or pivots"); with it, located."""
    folder = tmp_path / "s"
    assert run_cli(["plan", "--tests", "probe_sphere:ca,r_test:cb", "-o", str(folder)]
                   ).exit_code == 0
    assert run_cli(["simulate", str(folder), "--seed", "3"]).exit_code == 0
    r = run_cli(["locate", str(folder)])
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert ("the session's sphere tests describe 2 machine configurations: probe_sphere "
            "(chain CAXYFZ, pivots A (" in r.output)
    assert "r_test_cb (chain CBXYFZ, pivots B (" in r.output
    assert "locate one at a time, e.g. --measurements probe_sphere" in r.output
    r = run_cli(["locate", str(folder), "--measurements", "r_test_cb"])
    assert r.exit_code == 0, r.output


def test_simulation_shares_one_machine_between_tests():
    """Two tests of one chain (a second sphere): one hidden machine, two spheres."""
    import copy

    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("probe_sphere",), runs=2)
    m2 = copy.deepcopy(s.measurements[0])
    m2.id, m2.file, m2.meta["sphere"] = "p2", "p2.csv", "S2"
    s.measurements.append(m2)
    linear = random_machine(TRAVEL, "XYFZ", seed=1)
    setups = simulate_session(s, linear, SimulationOptions(seed=2))
    a, b = (setups[m.id] for m in s.measurements)
    assert a.location == b.location and np.any(a.sphere_mm != b.sphere_mm)
    assert locate(s).result.rms_after_um > 2.0  # the linear errors left out
    res = locate(s, model=linear)
    assert res.measurements == ("probe_sphere", "p2") and res.result.rms_after_um < 1.5


def test_python_face_calls_the_step(simulated):
    """Calibration.locate: the step on the calibration's session (docs/architecture.md)."""
    from volcal import Calibration
    from volcal.session.errortable import read_error_table

    cal = Calibration.open(simulated)
    linear = read_error_table(simulated / "truth" / "machine.csv")
    a = cal.locate(model=linear)
    b = locate(simulated, model=simulated / "truth" / "machine.csv")
    assert a.to_json() == b.to_json()


def _probe_log(centres, angles, radius, rng=None, noise_mm=0.0):
    """A LinuxCNC probe log: 5 points per pose (top, 4 sides 45 deg down), X Y Z A B C U V W."""
    dirs = [np.array([0.0, 0.0, 1.0])] + [
        np.array([np.cos(t) * np.cos(np.pi / 4), np.sin(t) * np.cos(np.pi / 4),
                  np.sin(np.pi / 4)]) for t in np.deg2rad([0, 90, 180, 270])]
    lines = []
    for i, c in enumerate(centres):
        for d in dirs:
            p = c + radius * d + (rng.normal(0, noise_mm, 3) if rng is not None else 0.0)
            abc = [angles.get(r, np.zeros(len(centres)))[i] for r in "ABC"]
            lines.append(" ".join(f"{v:.6f}" for v in [*p, *abc, 0.0, 0.0, 0.0]))
    return "\n".join(lines) + "\n"


def test_fit_sphere_hand_values():
    from volcal.importer.probe_log import fit_sphere

    c0 = np.array([10.0, -20.0, 30.0])
    pts = np.array(_probe_log([c0], {}, 12.5).split(), dtype=float).reshape(-1, 9)[:, :3]
    # the log's 1 nm resolution, amplified by points on the upper half only
    c, r, rms = fit_sphere(pts)
    np.testing.assert_allclose(c, c0, atol=5e-6)
    assert r == pytest.approx(12.5, abs=5e-6) and rms < 1e-3
    c, r, _ = fit_sphere(pts[:4], radius_mm=12.5)
    np.testing.assert_allclose(c, c0, atol=5e-6)


def test_import_linuxcnc_probe_log(simulated, tmp_path):
    """volcal import LOG --session S --measurement ID: the centres of the fitted poses."""
    import shutil

    from volcal.kinds.probe_sphere import dispersion_um

    s = read_session(simulated)
    m = s.measurements[0]
    ang = {r.upper(): m.columns[f"{r}_deg"] for r in ("c", "a")}
    log = tmp_path / "probe.txt"
    log.write_text(_probe_log(m.positions, ang, 12.5 + 1.0))
    folder = tmp_path / "planned"
    assert run_cli(["plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ", "--tests",
                    "probe_sphere", "-o", str(folder)]).exit_code == 0
    r = run_cli(["import", str(log), "--session", str(folder), "--measurement", "probe_sphere"])
    assert r.exit_code == 0, r.output
    got = read_session(folder).measurements[0]
    np.testing.assert_allclose(got.positions, m.positions, atol=2e-6)
    np.testing.assert_allclose(got.deviation, dispersion_um(m, m.positions), atol=5e-3)
    assert got.meta["import"]["layout"] == "linuxcnc-probe-log"
    # a damaged line is named; a log of another program is refused
    bad = tmp_path / "bad.txt"
    bad.write_text(log.read_text().replace("\n", "\n1 2 3\n", 1))
    shutil.copytree(folder, tmp_path / "again")
    r = run_cli(["import", str(bad), "--session", str(tmp_path / "again"), "--measurement",
                 "probe_sphere", "--replace"])
    assert r.exit_code == 2 and "bad.txt" in r.output and "2" in r.output
    short = tmp_path / "short.txt"
    short.write_text("".join(log.read_text().splitlines(keepends=True)[:50]))
    r = run_cli(["import", str(short), "--session", str(tmp_path / "again"), "--measurement",
                 "probe_sphere", "--replace"])
    assert r.exit_code == 2 and "10 poses" in r.output


def test_locate_writes_the_linuxcnc_hal_file(simulated, tmp_path):
    hal = tmp_path / "trt.hal"
    r = run_cli(["locate", str(simulated), "--model", str(simulated / "truth" / "machine.csv"),
                 "--linuxcnc-hal", str(hal), "--z-rot-point-mm", "-5"])
    assert r.exit_code == 0, r.output
    text = hal.read_text()
    setp = dict(line.split()[1:] for line in text.splitlines() if line.startswith("setp "))
    assert set(setp) == {f"xyzac-trt-kins.{p}" for p in
                         ("x-rot-point", "y-rot-point", "z-rot-point", "y-offset", "z-offset")}
    assert float(setp["xyzac-trt-kins.z-rot-point"]) == -5.0
    location, _ = _truth(simulated)
    # C's line: the configured pivot plus EX0C, within a few um (the fit without tilts)
    assert float(setp["xyzac-trt-kins.x-rot-point"]) == pytest.approx(
        400.0 + location["EX0C"] * 1e-3, abs=0.02)
    assert "not held by the kinematics" in text and "EA0C" in text


def test_control_angle_sign_for_linuxcncs_trt_kinematics(simulated, tmp_path):
    """control_angle_sign = -1: the program turns to minus volcal's angles and the probe log
    (the control's angles) is read back as volcal's."""
    import shutil

    from volcal.kinds import kind_of
    from volcal.program.steps import ProgramOptions

    s = read_session(simulated)
    m = s.measurements[0]
    ang = {r.upper(): m.columns[f"{r}_deg"] for r in ("c", "a")}
    folder = tmp_path / "planned"
    assert run_cli(["plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ", "--tests",
                    "probe_sphere", "-o", str(folder)]).exit_code == 0
    toml = folder / "session.toml"
    toml.write_text(toml.read_text().replace("noise_um = 1.0", "noise_um = 1.0\n"
                                             "control_angle_sign = -1"))
    planned = read_session(folder, require_deviation=False).measurements[0]
    text, _ = kind_of("probe_sphere").program_text(planned, "linuxcnc", "P", 1,
                                                   ProgramOptions(safe_z_mm=500.0))
    assert "G0 C-0.000 A90.000" in text or "G0 C0.000 A90.000" in text  # volcal A = -90
    log = tmp_path / "probe.txt"
    log.write_text(_probe_log(m.positions, {k: -v for k, v in ang.items()}, 14.0))
    shutil.copytree(folder, tmp_path / "b")
    r = run_cli(["import", str(log), "--session", str(folder), "--measurement", "probe_sphere"])
    assert r.exit_code == 0, r.output
    np.testing.assert_allclose(read_session(folder).measurements[0].positions, m.positions,
                               atol=2e-6)
    log.write_text(_probe_log(m.positions, ang, 14.0))  # volcal's angles: refused
    r = run_cli(["import", str(log), "--session", str(tmp_path / "b"), "--measurement",
                 "probe_sphere"])
    assert r.exit_code == 2 and "planned" in r.output


def test_advise_says_what_the_planned_poses_determine():
    """volcal advise on a planned session with a probe_sphere test beside a linear one."""
    from volcal.steps.advise import advise

    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("probe_sphere", "linear:x"), runs=2)
    msgs = [m for m in advise(s).messages if m.startswith("probe_sphere (CAXYFZ)")]
    assert any("8 of 10 location errors are determined" in m for m in msgs)
    assert any("No candidate reading separates EC0C, EA0A" in m for m in msgs)


def test_report_section_lists_the_location_errors_with_u(simulated):
    """The kind's report section: every location error, value and U, the redundant ones
    named; the scatter before and after."""
    from types import SimpleNamespace

    s = read_session(simulated)
    sec = kind_of("probe_sphere").report_section(SimpleNamespace(session=s, result=None))
    assert sec is not None and sec.id == "location"
    table = sec.tables[0]
    names = [r[0] for r in table.rows]
    assert names == ["EX0C", "EY0C", "EA0C", "EB0C", "EC0C", "EY0A", "EZ0A", "EB0A", "EC0A",
                     "EA0A"]
    ec0c = table.rows[names.index("EC0C")]
    assert ec0c[2] == "-" and ec0c[5].startswith("redundant")
    ex0c = table.rows[0]
    location, _ = _truth(simulated)
    # perfect linear axes assumed here (the simulation's are small): within a few U
    assert abs(float(ex0c[2]) - location["EX0C"]) < 20.0
    assert "with the configured kinematics" in table.note
    assert any("8 of 10 location errors are determined" in p for p in sec.paragraphs)


def test_no_laser_plausibility_warnings_on_sphere_centres(simulated):
    """The laser readings' checks (order of the rows, first reading ~0) do not apply."""
    assert not [w for w in read_session(simulated).warnings if w.startswith("probe_sphere:")]
