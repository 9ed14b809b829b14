import numpy as np
import pytest
from typer.testing import CliRunner

from volcal.classic.lines import abbe_session, average_line, lever_offsets, lines_from_files
from volcal.cli import app
from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.errortable import read_error_table
from volcal.session.format import write_session

from .conftest import TRAVEL, no_angles

runner = CliRunner()


def _simulated(tmp_path, chain="XYFZ", tests=("linear",), seed=4, angles=True, noise=0.0):
    # the classic solutions reference the first target: keep it at the travel start
    s = plan_session(TRAVEL, chain, 8, tests=tests, runs=2, iso_spacing=False,
                     linear_margin_mm=0.0)
    vm = random_machine(TRAVEL, chain, seed)
    if not angles:
        vm = no_angles(vm)
    simulate_session(s, vm, SimulationOptions(noise_um=noise, mirror_misalignment_urad=0.0,
                                              seed=seed))
    folder = write_session(s, tmp_path / "session")
    return s, vm, folder


def test_average_line_groups_runs_and_directions():
    pos = np.zeros((6, 3))
    pos[:, 0] = [0, 10, 20, 20, 10, 0]
    pos[:, 1] = 5.0
    dev = np.array([0.0, 1.0, 2.0, 4.0, 3.0, 2.0])
    t, mean, point = average_line(pos, dev, 0)
    np.testing.assert_allclose(t, [0, 10, 20])
    np.testing.assert_allclose(mean, [1.0, 2.0, 3.0])
    assert point[1] == 5.0
    pos[4, 2] = 1.0
    with pytest.raises(VolcalInputError, match="row 6.*z_mm"):
        average_line(pos, dev, 0, "f.csv")


def test_lever_offsets_follow_the_chain():
    pts = [[0, 0, 0], [0, 600, 0], [0, 0, 500], [700, 0, 0]]
    # XYFZ: order X, Y, Z -> lever of X moves with y and z; of Y only with z; Z with none
    np.testing.assert_allclose(lever_offsets(pts, np.zeros(3), "XYFZ", 0),
                               [[0, 0], [600, 0], [0, 500], [0, 0]])
    np.testing.assert_allclose(lever_offsets(pts, np.zeros(3), "XYFZ", 1),
                               [[0, 0], [0, 0], [0, 500], [0, 0]])
    np.testing.assert_allclose(lever_offsets(pts, np.zeros(3), "XYFZ", 2), np.zeros((4, 2)))
    # ZFYX: order Z, Y, X -> lever of Z moves with x and y
    np.testing.assert_allclose(lever_offsets(pts, np.zeros(3), "ZFYX", 2),
                               [[0, 0], [0, 600], [0, 0], [700, 0]])
    # the tool offset always counts
    np.testing.assert_allclose(lever_offsets(pts[:2], [[0, 0, 0], [10, 20, 30]], "XYFZ", 2),
                               [[0, 0], [10, 20]])


def test_abbe_session_matches_truth_for_every_axis(tmp_path):
    # the planner makes the Abbe offsets the chain's lever-arm rule can see (a tool offset
    # where no machine move changes the lever arm), so all three axes are solved
    s, vm, _ = _simulated(tmp_path)
    res = {r.axis: r for r in abbe_session(s)}
    names = {0: ("EXX", "EBX", "ECX"), 1: ("EYY", "EAY", "ECY"), 2: ("EZZ", "EAZ", "EBZ")}
    for k, (pos, r1, r2) in names.items():
        x = res[k]
        assert x.positioning_um is not None, x.message
        # exact readings (beam aligned to the motion, no noise): second order only
        np.testing.assert_allclose(x.positioning_um, vm.function(pos, x.targets_mm), atol=1e-3)
        np.testing.assert_allclose(x.rotations_urad[:, 0], vm.function(r1, x.targets_mm),
                                   atol=2e-2)
        np.testing.assert_allclose(x.rotations_urad[:, 1], vm.function(r2, x.targets_mm),
                                   atol=2e-2)


