"""The certificate's direct optics (issue 20): straightness, angular deviation and
squareness by optical square, their U, the as-found / as-left pairs and the statements
of conformity.

Two sessions:

* the direct set of ``plan --tests direct``, simulated on a random machine, certified with
  a budget: every number of ``results.as_found.direct_optics`` must be the number
  ``volcal evaluate optics --budget B --json`` prints (run in-process unless
  VOLCAL_TEST_SUBPROCESS=1: tests/volcal_cli_helpers.py), the JSON
  must validate against the schema, the PDF (read back with pdftotext) must carry the
  tables;
* three hand-made lines (4 readings each) whose results are worked out by hand in
  :func:`test_conformity_by_hand`.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
import tomllib
from types import SimpleNamespace

import jsonschema
import numpy as np
import pytest
from optics_helpers import hand_budget, hand_session

from timing import scaled_timeout
from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.report.certificate import build_certificate
from volcal.report.certificate_files import schema, write_certificate
from volcal.report.certificate_layout import layout
from volcal.session.format import Session, read_session, write_session
from volcal.standards.tolerance import Tolerance, parse_tolerance
from volcal.uncertainty.budget import TEMPLATE, read_budget
from volcal_cli_helpers import volcal_process

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
VOLCAL = [sys.executable, "-c", "from volcal.cli import main; main()"]


def _valid(doc):
    jsonschema.validate(doc, schema(), cls=jsonschema.Draft202012Validator)


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    root = tmp_path_factory.mktemp("certoptics")
    s = plan_session(TRAVEL, "XYFZ", 3, ("direct",), runs=2, name="CERT-OPTICS")
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=11, n_nodes=21),
                     SimulationOptions(noise_um=0.3, seed=4))
    write_session(s, root / "s")
    (root / "b.toml").write_text(TEMPLATE, encoding="utf-8")
    p = volcal_process("evaluate", "optics", root / "s", "--budget", root / "b.toml", "--json",
                       timeout=scaled_timeout(300))
    assert p.returncode == 0, p.stderr
    s = read_session(root / "s")
    tol = parse_tolerance("X.straightness_um=40,Y.straightness_um=0.5,EC0Y.squareness_urad=200")
    doc = build_certificate(s, optics_budget=read_budget(root / "b.toml"), tolerance=tol,
                            issued="2026-11-25")
    return SimpleNamespace(root=root, session=s, cli=json.loads(p.stdout), doc=doc)


def test_direct_optics_are_the_numbers_of_evaluate_optics(sim):
    opt, ev = sim.doc["results"]["as_found"]["direct_optics"], sim.cli
    assert opt["reference_line"] == "least_squares" and opt["uncertainty_evaluated"]
    # every line of the session, none left out
    assert [r["measurement"] for r in opt["straightness"]] == list(ev["straightness"])
    assert [r["measurement"] for r in opt["angular"]] == list(ev["angular"])
    assert len(opt["squareness"]) == len(ev["squareness"]) >= 3
    assert len(opt["straightness"]) == 7 and len(opt["angular"]) == 8
    for r in opt["straightness"]:
        e = ev["straightness"][r["measurement"]]
        assert (r["axis"], r["error_direction"]) == (e["axis"].upper(),
                                                     e["error_direction"].upper())
        ls = e["least_squares"]
        assert r["straightness_um"] == pytest.approx(ls["straightness_um"], rel=1e-12)
        assert r["U_um"] == pytest.approx(ls["U_straightness_um"], rel=1e-12)
        assert r["k"] == ls["k"] == pytest.approx(2.0)
        assert r["length_mm"] == pytest.approx(e["length_mm"])
        assert 0.0 < r["U_um"] < r["straightness_um"]
    for r in opt["angular"]:
        e = ev["angular"][r["measurement"]]
        assert (r["axis"], r["rotation"], r["target"]) == (e["axis"].upper(),
                                                           e["rotation"].upper(), e["target"])
        assert r["angular_deviation_urad"] == pytest.approx(e["angular_deviation_urad"],
                                                            rel=1e-12)
        assert r["U_urad"] == pytest.approx(e["U_angular_deviation_urad"], rel=1e-12)
        assert r["max_urad"] - r["min_urad"] == pytest.approx(r["angular_deviation_urad"])
    assert {r["target"] for r in opt["angular"]} == {"level", "angular_optics"}
    for r, e in zip(opt["squareness"], ev["squareness"], strict=True):
        name = e["name"]
        assert (r["name"], r["reference"], r["lines"]) == (name, e["reference"], e["lines"])
        assert r["value_urad"] == pytest.approx(e["least_squares"][name], rel=1e-12)
        assert r["U_urad"] == pytest.approx(e["least_squares"][f"U_{name}"], rel=1e-12)
        # no [references.NAME] table: the square's default certificate, 0 +- 2.5 urad
        assert r["square_deviation_urad"] == 0.0 and r["u_square_urad"] == 2.5
        assert r["u_square_source"] == "default"
    assert {r["name"] for r in opt["squareness"]} == {"EC0Y", "EB0Z", "EA0Z"}
    # the certificate names the method and carries each result's budget table
    m = next(m for m in sim.doc["methods"] if m["id"] == "ISO 230-1 direct optics")
    assert m["reference"] == "ISO 230-1:2012" and "str-xy" in m["measurements"]
    assert sim.doc["uncertainty"]["given"]
    b = sim.doc["uncertainty"]["budgets"]["str-xy"]
    assert b["U_um"] == pytest.approx(ev["straightness"]["str-xy"]["least_squares"]
                                      ["U_straightness_um"], rel=1e-12)
    assert b["u_um"] == pytest.approx(b["U_um"] / b["k"])
    assert "_budgets" not in json.dumps(sim.doc)


def test_the_json_validates_old_certificates_too(sim):
    _valid(sim.doc)
    assert sim.doc["format"] == "volcal-certificate/1"
    # the key is additive: a certificate without it (written before) is still valid
    old = json.loads(json.dumps(sim.doc))
    del old["results"]["as_found"]["direct_optics"], old["conformity"]["statements_urad"]
    old["methods"] = [m for m in old["methods"] if m["id"] != "ISO 230-1 direct optics"]
    _valid(old)
    # and the schema checks the new part: an unknown rotation, a missing U are refused
    for mutate in (lambda d: d["angular"][0].update(rotation="Q"),
                   lambda d: d["straightness"][0].pop("U_um"),
                   lambda d: d["squareness"][0].update(U_urad=-1.0)):
        bad = json.loads(json.dumps(sim.doc))
        mutate(bad["results"]["as_found"]["direct_optics"])
        with pytest.raises(jsonschema.ValidationError):
            _valid(bad)


def test_the_pdf_and_the_html_carry_the_tables(sim, tmp_path):
    if not shutil.which("pdftotext"):
        pytest.skip("poppler-utils is not installed (make browser-deps installs it)")
    files = write_certificate(sim.doc, tmp_path)
    text = subprocess.run(["pdftotext", "-layout", str(files.pdf), "-"], capture_output=True,
                          text=True, check=True).stdout
    flat = " ".join(text.split())
    opt = sim.doc["results"]["as_found"]["direct_optics"]
    assert "straightness, ISO 230-1 [µm]" in flat
    assert "angular deviation, ISO 230-1 [µrad]" in flat
    assert "squareness by optical square, ISO 230-1 [µrad]" in flat
    for r in opt["straightness"]:  # one row per line, no cell cut
        assert (f"{r['measurement']} {r['axis']} {r['error_direction']} least squares "
                f"{r['length_mm']:.1f} {r['straightness_um']:.2f} {r['U_um']:.2f} 2.00"
                ) in flat, r["measurement"]
    for r in opt["angular"]:
        assert (f"{r['measurement']} {r['axis']} {r['rotation']} "
                f"{r['target'].replace('_', ' ')} {r['angular_deviation_urad']:.2f} "
                f"{r['min_urad']:.2f} {r['max_urad']:.2f} {r['U_urad']:.2f} 2.00") in flat
    r = opt["squareness"][0]
    assert (f"{r['name']} {r['reference']} {' + '.join(r['lines'])} least squares 0.00 2.50 "
            f"{r['value_urad']:.2f} {r['U_urad']:.2f} 2.00") in flat
    # the squareness statement in its own table, in µrad
    st = sim.doc["conformity"]["statements_urad"][0]
    assert "Squareness by optical square [µrad]" in flat
    assert f"200.00 {st['value_urad']:.2f}" in flat
    html = files.html.read_text(encoding="utf-8")
    assert "straightness, ISO 230-1 [µm]" in html
    assert f"<td>{opt['straightness'][0]['straightness_um']:.2f}</td>" in html


def test_the_straightness_statement_takes_the_axis_largest_line(sim):
    c = sim.doc["conformity"]
    opt = sim.doc["results"]["as_found"]["direct_optics"]
    for axis, t in (("X", 40.0), ("Y", 0.5)):
        worst = max((r for r in opt["straightness"] if r["axis"] == axis),
                    key=lambda r: r["straightness_um"])
        row = next(r for r in c["statements"] if r["quantity"].startswith(f"{axis}: "))
        assert row["value_um"] == worst["straightness_um"] and row["U_um"] == worst["U_um"]
        assert worst["measurement"] in row["quantity"] and row["tolerance_um"] == t
        assert row["verdict"] == ("pass" if worst["straightness_um"] <= t else "fail")
    assert [r["verdict"] for r in c["statements"]] == ["pass", "fail"]  # Y: 0.5 um is tight
    assert c["tolerance"] == ("X.straightness_um=40,Y.straightness_um=0.5,"
                              "EC0Y.squareness_urad=200")


def _verdicts(doc):
    c = doc["conformity"]
    return ({r["state"]: r["verdict"] for r in c["statements"]},
            {r["state"]: r["verdict"] for r in c["statements_urad"]})


def test_conformity_byhand_session():
    """As found (str-xy 0, 2, 1, 3 um at 0, 100, 200, 300 mm): the least-squares line has
    slope 400 / 50000 = 0.008 um/mm (8 urad), residuals -0.3, 0.9, -0.9, 0.3: straightness
    1.8 um; its extremes at readings 1 and 2 give c = (-0.3, 0.9, -0.9, 0.3), |c|^2 = 1.8,
    u^2 = (1.8 x 0.005)^2 + 0.3^2 x 1.8 = 0.162081, U = 0.8052 um (k = 2).
    str-yx is straight (slope 10 urad): EC0Y = -(8 + 10) + 1 = -17 urad,
    u^2 = (18 x 0.005)^2 + 0.09 x (20 + 20) + 2.5^2 = 9.8581, U = 6.2795 urad.
    The level's range 6.5 urad, u^2 = (6.5 x 0.01)^2 + 2 x 0.5^2, U = 1.4202 urad.
    As left every reading of str-xy and the level is halved: 0.9 um, EC0Y = -(4 + 10) + 1
    = -13 urad (U = 2 sqrt((14 x 0.005)^2 + 3.6 + 6.25) = 6.2785), 3.25 urad.

    Guarded rule, w = U: T_X = 2 um: as found 1.8 > 2 - 0.805 (conditional), as left
    0.9 <= 1.195 (pass); T = 1.5 um: 1.8 > 1.5 (fail), 0.9 > 0.695 (conditional).
    |EC0Y| against 25 urad: 17 <= 18.72 (pass), 13 (pass); against 15 urad: 17 > 15
    (fail), 13 > 8.72 (conditional). The simple rule with 1.5 um, 15 urad: fail, fail
    as found; pass, pass as left."""
    found, left, b = hand_session(), hand_session(0.5), hand_budget()
    U_st = 2 * math.sqrt(0.162081)
    U_sq = 2 * math.sqrt(0.0081 + 3.6 + 6.25)
    doc = build_certificate(found, as_left=left, optics_budget=b, decision_rule="guarded",
                            tolerance=parse_tolerance("X.straightness_um=2,"
                                                      "EC0Y.squareness_urad=25"))
    _valid(doc)
    opt = doc["results"]["as_found"]["direct_optics"]
    st = next(r for r in opt["straightness"] if r["measurement"] == "str-xy")
    assert st["straightness_um"] == pytest.approx(1.8) and st["U_um"] == pytest.approx(U_st)
    sq = opt["squareness"][0]
    assert (sq["name"], sq["value_urad"]) == ("EC0Y", pytest.approx(-17.0))
    assert sq["U_urad"] == pytest.approx(U_sq) and sq["square_deviation_urad"] == 1.0
    assert sq["u_square_source"] == "references.xy"
    lev = opt["angular"][0]
    assert lev["angular_deviation_urad"] == pytest.approx(6.5)
    assert lev["U_urad"] == pytest.approx(2 * math.sqrt(0.065**2 + 0.5), rel=1e-9)
    assert _verdicts(doc) == ({"as_found": "conditional", "as_left": "pass"},
                              {"as_found": "pass", "as_left": "pass"})
    row = next(r for r in doc["conformity"]["statements_urad"] if r["state"] == "as_left")
    assert row["value_urad"] == pytest.approx(13.0)
    assert row["U_urad"] == pytest.approx(2 * math.sqrt(0.07**2 + 3.6 + 6.25))
    tight = parse_tolerance("X.straightness_um=1.5,EC0Y.squareness_urad=15")
    doc = build_certificate(found, as_left=left, optics_budget=b, decision_rule="guarded",
                            tolerance=tight)
    assert _verdicts(doc) == ({"as_found": "fail", "as_left": "conditional"},
                              {"as_found": "fail", "as_left": "conditional"})
    note = next(r["note"] for r in doc["conformity"]["statements_urad"]
                if r["state"] == "as_left")
    assert f"T - w = {15 - 2 * math.sqrt(0.07**2 + 3.6 + 6.25):.3g} urad" in note
    doc = build_certificate(found, as_left=left, optics_budget=b, tolerance=tight)
    assert _verdicts(doc) == ({"as_found": "fail", "as_left": "pass"},
                              {"as_found": "fail", "as_left": "pass"})
    # the failed statements are flagged in the printed tables
    tables = [b for s in layout(doc) for b in s.blocks if b.kind == "table"]
    urad = next(t for t in tables if t.title == "Squareness by optical square [µrad]")
    assert urad.flagged == [0] and urad.rows[0][2:6] == ["15.00", "17.00", "6.28", "fail"]

    # as-found / as-left: the same lines paired quantity by quantity
    pairs = {(p["measurement"], p["quantity"]): p
             for p in doc["as_found_as_left"]["direct_optics_pairs"]}
    assert pairs[("str-xy", "straightness")]["as_found"] == pytest.approx(1.8)
    assert pairs[("str-xy", "straightness")]["as_left"] == pytest.approx(0.9)
    assert pairs[("lev-xa", "angular deviation")]["as_left"] == pytest.approx(3.25)
    p = pairs[("EC0Y (xy: str-xy + str-yx)", "squareness")]
    assert (p["as_found"], p["as_left"], p["unit"]) == (pytest.approx(-17.0),
                                                        pytest.approx(-13.0), "urad")
    pt = next(t for t in tables if t.title.startswith("Direct optics (ISO 230-1) measured"))
    assert ["str-xy", "X along Y", "straightness", "µm", "1.80", "0.90", "-0.90"] in pt.rows


def test_without_a_budget_u_is_null_and_said_so():
    found = hand_session()
    doc = build_certificate(found, decision_rule="guarded",
                            tolerance=parse_tolerance("X.straightness_um=2"))
    _valid(doc)
    opt = doc["results"]["as_found"]["direct_optics"]
    assert not opt["uncertainty_evaluated"]
    assert all(r["U_um"] is None and r["k"] is None for r in opt["straightness"])
    assert all(r["U_urad"] is None for r in opt["angular"] + opt["squareness"])
    assert not doc["uncertainty"]["given"] and doc["uncertainty"]["budgets"] is None
    assert "no measurement-uncertainty budget given" in doc["warnings"]
    # guarded without U: no pass can be stated (as for the other results)
    row = doc["conformity"]["statements"][0]
    assert row["verdict"] == "conditional" and "no pass can be stated" in row["note"]
    blocks = [b for s in layout(doc) for b in s.blocks]
    st = next(b for b in blocks if b.title == "straightness, ISO 230-1 [µm]")
    assert "U" not in st.columns and st.rows[0][5] == "1.80"
    assert any(b.kind == "note" and "were not evaluated" in b.text for b in blocks)
    # a session without direct optics: the key is null
    assert build_certificate(Session("m", "XYFZ", TRAVEL, []))["results"]["as_found"][
        "direct_optics"] is None


def test_tolerance_keys_of_the_direct_optics():
    t = parse_tolerance("X=10,x.straightness_um=4,Z.STRAIGHTNESS_UM=6,ec0y.squareness_urad=20")
    assert t.axis_um == {"X": 10.0} and t.straightness_um == {"X": 4.0, "Z": 6.0}
    assert t.squareness_urad == {"EC0Y": 20.0}
    assert t.text() == "X=10,X.straightness_um=4,Z.straightness_um=6,EC0Y.squareness_urad=20"
    assert parse_tolerance(t.text()) == t
    assert Tolerance().straightness_um == {} and Tolerance().squareness_urad == {}
    for bad, words in (("Q.straightness_um=3", "X, Y, Z"),
                       ("EC0X.squareness_urad=2", "EC0Y, EB0Z, EA0Z"),
                       ("EC0Y.squareness_urad=-2", "positive number of urad"),
                       ("X.straightness_um=1,X.straightness_um=2", "given twice")):
        with pytest.raises(VolcalInputError, match=words):
            parse_tolerance(bad)


def test_report_budget_reaches_the_certificate(tmp_path, monkeypatch, capsys, stub_pdfs):
    """`volcal report --certificate --budget B`: the hand lines' U on certificate.json
    (the budget file with straightness 0.5 %, 0.3 um; the template's level, 0.58 % and
    0.58 urad: U = 2 sqrt((6.5 x 0.0058)^2 + 2 x 0.58^2)). The PDFs stubbed
    (tests/report_stubs.py): the certificate's PDF is read in
    test_the_pdf_and_the_html_carry_the_tables; the figures of a direct-optics session are
    drawn here."""
    from volcal.cli import main

    write_session(hand_session(), tmp_path / "s")
    (tmp_path / "b.toml").write_text(TEMPLATE.replace(
        "u_straightness_scale_pct = 0.29", "u_straightness_scale_pct = 0.5").replace(
        "u_straightness_um = 0.29", "u_straightness_um = 0.3"), "utf-8")
    monkeypatch.setattr(sys, "argv", ["volcal", "report", str(tmp_path / "s"), "--certificate",
                                      "--budget", str(tmp_path / "b.toml"), "--tolerance-um",
                                      "X.straightness_um=2", "--decision-rule", "guarded",
                                      "-o", str(tmp_path / "out")])
    try:
        main()
    except SystemExit as exc:
        assert not exc.code, capsys.readouterr().err
    doc = json.loads((tmp_path / "out" / "certificate.json").read_text("utf-8"))
    _valid(doc)
    opt = doc["results"]["as_found"]["direct_optics"]
    assert opt["straightness"][0]["U_um"] == pytest.approx(2 * math.sqrt(0.162081))
    assert opt["angular"][0]["U_urad"] == pytest.approx(
        2 * math.sqrt((6.5 * 0.0058) ** 2 + 2 * 0.58**2), rel=1e-9)
    assert doc["uncertainty"]["given"] and "str-xy" in doc["uncertainty"]["budgets"]
    row = doc["conformity"]["statements"][0]
    assert (row["value_um"], row["verdict"]) == (pytest.approx(1.8), "conditional")


def test_evaluate_optics_states_the_same_verdicts(tmp_path):
    """`volcal evaluate optics --tolerance-um ... --decision-rule guarded --budget B`
    judges the hand lines as the certificate does (:func:`test_conformity_by_hand`: the
    straightness 1.8 um, U 0.805, against 2 um is conditional, |EC0Y| 17 urad, U 6.28,
    against 15 urad fails); ISO 230-2 limits alone are refused with the command that
    judges them, and `evaluate session` says where the optics' limits are judged."""
    write_session(hand_session(), tmp_path / "s")
    doc = tomllib.loads(TEMPLATE)
    doc["optics"] = {"u_straightness_scale_pct": 0.5, "u_straightness_um": 0.3,
                     "u_level_scale_pct": 1.0, "u_level_urad": 0.5}
    import tomli_w

    (tmp_path / "b.toml").write_text(tomli_w.dumps(doc), encoding="utf-8")
    p = volcal_process("evaluate", "optics", tmp_path / "s", "--budget", tmp_path / "b.toml",
                       "--tolerance-um", "X.straightness_um=2,EC0Y.squareness_urad=15",
                       "--decision-rule", "guarded", "--json", timeout=scaled_timeout(300))
    assert p.returncode == 0, p.stderr
    conf = json.loads(p.stdout)["conformity"]
    st, sq = conf["statements"]
    assert st["value_um"] == pytest.approx(1.8) and st["verdict"] == "conditional"
    assert st["U_um"] == pytest.approx(2 * math.sqrt(0.162081))
    assert sq["value_urad"] == pytest.approx(17.0) and sq["verdict"] == "fail"
    assert conf["decision_rule"] == "guarded"
    # a real process: the exit code of the refusal (the verdicts above run in-process)
    p = subprocess.run([*VOLCAL, "evaluate", "optics", str(tmp_path / "s"),
                        "--tolerance-um", "X=10"], capture_output=True, text=True,
                       timeout=scaled_timeout(300))
    assert p.returncode == 2 and "volcal evaluate session" in p.stderr
    assert "Traceback" not in p.stderr


def test_classic_optics_is_evaluate_optics(sim):
    """`volcal classic optics` (each optic on its own, no model) prints what `volcal
    evaluate optics --json` prints without a budget; it calls the same command function
    and must pass every option (a new option once broke it with typer's defaults)."""
    a = volcal_process("classic", "optics", sim.root / "s", "--json",
                       timeout=scaled_timeout(300))
    b = volcal_process("evaluate", "optics", sim.root / "s", "--json",
                       timeout=scaled_timeout(300))
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    assert json.loads(a.stdout) == json.loads(b.stdout)
    assert json.loads(a.stdout)["straightness"]
