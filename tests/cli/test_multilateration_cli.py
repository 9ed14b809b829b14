"""``volcal plan --tests multilateration``, simulate, identify, program as a user runs them."""

from __future__ import annotations

import json
import tomllib

import numpy as np

from timing import scaled_timeout
from volcal.session.format import read_session
from volcal_cli_helpers import volcal_process


def volcal(*args):
    """``volcal *args`` in-process (VOLCAL_TEST_SUBPROCESS=1: in a process of its own)."""
    return volcal_process(*args, timeout=scaled_timeout(120))


def test_plan_simulate_identify_program(tmp_path):
    s = tmp_path / "S"
    r = volcal("plan", "--travel", "0:400,0:300,0:200", "--tests", "multilateration",
               "--grid", "3,3,3", "--stations", "3", "--tool-offsets", "0,0,0;60,60,0", "-o", s)
    assert r.returncode == 0, r.stderr
    assert "planned 6 measurements, 162 readings" in r.stdout
    planned = read_session(s, require_deviation=False)
    assert {m.kind for m in planned.measurements} == {"multilateration"}
    assert len({tuple(m.meta["station_mm"]) for m in planned.measurements}) == 3
    r = volcal("simulate", s, "--seed", "2", "--noise-um", "0.2")
    assert r.returncode == 0, r.stderr
    truth = tomllib.loads((s / "truth" / "setup.toml").read_text())
    actual = truth["setup"]["trk-s1-t1"]["station_mm"]
    nominal = planned.get("trk-s1-t1").meta["station_mm"]
    assert 0.0 < np.linalg.norm(np.subtract(actual, nominal)) < 20.0  # a few mm set-up error
    r = volcal("identify", s, "-o", tmp_path / "model.json")
    assert r.returncode == 0, r.stderr
    fit = json.loads((tmp_path / "model.json").read_text())["fit"]["multilateration"]
    st = {x["station"]: x for x in fit["stations"]}
    key = "station(" + ",".join(f"{v:.3f}".rstrip("0").rstrip(".") for v in nominal) + ")"
    # the fitted station is the true one (a few mm from the set-up) to a few um
    np.testing.assert_allclose(st[key]["fitted_mm"], actual, atol=0.02)
    r = volcal("program", s, "--dialect", "fanuc", "-o", tmp_path / "P")
    assert r.returncode == 0, r.stderr
    text = (tmp_path / "P" / "trk_s1_t1.nc").read_text()
    assert "station_mm" in text.lower() and text.count("G04") == 27  # a dwell per point
    for dialect in ("siemens", "heidenhain"):
        r = volcal("program", s, "--dialect", dialect, "-o", tmp_path / dialect)
        assert r.returncode == 0, r.stderr
        names = [p.name.lower() for p in (tmp_path / dialect).iterdir()]
        assert sum(n.startswith("trk") for n in names) == 6


def test_plan_bad_grid_is_a_clean_error(tmp_path):
    r = volcal("plan", "--tests", "multilateration", "--grid", "9,7", "-o", tmp_path / "S")
    assert r.returncode == 2 and "Traceback" not in r.stderr and "--grid" in r.stderr
