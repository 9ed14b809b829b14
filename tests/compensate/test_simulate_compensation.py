"""``volcal simulate --compensation``: the virtual machine runs with the tables a
compensation folder holds (the as-left measurement of a virtual machine, session 18).

The machine with the tables active is checked against the table files themselves (the
LinuxCNC columns read here with numpy, not with volcal's reader): the positioning error
of each axis less the mean of the two trims, its reversal less their mean difference;
and the as-left session, identified, agrees with that machine as the as-found one agrees
with its own."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from typer.testing import CliRunner

from volcal import Calibration
from volcal.cli import app
from volcal.errors import VolcalInputError
from volcal.model.kinematics import volumetric_error
from volcal.session.format import read_session
from volcal.standards.volumetric import work_zone_grid

TRAVEL = [[0, 800], [0, 600], [0, 500]]


@pytest.fixture(scope="module")
def found(tmp_path_factory):
    d = tmp_path_factory.mktemp("asleft")
    c = Calibration.plan(TRAVEL, steps=6, runs=2, name="ASLEFT").simulate(seed=4)
    c.save(d / "FOUND")
    c.identify()
    c.compensate(d / "COMP", "linuxcnc", session=c.session)  # as --session: both directions
    assert "bidirectional = true" in (d / "COMP" / "volcal-compensation.toml").read_text()
    assert c.compensated is not None and len(c.compensated.line_checks) == 9
    c.result.to_json(d / "model.json")
    r = CliRunner().invoke(app, ["compensate", str(d / "model.json"), "--format", "linuxcnc",
                                 "--session", str(d / "FOUND"), "-o", str(d / "COMP-CLI")])
    assert r.exit_code == 0, r.output  # the command's tables: the same numbers
    for axis in "XYZ":
        np.testing.assert_array_equal(np.loadtxt(d / "COMP" / f"{axis}.comp"),
                                      np.loadtxt(d / "COMP-CLI" / f"{axis}.comp"))
    return c, d


def _rms_rigid_removed(q, d):
    from volcal.model.rigid import remove_rigid_body

    return float(np.sqrt(np.mean(np.sum(remove_rigid_body(q, d) ** 2, axis=1))))


def test_the_machine_runs_with_the_trims_of_the_files(found):
    c, d = found
    left = Calibration.plan(TRAVEL, steps=6, runs=2, name="ASLEFT").simulate(
        machine=c.truth, seed=5, compensation=d / "COMP")
    m0, m1 = c.truth, left.truth
    for k, axis in enumerate("XYZ"):
        cols = np.loadtxt(d / "COMP" / f"{axis}.comp")  # nominal, forward, reverse [mm]
        x, fwd, rev = cols[:, 0], 1000.0 * cols[:, 1], 1000.0 * cols[:, 2]
        inside = (x >= TRAVEL[k][0]) & (x <= TRAVEL[k][1])
        name = f"E{axis}{axis}"
        # trim = -error, added to the command: the error left is error + trim
        np.testing.assert_allclose(m1.function(name, x[inside]),
                                   m0.function(name, x[inside]) + 0.5 * (fwd + rev)[inside],
                                   atol=1e-9)
        assert np.ptp(fwd - rev) > 0 or abs(np.mean(fwd - rev)) > 0.1  # two directions
        xi, di = x[inside], (fwd - rev)[inside]  # the points span the travel, 20 mm apart
        mean = np.sum(0.5 * (di[1:] + di[:-1]) * np.diff(xi)) / (xi[-1] - xi[0])
        assert m1.reversal[k] == pytest.approx(m0.reversal[k] + mean, abs=1e-9)
        for other in "XYZ".replace(axis, ""):  # the straightness is not in LinuxCNC's tables
            np.testing.assert_allclose(m1.function(f"E{other}{axis}", x),
                                       m0.function(f"E{other}{axis}", x), atol=1e-12)
    np.testing.assert_array_equal(m1.squareness, m0.squareness)
    assert left.session.provenance["compensation"] == str(d / "COMP")
    # the as-left readings identify the machine with the tables active as well as the
    # same noise on the machine as found identifies that one; not the machine as found
    q = work_zone_grid(np.asarray(TRAVEL, float), 7)
    left.identify()
    again = Calibration.plan(TRAVEL, steps=6, runs=2, name="ASLEFT").simulate(
        machine=m0, seed=5)  # the machine as found, the same noise: no tables
    again.identify()
    err = {}
    for key, cal, truth in (("again", again, m0), ("left", left, m1), ("cross", left, m0)):
        e, _ = cal.result.predict(q)
        err[key] = _rms_rigid_removed(q, e - volumetric_error(truth, q))
    # measured: again 2.45, left 2.42, cross 5.97 um (rigid-body motion removed)
    assert err["left"] == pytest.approx(err["again"], rel=0.2), err
    assert err["cross"] > 2.0 * err["left"], err


def test_cli_writes_the_record_and_refuses_another_machine(found, tmp_path):
    c, d = found
    runner = CliRunner()
    Calibration.plan(TRAVEL, steps=6, runs=2, name="ASLEFT").save(tmp_path / "LEFT")
    r = runner.invoke(app, ["simulate", str(tmp_path / "LEFT"), "--machine",
                            str(d / "FOUND" / "truth" / "machine.csv"), "--seed", "5",
                            "--compensation", str(d / "COMP")])
    assert r.exit_code == 0, r.output
    assert "the tables of" in r.output
    record = (tmp_path / "LEFT" / "truth" / "compensation.toml").read_text(encoding="utf-8")
    assert 'controller_format = "linuxcnc"' in record and "bidirectional = true" in record
    s = read_session(tmp_path / "LEFT")
    assert s.provenance["compensation"] == str(d / "COMP")
    from volcal.report.pipeline import read_truth
    from volcal.report.sections import machine_section

    said = machine_section(SimpleNamespace(session=s, truth=read_truth(s))).paragraphs[-1]
    assert said.startswith("This session was simulated on a virtual machine running with "
                           f"the compensation tables of {d / 'COMP'} (an as-left")
    r = runner.invoke(app, ["simulate", str(tmp_path / "LEFT"), "--compensation", "NOPE"])
    assert isinstance(r.exception, VolcalInputError)  # main() prints it, exit status 2
    assert str(r.exception).startswith("--compensation NOPE: not a folder"), r.exception
    with pytest.raises(VolcalInputError, match="compensation=NOPE: not a folder"):
        Calibration.plan(TRAVEL, steps=6, name="ASLEFT").simulate(compensation="NOPE")
    other = Calibration.plan([[0, 900], [0, 600], [0, 500]], steps=6, name="OTHER")
    with pytest.raises(VolcalInputError, match="force"):
        other.simulate(compensation=d / "COMP")
    other.simulate(compensation=d / "COMP", force=True)  # refused above, applied here


@pytest.mark.parametrize("fmt", ["fanuc", "siemens", "isg"])
def test_the_machine_is_what_the_reports_after_removes(found, fmt):
    """Fanuc's stepwise tables, Siemens' cross (straightness) tables and ISG's 21
    functions: the volumetric error of the machine with the tables active is the machine
    as found less :meth:`WrittenTables.correction`, the "after" of the report and of
    ``compensate --session``, at every point of the work zone (checked: 1e-6 um from the
    files of `volcal compensate`, the same in memory)."""
    from volcal.compensate.readback import read_written_tables

    c, d = found
    c.compensate(d / f"C-{fmt}", fmt)
    left = Calibration.plan(TRAVEL, steps=6, runs=2, name="ASLEFT").simulate(
        machine=c.truth, seed=5, compensation=d / f"C-{fmt}")
    tables = read_written_tables(d / f"C-{fmt}", travel=TRAVEL)
    q = work_zone_grid(np.asarray(TRAVEL, float), 13)
    after = volumetric_error(c.truth, q) - tables.correction(q)
    np.testing.assert_allclose(volumetric_error(left.truth, q), after, atol=1e-6)
    assert np.abs(after).max() < np.abs(volumetric_error(c.truth, q)).max()


def test_a_grid_shifts_the_commanded_positions(found):
    """A 3-D grid of correction vectors (``volcal compensate --format grid``): the controller
    takes the grid's vector at each commanded position off the axes' motion. Without noise
    or set-up errors every as-left reading is the machine as found read at the commanded
    positions less the grid's vector there, the vector interpolated here from the file's
    own numbers by scipy (not volcal's reader); the record says ``grid = true`` and there
    is no truth to compare a model with (the as-left machine is no set of error functions).
    The as-left session, identified, shows the volumetric error left, a fraction of the
    machine's as found."""
    from scipy.interpolate import RegularGridInterpolator

    from volcal.measure.readings import SetupErrors, reading_exact
    from volcal.model.kinematics import UM

    c, d = found
    c.compensate(d / "GRID", "grid")
    exact = Calibration.plan(TRAVEL, steps=6, runs=2, name="ASLEFT").simulate(
        machine=c.truth, seed=5, noise_um=0.0, mirror_misalignment_urad=0.0,
        compensation=d / "GRID")
    assert exact.truth is None
    path = d / "GRID" / "volumetric_grid.csv"
    assert path.read_text().splitlines()[0] == \
        "x_mm,y_mm,z_mm,error_x_um,error_y_um,error_z_um"  # the error sign: removed
    rows = np.loadtxt(path, delimiter=",", skiprows=1)
    axes = [np.unique(rows[:, k]) for k in range(3)]
    table = np.full((*(a.size for a in axes), 3), np.nan)
    idx = [np.searchsorted(axes[k], rows[:, k]) for k in range(3)]
    table[idx[0], idx[1], idx[2]] = rows[:, 3:6]
    assert not np.isnan(table).any()  # a full grid
    f = 1.0
    grid = RegularGridInterpolator(axes, table, method="linear", bounds_error=False,
                                   fill_value=None)
    for m in exact.session.measurements:
        q = m.positions
        inside = np.clip(q, [a[0] for a in axes], [a[-1] for a in axes])
        q_act = q - f * grid(inside) * UM
        if m.kind == "linear":  # the machine's reversal, as for every bidirectional run
            k = m.axis
            q_act[:, k] += np.where(m.direction == "+", 0.5, -0.5) * c.truth.reversal[k] * UM
        want = reading_exact(c.truth, m, SetupErrors.none(), q_act)
        np.testing.assert_allclose(m.deviation, want - want[0], atol=1e-6, err_msg=m.id)
    left = Calibration.plan(TRAVEL, steps=6, runs=2, name="ASLEFT").simulate(
        machine=c.truth, seed=5, compensation=d / "GRID")
    left.save(d / "LEFT-GRID")
    record = (d / "LEFT-GRID" / "truth" / "compensation.toml").read_text(encoding="utf-8")
    assert 'controller_format = "grid"' in record and "grid = true" in record
    from volcal.report.pipeline import read_truth

    assert read_truth(read_session(d / "LEFT-GRID")) is None
    q = work_zone_grid(np.asarray(TRAVEL, float), 7)
    left.identify()
    e_left, _ = left.result.predict(q)
    e_found = volumetric_error(c.truth, q)
    rms_left, rms_found = _rms_rigid_removed(q, e_left), _rms_rigid_removed(q, e_found)
    # measured: 1.57 um left against 11.50 um as found (rigid-body motion removed)
    assert rms_left < 0.3 * rms_found, (rms_left, rms_found)


def test_a_grid_refuses_a_session_with_other_tests(found, tmp_path):
    c, d = found
    c.compensate(d / "GRID2", "grid")
    with pytest.raises(VolcalInputError, match=r"3-D grid .* not to r_test \(r_test\)"):
        Calibration.plan(TRAVEL, steps=6, tests="linear,r_test", name="ASLEFT").simulate(
            machine=c.truth, compensation=d / "GRID2")
