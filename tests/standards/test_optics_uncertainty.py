"""U of each direct optic's own ISO 230-1 evaluation (volcal.standards.optics_uncertainty).

Every expected number is worked out by hand in the test's docstring: each evaluation is
linear in the readings between the readings where the data put its extremes, so
``u^2 = (value u_g)^2 + u_e^2 |c|^2`` with ``c`` the coefficients of the readings.
"""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest

from volcal.plan.planner import plan_session
from volcal.session.format import Session, write_session
from volcal.standards.optics import evaluate_optics
from volcal.standards.optics_uncertainty import add_optics_uncertainty, optics_uncertainty
from volcal.uncertainty.budget import TEMPLATE, parse_budget
from volcal_cli_helpers import run_volcal

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def _budget(**optics):
    doc = tomllib.loads(TEMPLATE)
    doc["optics"] = {"u_straightness_scale_pct": 0.5, "u_straightness_um": 0.3,
                     "u_level_scale_pct": 1.0, "u_level_urad": 0.5, **optics}
    return parse_budget(doc, "b.toml")


def _planned():
    return {m.id: m for m in plan_session(TRAVEL, "XYFZ", 3, ("direct",), runs=1,
                                          iso_spacing=False,
                                          linear_margin_mm=0.0).measurements}


def _set(m, positions, deviation):
    m.positions = np.asarray(positions, dtype=float)
    m.deviation = np.asarray(deviation, dtype=float)
    m.columns = {}
    return m


def _hand_session():
    """An X line read along Z: s = 0, 100, 200, 300 mm, readings 0, 2, 1, 3 um; a level."""
    p = _planned()
    q = [[0.0, 0, 0], [100, 0, 0], [200, 0, 0], [300, 0, 0]]
    return Session("h", "XYFZ", TRAVEL, [_set(p["str-xz"], q, [0.0, 2.0, 1.0, 3.0]),
                                         _set(p["lev-xa"], q, [0.0, -4.0, 2.5, 1.0])])


def test_straightness_and_level_by_hand():
    """u_g = 0.5 %, u_e = 0.3 um (straightness); 1 %, 0.5 urad (level).

    End points: residuals 0, 1, -1, 0 (2 um), extremes at readings 1 and 2:
    r1 - r2 = t1 - t2 + (t3 - t0) / 3, |c|^2 = 1 + 1 + 2/9 = 20/9;
    u^2 = (2 x 0.005)^2 + 0.09 x 20/9 = 0.2001, U = 2 sqrt(0.2001) = 0.89465 um.
    End-point slope (t3 - t0) / 300 mm = 10 urad: u^2 = (10 x 0.005)^2 + 2 (0.3/300 1e3)^2
    = 0.0025 + 2.0, U = 2.83019 urad.
    Least squares: residuals -0.3, 0.9, -0.9, 0.3 (1.8 um); r1 - r2 = t1 - t2 + 100 b with
    b = sum (s_i - 150) t_i / 50000: c = -0.3, 0.9, -0.9, 0.3, |c|^2 = 1.8;
    u^2 = (1.8 x 0.005)^2 + 0.09 x 1.8 = 0.162081, U = 0.80519 um.
    Level range 6.5 urad (readings -4 and 2.5): u^2 = (6.5 x 0.01)^2 + 2 x 0.25 = 0.504225,
    U = 1.42018 urad."""
    s = _hand_session()
    ev = add_optics_uncertainty(evaluate_optics(s), optics_uncertainty(s, _budget()))
    ep = ev["straightness"]["str-xz"]["end_point"]
    ls = ev["straightness"]["str-xz"]["least_squares"]
    assert ep["straightness_um"] == pytest.approx(2.0)  # the evaluation's keys are kept
    assert ep["U_straightness_um"] == pytest.approx(2 * math.sqrt(0.2001), rel=1e-9)
    assert ep["U_slope_urad"] == pytest.approx(2 * math.sqrt(2.0025), rel=1e-9)
    assert ls["U_straightness_um"] == pytest.approx(2 * math.sqrt(0.162081), rel=1e-9)
    assert ep["k"] == ls["k"] == 2.0
    lev = ev["angular"]["lev-xa"]
    assert lev["angular_deviation_urad"] == pytest.approx(6.5)
    assert lev["U_angular_deviation_urad"] == pytest.approx(2 * math.sqrt(0.504225), rel=1e-9)
    # the budget of the straightness: the readings carry 0.2 / 0.2001 of the variance
    comps = ev["uncertainty"]["straightness"]["str-xz"]["end_point"]["straightness_um"][
        "components"]
    share = {c["label"]: c["share"] for c in comps}
    assert share["reading, str-xz"] == pytest.approx(0.2 / 0.2001, rel=1e-9)
    assert share["scale of the straightness optics"] == pytest.approx(1e-4 / 0.2001,
                                                                      rel=1e-9)


