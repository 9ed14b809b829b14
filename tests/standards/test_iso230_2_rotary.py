"""ISO 230-2 for a rotary axis against a hand-worked data set, units, closure, budget.

The data set: 6 target angles over a full circle (0 and 360 deg, one physical position),
5 bidirectional runs. At target i the readings of run j (j = 1..5) are
``x_ij = mean_i + (j - 3) c_i`` [urad], so the mean is ``mean_i`` and the standard
deviation ``c_i sqrt(10 / 4) = c_i sqrt(2.5)`` exactly. The expected parameters below are
worked by hand from the ISO 230-2 definitions (clause 3), not by volcal:

* means up   0, 3, -2, 5, 1, 0.4; down 1, 4.5, -0.5, 6, 2.5, 1.2 [urad]
* c up 0.2, 0.4, 0.2, 0.4, 0.2, 0.2; c down 0.4, 0.2, 0.4, 0.2, 0.4, 0.2
* B_i = up - down = -1, -1.5, -1.5, -1, -1.5, -0.8; B = 1.5; B mean = -7.3 / 6
* E up = 5 - (-2) = 7; E down = 6 - (-0.5) = 6.5; E = 6 - (-2) = 8
* M: bidirectional means 0.5, 3.75, -1.25, 5.5, 1.75, 0.8 -> 5.5 + 1.25 = 6.75
* R up = R down = 4 x 0.4 sqrt(2.5); R = max(2 s_up + 2 s_down + |B_i|) =
  1.2 sqrt(2.5) + 1.5
* A up = (5 + 0.8 sqrt 2.5) - (-2 - 0.4 sqrt 2.5) = 7 + 1.2 sqrt 2.5;
  A down = (6 + 0.4 sqrt 2.5) - (-0.5 - 0.8 sqrt 2.5) = 6.5 + 1.2 sqrt 2.5;
  A = (6 + 0.4 sqrt 2.5) - (-2 - 0.4 sqrt 2.5) = 8 + 0.8 sqrt 2.5
* closure (360 minus 0): up 0.4, down 0.2
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from volcal.session.rotary import ARCSEC_URAD, arcsec_to_urad, urad_to_arcsec
from volcal_cli_helpers import run_volcal

TARGETS = [0.0, 47.3, 133.9, 222.6, 301.2, 360.0]
MEAN_UP = [0.0, 3.0, -2.0, 5.0, 1.0, 0.4]
MEAN_DN = [1.0, 4.5, -0.5, 6.0, 2.5, 1.2]
C_UP = [0.2, 0.4, 0.2, 0.4, 0.2, 0.2]
C_DN = [0.4, 0.2, 0.4, 0.2, 0.4, 0.2]
R25 = math.sqrt(2.5)
HAND = {"A": 8 + 0.8 * R25, "A_up": 7 + 1.2 * R25, "A_down": 6.5 + 1.2 * R25,
        "E": 8.0, "E_up": 7.0, "E_down": 6.5, "M": 6.75,
        "R": 1.2 * R25 + 1.5, "R_up": 1.6 * R25, "R_down": 1.6 * R25,
        "B": 1.5, "B_mean": -7.3 / 6}


def rows(scale: float = 1.0):
    """The readings in the ISO 230-2 standard cycle: run j up the targets, then down."""
    out = []
    for j in range(1, 6):
        for i, t in enumerate(TARGETS):
            out.append((t, j, "+", (MEAN_UP[i] + (j - 3) * C_UP[i]) * scale))
        for i in reversed(range(len(TARGETS))):
            out.append((TARGETS[i], j, "-", (MEAN_DN[i] + (j - 3) * C_DN[i]) * scale))
    return out


def write(path, column="deviation_urad", scale=1.0, fmt="{:.10f}"):
    lines = [f"target_deg,run,direction,{column}"]
    lines += [f"{t:g},{j},{d},{fmt.format(v)}" for t, j, d, v in rows(scale)]
    path.write_text("\n".join(lines) + "\n")
    return path


def evaluate_json(monkeypatch, capsys, *args):
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", *map(str, args),
                                "--json")
    assert code == 0, err
    return json.loads(out)


def test_the_hand_worked_rotary_data_set(tmp_path, monkeypatch, capsys):
    d = evaluate_json(monkeypatch, capsys, write(tmp_path / "c.csv"))
    for k, v in HAND.items():
        assert d[k] == pytest.approx(v, abs=1e-9), k
    assert d["unit"] == "urad" and d["kind"] == "rotary" and d["modulo"] is True
    assert [r["target_deg"] for r in d["targets"]] == TARGETS
    t = {r["target_deg"]: r for r in d["targets"]}
    assert t[133.9]["s_up"] == pytest.approx(0.2 * R25, abs=1e-12)
    assert t[222.6]["mean"] == pytest.approx(5.5, abs=1e-12)
    assert t[0.0]["B"] == pytest.approx(-1.0, abs=1e-12)
    assert d["n_runs_up"] == d["n_runs_down"] == 5 and d["complete"] is True
    # 0 and 360 deg are one physical position: the closure per direction
    assert d["closure"]["targets_deg"] == [0.0, 360.0]
    assert d["closure"]["up"] == pytest.approx(0.4, abs=1e-9)
    assert d["closure"]["down"] == pytest.approx(0.2, abs=1e-9)


def test_the_rotary_json_has_the_linear_keys_and_the_unit(tmp_path, monkeypatch, capsys):
    """The same top-level and per-target keys as a linear file's output, plus ``unit``."""
    lin = tmp_path / "x.csv"
    lin.write_text("target_mm,run,direction,deviation_um\n" + "".join(
        f"{t * 2:g},{j},{d},{v:.6f}\n" for t, j, d, v in rows()))
    dl = evaluate_json(monkeypatch, capsys, lin)
    dr = evaluate_json(monkeypatch, capsys, write(tmp_path / "c.csv"))
    assert dl["unit"] == "um"
    assert set(dl) | {"unit"} <= set(dr)
    assert set(dl["targets"][0]) <= set(dr["targets"][0])
    assert dr["targets"][0]["target_mm"] is None  # a rotary target is an angle
    # the numbers are the same statistics: the linear file holds the same readings
    for k in HAND:
        assert dr[k] == pytest.approx(dl[k], abs=1e-5)


