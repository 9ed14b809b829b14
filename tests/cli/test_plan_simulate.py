"""``volcal plan`` and ``volcal simulate`` as a user runs them (in-process through
``main()``; VOLCAL_TEST_SUBPROCESS=1 runs each in its own process,
:func:`volcal_cli_helpers.volcal_process`)."""

from __future__ import annotations

import numpy as np
import pytest

from timing import scaled_timeout
from volcal.session.errortable import read_error_table, write_error_table
from volcal.session.format import read_session
from volcal_cli_helpers import volcal_process


def volcal(*args, cwd=None):
    return volcal_process(*args, cwd=cwd, timeout=scaled_timeout(120))


def _one_clean_error(r):
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr + r.stdout
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert lines and lines[0].startswith("error:")
    return lines


def test_plan_then_simulate(tmp_path):
    s = tmp_path / "S"
    r = volcal("plan", "--travel", "0:400,0:300,0:200", "--chain", "FXYZ", "--steps", "4",
               "--runs", "2", "-o", s)
    assert r.returncode == 0, r.stderr
    assert "planned 17 measurements" in r.stdout
    planned = read_session(s, require_deviation=False)
    assert planned.chain == "FXYZ"
    np.testing.assert_array_equal(planned.travel, [[0, 400], [0, 300], [0, 200]])
    assert all(m.deviation is None for m in planned.measurements)
    r = volcal("simulate", s, "--seed", "3", "--noise-um", "0")
    assert r.returncode == 0, r.stderr
    done = read_session(s)
    truth = read_error_table(s / "truth" / "machine.csv")
    assert str(truth.chain) == "FXYZ"
    assert (s / "truth" / "setup.toml").is_file()
    # deviations are the exact readings of the truth (noise off)
    import tomllib

    from volcal.measure.readings import SetupErrors, reading_exact
    setup = tomllib.loads((s / "truth" / "setup.toml").read_text())["setup"]
    for m in done.measurements:
        su = SetupErrors(np.array(setup[m.id]["mirror_tilt_urad"]),
                         np.array(setup[m.id]["beam_tilt_urad"]))
        np.testing.assert_allclose(m.deviation, reading_exact(truth, m, su), atol=2e-5)


def test_simulate_with_machine_file(tmp_path):
    from conftest import machine

    s = tmp_path / "S"
    assert volcal("plan", "--steps", "2", "--tests", "diagonal", "-o", s).returncode == 0
    m = machine("XYFZ", seed=9).scaled(0.0)
    m.values[0][:, 0] = np.linspace(0, 8.0, m.nodes[0].size)  # 8 um over X
    write_error_table(m, tmp_path / "M.csv")
    r = volcal("simulate", s, "--machine", tmp_path / "M.csv", "--noise-um", "0",
               "--mirror-urad", "0")
    assert r.returncode == 0, r.stderr
    d = read_session(s).get("diag-ppp")
    np.testing.assert_allclose(d.deviation[-1], 8.0 * d.beam_direction[0], atol=1e-3)


@pytest.mark.parametrize("args", [
    ["plan", "--travel", "0:800,0:600", "-o", "{tmp}/x"],
    ["plan", "--travel", "0:800,0:600,500:0", "-o", "{tmp}/x"],
    ["plan", "--tests", "spiral", "-o", "{tmp}/x"],
    ["plan", "--tool-offset", "1,2", "-o", "{tmp}/x"],
    ["plan", "--steps", "0", "-o", "{tmp}/x"],
    ["simulate", "{tmp}/missing"],
    ["simulate", "{tmp}/S", "--machine", "{tmp}/nothing.csv"],
])
def test_bad_input_exit_2_without_traceback(tmp_path, args):
    assert volcal("plan", "--steps", "2", "--tests", "linear", "-o", tmp_path / "S",
                  ).returncode == 0
    r = volcal(*[a.format(tmp=tmp_path) for a in args])
    _one_clean_error(r)
    assert not (tmp_path / "x").exists()


def test_corrupted_session_names_file_row_column(tmp_path):
    s = tmp_path / "S"
    assert volcal("plan", "--steps", "2", "--tests", "diagonal", "-o", s).returncode == 0
    p = s / "diag-npp.csv"
    lines = p.read_text().splitlines()
    lines[2] = lines[2].replace("0", "zero", 1)
    p.write_text("\n".join(lines) + "\n")
    lines = _one_clean_error(volcal("simulate", s))
    text = " ".join(lines)
    assert "diag-npp.csv" in text and "row 3" in text and "column" in text


def test_long_error_stays_on_one_line(tmp_path):
    lines = _one_clean_error(volcal("plan", "--chain", "QQQQ", "-o", tmp_path / "x"))
    assert len(lines) == 1


def test_usage_error_no_traceback(tmp_path):
    r = volcal("plan", "--steps", "abc", "-o", tmp_path / "x")
    assert r.returncode == 2
    assert "Traceback" not in r.stderr


def test_simulate_keeps_other_files(tmp_path):
    s = tmp_path / "S"
    assert volcal("plan", "--steps", "2", "--tests", "diagonal", "-o", s).returncode == 0
    (s / "notes.txt").write_text("keep me")
    assert volcal("simulate", s).returncode == 0
    assert (s / "notes.txt").read_text() == "keep me"