def test_degrees_of_freedom_give_student_k():
    """The reading's u with 4 degrees of freedom (each of the four readings an input of
    its own, c = -1/3, 1, -1, 1/3): Welch-Satterthwaite
    nu_eff = u^4 / sum (c_i u_e)^4 / 4 = 0.2001^2 / ((2 x 0.09^2 + 2 x 0.01^2) / 4)
    = 9.766, k = t_95.45(9.766) = 2.29."""
    s = _hand_session()
    unc = optics_uncertainty(s, _budget(u_straightness_um_dof=4))
    e = unc["straightness"]["str-xz"]["end_point"]
    assert e["uncertainty"]["straightness_um"]["dof"] == pytest.approx(
        0.2001**2 / ((2 * 0.09**2 + 2 * 0.01**2) / 4), rel=1e-9)
    assert e["k"] == pytest.approx(2.29, abs=0.01)
    assert e["U_straightness_um"] == pytest.approx(e["k"] * math.sqrt(0.2001), rel=1e-9)


def _square_session(delta=4.0, u_square=0.5):
    """Optical square 'xy': X read along Y, slope 510 urad; Y read along X, slope -480 urad
    (each the machine's line plus the reference optic's rotation, which cancels)."""
    p = _planned()
    a = _set(p["str-xy"], [[0.0, 0, 0], [100, 0, 0], [200, 0, 0]], [0.0, 51.0, 102.0])
    b = _set(p["str-yx"], [[0.0, 0, 0], [0, 100, 0], [0, 200, 0]], [0.0, -48.0, -96.0])
    s = Session("sq", "XYFZ", TRAVEL, [a, b])
    s.references = {"xy": {"square_deviation_urad": delta, "u_square_urad": u_square}}
    return s


@pytest.mark.parametrize("corr,var", [
    # one optic for both lines: the scale error acts on the angle, 30 urad x 1 % = 0.3;
    # each slope's readings: w = (-5, 0, 5) urad/um, 0.2^2 x 50 = 2 per line; square 0.5^2
    ("instrument", 0.3**2 + 0.5**2 + 2 * 2.0),
    # one per line: it acts on each slope, 510 and 480 urad x 1 %: 5.1^2 + 4.8^2
    ("measurement", 5.1**2 + 4.8**2 + 0.5**2 + 2 * 2.0),
])
def test_squareness_by_hand(corr, var):
    """-(510 - 480) + 4 = -26 urad (EC0Y) from both references (straight lines)."""
    s = _square_session()
    b = _budget(u_straightness_scale_pct=1.0, u_straightness_um=0.2, scale_correlation=corr)
    ev = add_optics_uncertainty(evaluate_optics(s), optics_uncertainty(s, b))
    (pair,) = ev["squareness"]
    for ref in ("least_squares", "end_point"):
        r = pair[ref]
        assert r["EC0Y"] == pytest.approx(-26.0)
        assert r["U_EC0Y"] == pytest.approx(2 * math.sqrt(var), rel=1e-9)
        assert r["U_angle_minus_90_urad"] == r["U_EC0Y"]


def test_square_certificate_enters_the_squareness():
    """u(square) 3 urad instead of 0.5: U^2 grows by 4 (3^2 - 0.5^2)."""
    b = _budget(u_straightness_scale_pct=1.0, u_straightness_um=0.2)
    lo = optics_uncertainty(_square_session(), b)["squareness"][0]["least_squares"]
    hi = optics_uncertainty(_square_session(u_square=3.0), b)["squareness"][0]["least_squares"]
    assert hi["U_EC0Y"] ** 2 - lo["U_EC0Y"] ** 2 == pytest.approx(4 * (9 - 0.25), rel=1e-9)


def test_defaults_are_said():
    doc = tomllib.loads(TEMPLATE)
    del doc["optics"]
    unc = optics_uncertainty(_hand_session(), parse_budget(doc, "b.toml"))
    note = next(n for n in unc["notes"] if "defaults" in n)
    assert "u_straightness_scale_pct = 0.289" in note and "u_level_urad = 0.577" in note
    assert "u_angular_urad" not in note  # no angular-optics line in this session


