"""U everywhere (issue 26, deliver 5): the evaluation's U of every ISO 230-2 parameter,
diagonal, volumetric index and direct-optics result is stored with it; compare tests the
results against the combined U with a verdict; the trend figure draws the U band; the fleet
page shows U. On SQLite and PostgreSQL.

Calibrations A and B of ``history_two`` (tests/history/history_fixtures.py: one machine,
10 increments, B with X scale +10 um/m), added with the budget template of
``volcal budget`` (``--budget``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from history_fixtures import history_two  # noqa: F401  (a fixture)

from volcal_cli_helpers import volcal_process


@pytest.fixture(scope="module")
def budget_file(tmp_path_factory):
    from volcal.uncertainty.budget import template_text

    p = tmp_path_factory.mktemp("budget") / "budget.toml"
    p.write_text(template_text())
    return p


def _evaluation(folder, budget):
    """The evaluation ``history add --budget`` makes (the one evaluation of the session)."""
    from volcal.identify.modelfile import load_model
    from volcal.session.format import read_session
    from volcal.standards.session import evaluate_session
    from volcal.uncertainty.budget import read_budget

    return evaluate_session(read_session(folder), load_model(folder / "model.json"),
                            model_uncertainty=True,
                            budget=None if budget is None else read_budget(budget),
                            optics=True)


@pytest.fixture(scope="module")
def evaluation_a(history_two, budget_file):  # noqa: F811
    """A's evaluation with the budget (:func:`_evaluation`), made once for both stores:
    the same files give the same numbers (the model's U from seeded draws)."""
    return _evaluation(history_two["a"], budget_file)


def test_stored_u_and_compare(store_url, history_two, budget_file, evaluation_a):  # noqa: F811
    """Every stored U is the evaluation's own number (never recomputed); compare tests
    each result against U = sqrt(U1^2 + U2^2) of the stored U with a verdict, and says
    "no uncertainty stored" only where a stored U is missing."""
    from volcal.history.api import History

    a, b = history_two["a"], history_two["b"]
    ev = evaluation_a
    with History(store_url) as h:
        ra = h.add(a, a / "model.json", budget=budget_file)
        rb = h.add(b, b / "model.json", budget=budget_file)
        df = h.compare(ra.id, rb.id).set_index("name")
        frame = h.results()
    res = ra.results
    lin = ev.with_budget["linear-x1"].to_dict()
    for key in ("A", "E", "M", "R", "B", "A_up", "R_down", "B_mean"):
        assert res[f"linear-x1.{key}"]["value"] == pytest.approx(lin[key], rel=1e-12)
        assert res[f"linear-x1.{key}"]["U"] == pytest.approx(lin[f"U_{key}"], rel=1e-12)
        assert res[f"X.{key}"] == res[f"linear-x1.{key}"]       # the axis' first test
        assert 0 < res[f"X.{key}"]["U"] < 5                       # [um]
    diag = ev.with_budget["diag-ppp"].to_dict()
    assert res["diag-ppp.E_D"]["U"] == pytest.approx(diag["U_E_D"], rel=1e-12)
    assert res["diag-ppp.max_abs_um"]["U"] is None              # none in the evaluation
    vol = ev.volumetric.to_dict()
    for key in ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range"):
        assert res[f"V.{key}"]["U"] == pytest.approx(vol[f"U_{key}"], rel=1e-9)
    for name, e in ev.model_indices["squareness"].items():
        assert res[name]["U"] == pytest.approx(e["U_urad"], rel=1e-9)
    assert ra.payload["budget"]["file"] == "budget.toml"
    assert "budget" in {f["role"] for f in ra.files}
    assert frame["U"].dtype == np.float64                       # NaN where none
    assert math.isnan(frame.set_index(["id", "parameter"])["U"][(ra.id,
                                                                 "diag-ppp.max_abs_um")])
    # compare
    assert set(df.verdict) <= {"CHANGED", "unchanged", "undecided"}
    assert (df.verdict == "CHANGED").equals(df.changed.fillna(False).astype(bool))
    results = df[df.test == "|d| > U"]
    for name, e in results.iterrows():
        has_u = ra.results[name]["U"] is not None and rb.results[name]["U"] is not None
        assert (e.reason == "") == has_u, name
        if has_u:
            u = math.hypot(ra.results[name]["U"], rb.results[name]["U"])
            d = rb.results[name]["value"] - ra.results[name]["value"]
            assert e.U == pytest.approx(u, rel=1e-12)
            assert e.changed == (abs(d) > u)
    # X scale +10 um/m: X's accuracy and systematic deviation move by several um, beyond
    # U (about 2.5 and 1.4 um); the axes that did not change stay within theirs
    assert list(df.loc[["X.A", "X.E", "V.E_VX"], "verdict"]) == ["CHANGED"] * 3
    assert list(df.loc[["Y.A", "Z.A", "Y.E", "Z.E"], "verdict"]) == ["unchanged"] * 4
    r = volcal_process("history", "compare", ra.id, rb.id, "--db", store_url)
    assert r.returncode == 0, r.stderr
    lines = {ln.split("\t")[0]: ln for ln in r.stdout.splitlines()}
    assert lines["name"] == "name\tdifference\tU (k=2)\tunit\tverdict\ttest"
    d, u = df.loc["X.E", "difference"], df.loc["X.E", "U"]
    assert lines["X.E"] == f"X.E\t{d:+.4f}\t{u:.4f}\tum\tCHANGED\t|d| {abs(d):.4f} > U {u:.4f}"
    d, u = df.loc["Y.E", "difference"], df.loc["Y.E", "U"]
    assert lines["Y.E"] == (f"Y.E\t{d:+.4f}\t{u:.4f}\tum\tunchanged\t"
                            f"|d| {abs(d):.4f} <= U {u:.4f}")


def test_without_budget(tmp_path, history_two, budget_file):  # noqa: F811
    """B added without a budget: no U for its ISO 230-2 and diagonal results (NaN), the
    model's for the indices; compare names the calibration without U; the fleet page
    shows E_VXYZ ± U and the U band of its trend."""
    from volcal.history.api import History
    from volcal.history.fleet import fleet_html

    a, b = history_two["a"], history_two["b"]
    db = str(tmp_path / "h.sqlite")
    add = volcal_process("history", "add", a, "--model", a / "model.json", "--budget",
                         budget_file, "--db", db, "--create")
    assert add.returncode == 0 and add.stdout == "C000002\n", add.stderr
    with History(db) as h:
        ra = h.show("C000002")
        assert ra.results["X.A"]["U"] > 0 and ra.payload["budget"]["file"] == "budget.toml"
        rb = h.add(b, b / "model.json")
        frame = h.results().set_index(["id", "parameter"])["U"]
        page = fleet_html(h)
        one = fleet_html(h, machine="VMC-1")
    assert rb.results["X.A"]["U"] is None and rb.results["diag-ppp.E_D"]["U"] is None
    assert math.isnan(frame[(rb.id, "X.A")]) and frame[(ra.id, "X.A")] > 0
    assert rb.results["V.E_VXYZ"]["U"] > 0                        # the model's U
    r = volcal_process("history", "compare", ra.id, rb.id, "--db", db)
    line = next(ln for ln in r.stdout.splitlines() if ln.startswith("X.A\t"))
    assert line.endswith("\t-\tum\tundecided\tnot tested: no uncertainty stored for the "
                         "later")
    assert "results not tested for want of a stored U: `volcal history add --budget " \
        "FILE` stores" in r.stdout
    assert not any(ln.startswith(("diag-ppp.length_mm", "diag-ppp.points_"))
                   for ln in r.stdout.splitlines())  # the test's descriptors, not tested
    assert rb.results["diag-ppp.length_mm"]["unit"] == "mm"
    assert rb.results["diag-ppp.points_measured"]["unit"] == "points"
    v = rb.results["V.E_VXYZ"]
    assert f"<td>{v['value']:.2f} ± {v['U']:.2f}</td>" in page
    assert '<polygon fill="#cde"' in page and "E_VXYZ trend with U" in page
    assert one == page                                    # the store's only machine


def test_trend_plot_draws_the_u_band():
    """The band value +- U joins the calibrations with U; one without U has none."""
    from matplotlib.collections import PolyCollection

    from volcal.plot.trend import trend_plot

    rows = [{"id": "C1", "date": "2025-01-10", "value": 2.0, "U": 0.5, "unit": "um"},
            {"id": "C2", "date": "2025-07-10", "value": 2.4, "U": None, "unit": "um"},
            {"id": "C3", "date": "2026-01-10", "value": 3.0, "U": 0.25, "unit": "um"}]
    ax = trend_plot(rows, "X.A", "VMC-1").axes[0]
    bands = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(bands) == 1
    ys = bands[0].get_paths()[0].vertices[:, 1]
    assert ys.min() == pytest.approx(1.5) and ys.max() == pytest.approx(3.25)
    assert "band and bars: U, k = 2" in ax.get_title()


def _hand_optics_session():
    """An X line read along Z (s = 0, 100, 200, 300 mm; 0, 2, 1, 3 um) and a level
    (0, -4, 2.5, 1 urad): tests/standards/test_optics_uncertainty.py's hand session."""
    from volcal.plan.planner import plan_session
    from volcal.session.format import Session

    travel = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
    p = {m.id: m for m in plan_session(travel, "XYFZ", 3, ("direct",), runs=1,
                                       iso_spacing=False,
                                       linear_margin_mm=0.0).measurements}
    q = np.array([[0.0, 0, 0], [100, 0, 0], [200, 0, 0], [300, 0, 0]])
    for mid, dev in (("str-xz", [0.0, 2.0, 1.0, 3.0]), ("lev-xa", [0.0, -4.0, 2.5, 1.0])):
        p[mid].positions, p[mid].deviation, p[mid].columns = q, np.array(dev), {}
    return Session("h", "XYFZ", travel, [p["str-xz"], p["lev-xa"]])


def test_direct_optics_results_stored_with_u():
    """Hand values (tests/standards/test_optics_uncertainty.py): straightness 1.8 um
    (least squares) U = 2 sqrt(0.162081), 2 um (end points) U = 2 sqrt(0.2001); level
    6.5 urad U = 2 sqrt(0.504225), with u_g 0.5 % and 1 %, u_e 0.3 um and 0.5 urad."""
    import tomllib

    from volcal.history.record import results_from_evaluation
    from volcal.standards.session import evaluate_session
    from volcal.uncertainty.budget import TEMPLATE, parse_budget

    doc = tomllib.loads(TEMPLATE)
    doc["optics"] = {"u_straightness_scale_pct": 0.5, "u_straightness_um": 0.3,
                     "u_level_scale_pct": 1.0, "u_level_urad": 0.5}
    ev = evaluate_session(_hand_optics_session(), None, budget=parse_budget(doc, "b.toml"),
                          optics=True)
    rows = {n: (v, u) for n, v, u, _ in results_from_evaluation(ev)}
    units = {n: unit for n, _, _, unit in results_from_evaluation(ev)}
    assert rows["str-xz.straightness"] == pytest.approx((1.8, 2 * math.sqrt(0.162081)))
    assert rows["str-xz.straightness_end_point"] == pytest.approx(
        (2.0, 2 * math.sqrt(0.2001)))
    assert rows["str-xz.slope_end_point"] == pytest.approx((10.0, 2 * math.sqrt(2.0025)))
    assert rows["lev-xa.angular_deviation"] == pytest.approx(
        (6.5, 2 * math.sqrt(0.504225)))
    assert units["str-xz.straightness"] == "um" and units["lev-xa.angular_deviation"] == "urad"
    # without a budget: the same values, no U
    bare = {n: u for n, _, u, _ in results_from_evaluation(
        evaluate_session(_hand_optics_session(), None, optics=True))}
    assert bare["str-xz.straightness"] is None and bare["lev-xa.angular_deviation"] is None