def test_abbe_session_explains_gaps_of_lines_without_lever_arm(tmp_path):
    # lines moved by machine positions only (no tool offset): Y's x-offset and Z's offsets
    # give no lever arm in chain XYFZ, and the solver says why
    s, _, _ = _simulated(tmp_path)
    for m in s.measurements:
        if np.any(m.tool_offset):
            j = int(np.flatnonzero(m.tool_offset)[0])
            m.positions[:, j] = TRAVEL[j, 1]
            m.tool_offset = np.zeros(3)
    res = {r.axis: r for r in abbe_session(s)}
    assert res[0].positioning_um is not None
    assert res[1].positioning_um is None and "collinear" in res[1].message
    assert "moving X does not change" in res[1].message
    assert res[2].positioning_um is None and "same Abbe offset" in res[2].message


def test_cli_abbe_files_offsets_and_chain_agree(tmp_path):
    s, vm, folder = _simulated(tmp_path)
    files = [str(folder / f"linear-x{i}.csv") for i in (1, 2, 3)]
    out1, out2 = tmp_path / "a.csv", tmp_path / "b.csv"
    r = runner.invoke(app, ["classic", "abbe", *files, "--axis", "X", "--offsets",
                            "0,0;600,0;0,500", "-o", str(out1)])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["classic", "abbe", *files, "--axis", "X", "--chain", "XYFZ",
                            "-o", str(out2)])
    assert r.exit_code == 0, r.output
    a = np.loadtxt(out1, delimiter=",", skiprows=1)
    b = np.loadtxt(out2, delimiter=",", skiprows=1)
    np.testing.assert_allclose(a, b)
    assert out1.read_text().splitlines()[0] == "x_mm,EXX_um,EBX_urad,ECX_urad"
    np.testing.assert_allclose(a[:, 1], vm.function("EXX", a[:, 0]), atol=1e-3)
    t, devs, _ = lines_from_files(files, "X")
    assert devs.shape == (3, t.size)


def test_cli_abbe_errors(tmp_path):
    s, vm, folder = _simulated(tmp_path)
    files = [str(folder / f"linear-x{i}.csv") for i in (1, 2, 3)]
    r = runner.invoke(app, ["classic", "abbe", *files, "--axis", "X", "--offsets",
                            "0,0;100,100;200,200"])
    assert isinstance(r.exception, VolcalInputError) and "collinear" in str(r.exception)
    r = runner.invoke(app, ["classic", "abbe", *files, "--axis", "X", "--offsets", "0,0;1"])
    assert isinstance(r.exception, VolcalInputError)
    other = str(folder / "linear-y1.csv")
    r = runner.invoke(app, ["classic", "abbe", files[0], files[1], other, "--axis", "X",
                            "--offsets", "0,0;600,0;0,500"])
    assert isinstance(r.exception, VolcalInputError)
    assert "linear-y1.csv" in str(r.exception) and "row" in str(r.exception)
    r = runner.invoke(app, ["classic", "abbe", *files, "--axis", "X"])
    assert isinstance(r.exception, VolcalInputError) and "--chain" in str(r.exception)


def test_cli_step_diagonal_writes_exact_error_table(tmp_path):
    # beam aligned to the actual motion acts like a set-up tilt (first order): switch it
    # off by building readings on the nominal beam, then write and solve via the CLI
    from volcal.measure.readings import reading_first_order

    s = plan_session(TRAVEL, "FXYZ", 6, tests=("step-diagonal", "diagonal"))
    vm = no_angles(random_machine(TRAVEL, "FXYZ", 21))
    for m in s.measurements:
        m.deviation = reading_first_order(vm, m)
    folder = write_session(s, tmp_path / "sd")
    out = tmp_path / "errs.csv"
    r = runner.invoke(app, ["classic", "step-diagonal", str(folder), "-o", str(out)])
    assert r.exit_code == 0, r.output
    est = read_error_table(out)
    np.testing.assert_allclose(est.squareness, vm.squareness, atol=1e-4)
    q = est.nodes[0]
    np.testing.assert_allclose(est.function("EXX", q), vm.function("EXX", q), atol=1e-4)
    r = runner.invoke(app, ["classic", "diagonals", str(folder)])
    assert r.exit_code == 0, r.output
    assert "EC0Y" in r.output and "diag-ppp" in r.output


def test_cli_missing_step_diagonals(tmp_path):
    s, vm, folder = _simulated(tmp_path)
    r = runner.invoke(app, ["classic", "step-diagonal", str(folder)])
    assert isinstance(r.exception, VolcalInputError)
    r = runner.invoke(app, ["classic", "diagonals", str(folder)])
    assert isinstance(r.exception, VolcalInputError)