def test_arcsec_and_urad_both_ways(tmp_path, monkeypatch, capsys):
    """1 arcsec = pi/648000 rad = 4.8481368 urad: in the readings and in the output."""
    assert ARCSEC_URAD == pytest.approx(4.8481368, abs=1e-7)
    assert arcsec_to_urad(1.0) == pytest.approx(math.pi / 648000 * 1e6, rel=1e-15)
    assert urad_to_arcsec(4.8481368110953599) == pytest.approx(1.0, rel=1e-15)
    assert urad_to_arcsec(1e6) == pytest.approx(206264.806, abs=1e-3)  # one radian
    assert arcsec_to_urad(3600.0) == pytest.approx(np.pi / 180 * 1e6, rel=1e-15)  # one degree
    x = np.array([-2.5, 0.0, 7.25])
    np.testing.assert_allclose(urad_to_arcsec(arcsec_to_urad(x)), x, rtol=1e-15)
    # a file in arcsec reads as the same angles in urad
    du = evaluate_json(monkeypatch, capsys, write(tmp_path / "u.csv"))
    da = evaluate_json(monkeypatch, capsys, write(tmp_path / "a.csv", "deviation_arcsec",
                                                  1 / ARCSEC_URAD, "{:.12f}"))
    for k in HAND:
        assert da[k] == pytest.approx(du[k], abs=1e-9), k
    # and --units arcsec prints every angle in arcsec
    ds = evaluate_json(monkeypatch, capsys, write(tmp_path / "s.csv"), "--units", "arcsec")
    assert ds["unit"] == "arcsec"
    for k, v in HAND.items():
        assert ds[k] == pytest.approx(v / 4.8481368110953599, abs=1e-9), k
    assert ds["targets"][3]["mean_up"] == pytest.approx(5.0 / 4.8481368110953599, abs=1e-9)
    assert ds["closure"]["up"] == pytest.approx(0.4 / 4.8481368110953599, abs=1e-9)


def test_the_budget_gives_U_from_the_angular_section(tmp_path, monkeypatch, capsys):
    """U(E) from the calibrator's +-1 arcsec at the two targets of E (rectangular) and the
    type A of their means: worked by hand for the data set."""
    budget = tmp_path / "b.toml"
    code, out, _ = run_volcal(monkeypatch, capsys, "budget", "--template")
    assert code == 0
    budget.write_text(out)
    d = evaluate_json(monkeypatch, capsys, write(tmp_path / "c.csv"), "--budget", budget)
    u_cal = 4.8481368110953599 / math.sqrt(3)  # XR20 +-1 arcsec, rectangular
    assert u_cal == pytest.approx(2.80, abs=0.005)
    # E = mean_down(222.6) - mean_up(133.9): two calibrator terms, two type A terms
    u_a = [0.2 * R25 / math.sqrt(5), 0.2 * R25 / math.sqrt(5)]
    u2 = 2 * 2.80 ** 2 + sum(v * v for v in u_a)
    assert d["uncertainty"]["parameters"]["E"]["u"] == pytest.approx(math.sqrt(u2), rel=1e-6)
    assert d["U_E"] == pytest.approx(d["uncertainty"]["parameters"]["E"]["k"] * math.sqrt(u2),
                                     rel=1e-6)
    # the datum (0 deg, where the calibrator was zeroed) has no calibrator term
    assert d["targets"][0]["u_urad"] < 0.3 < d["targets"][1]["u_urad"]
    # a tolerance on A with the guarded rule uses U
    d = evaluate_json(monkeypatch, capsys, write(tmp_path / "c.csv"), "--budget", budget,
                      "--tolerance-urad", "A=12", "--decision-rule", "guarded")
    v = d["verdicts"][0]
    assert v["parameter"] == "A" and v["value_urad"] == pytest.approx(HAND["A"])
    assert v["acceptance_limit_urad"] == pytest.approx(12 - d["U_A"])
    assert d["verdict"] == ("pass" if HAND["A"] <= 12 - d["U_A"] else "conditional")


def test_rotary_file_errors_name_file_row_and_column(tmp_path, monkeypatch, capsys):
    f = write(tmp_path / "c.csv")
    lines = f.read_text().splitlines()
    lines[4] = lines[4].rsplit(",", 1)[0] + ",abc"
    f.write_text("\n".join(lines) + "\n")
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f))
    assert code == 2 and "Traceback" not in err
    assert "c.csv" in err and "row 5" in err and "deviation_urad" in err
    f = write(tmp_path / "d.csv")
    f.write_text(f.read_text().replace("direction,", "way,", 1))
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f))
    assert code == 2 and "missing column direction" in err and "d.csv" in err
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2",
                                str(write(tmp_path / "e.csv")), "--units", "mrad")
    assert code == 2 and "expected urad or arcsec" in err