def test_cli_evaluate_optics_budget(tmp_path, monkeypatch, capsys):
    write_session(_hand_session(), tmp_path / "s")
    doc = tomllib.loads(TEMPLATE)
    (tmp_path / "b.toml").write_text(TEMPLATE.replace(
        "u_straightness_scale_pct = 0.29", "u_straightness_scale_pct = 0.5").replace(
        "u_straightness_um = 0.29", "u_straightness_um = 0.3"), "utf-8")
    assert doc["optics"]["u_straightness_um"] == 0.29
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "optics", str(tmp_path / "s"),
                                "--budget", str(tmp_path / "b.toml"), "--json")
    assert code == 0, err
    d = json.loads(out)
    ep = d["straightness"]["str-xz"]["end_point"]
    assert ep["straightness_um"] == pytest.approx(2.0)
    assert ep["U_straightness_um"] == pytest.approx(2 * math.sqrt(0.2001), rel=1e-6)
    # the template's level: 0.58 % and 0.58 urad, both rectangular
    assert d["angular"]["lev-xa"]["U_angular_deviation_urad"] == pytest.approx(
        2 * math.sqrt((6.5 * 0.0058) ** 2 + 2 * 0.58**2), rel=1e-6)
    assert d["budget_file"] == str(tmp_path / "b.toml")
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "optics", str(tmp_path / "s"),
                              "--budget", str(tmp_path / "b.toml"))
    assert code == 0 and "U end-point" in out and "0.895" in out
    # without --budget the output is unchanged: no U keys
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "optics", str(tmp_path / "s"),
                              "--json")
    assert "U_straightness_um" not in out and "uncertainty" not in json.loads(out)


def test_cli_bad_optics_budget_names_file_and_key(tmp_path, monkeypatch, capsys):
    write_session(_hand_session(), tmp_path / "s")
    bad = tmp_path / "b.toml"
    bad.write_text(TEMPLATE.replace('scale_correlation = "instrument"',
                                    'scale_correlation = "kit"'), "utf-8")
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "optics", str(tmp_path / "s"),
                                "--budget", str(bad), "--json")
    assert code == 2 and out == ""
    assert "optics.scale_correlation" in err and "measurement" in err and str(bad) in err


def test_monte_carlo_of_the_exact_model_agrees():
    """GUM S1 check of the first-order U: a 6 um sine over 800 mm (17 readings) on a
    40 urad reference slope, the template's straightness optics (scale +-0.5 %, reading
    +-0.5 um, rectangular), 20 000 draws of the exact model y = t (1 + g) + e, the
    straightness of each draw about both reference lines. Least squares: the draws'
    standard deviation equals u within 5 % (0.337 vs 0.341 um), 96 % inside +-U; end
    points: the first-order u is conservative where the extremes are flat (the maximum
    picks the best of neighbouring readings: 0.403 vs 0.460 um, 97.7 % inside +-U)."""
    from volcal.standards.straightness import straightness

    m = _planned()["str-xz"]
    s = np.linspace(0.0, 800.0, 17)
    true = 6.0 * np.sin(2 * np.pi * s / 800.0) + 40e-3 * s
    _set(m, np.column_stack([s, 0 * s, 0 * s]), true)
    unc = optics_uncertainty(Session("mc", "XYFZ", TRAVEL, [m]),
                             parse_budget(tomllib.loads(TEMPLATE)))
    rng = np.random.default_rng(1)
    n = 20000
    y = (true * (1 + rng.uniform(-0.5e-2, 0.5e-2, (n, 1)))
         + rng.uniform(-0.5, 0.5, (n, s.size)))
    G = np.column_stack([np.ones_like(s), s])
    resid = {"least_squares": y - y @ (G @ np.linalg.pinv(G)).T,
             "end_point": y - y[:, :1] - (y[:, -1:] - y[:, :1]) * (s / 800.0)}
    for ref, ratio, cover in (("least_squares", (0.95, 1.05), (0.94, 0.98)),
                              ("end_point", (0.80, 0.95), (0.955, 0.99))):
        d = np.ptp(resid[ref], axis=1) - straightness(s, true, ref).straightness_um
        e = unc["straightness"]["str-xz"][ref]
        u = e["uncertainty"]["straightness_um"]["u"]
        assert ratio[0] < d.std() / u < ratio[1], (ref, d.std(), u)
        assert cover[0] < np.mean(np.abs(d) <= e["U_straightness_um"]) < cover[1], ref
