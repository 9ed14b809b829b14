"""The uncertainty chain as a user runs it, end to end (issue 17).

budget --template -> plan -> simulate --budget -> identify --budget -> evaluate session
--budget --tolerance-um X=.. --decision-rule guarded --json -> report --budget with a
[calibration]/[[equipment]] session: the certificate is issued with the budget tables and
the U of the values it states; every number is checked against an independent
evaluation of the same files.
"""

import json
import shutil
import sys

import pytest

from volcal.cli import main
from volcal.session.format import read_session

CALIBRATION = """
[calibration]
date = 2026-11-23
operator = "A. Technician"
approved_by = "B. Manager"
customer = "Shop Ltd"
laboratory = "Metrology Service GmbH"

[[equipment]]
role = "laser"
make = "Renishaw"
model = "XL-80"
serial = "L-12345"
certificate = "CAL-2026-0815"
calibrated = 2026-03-01
due = 2027-03-01
"""


def run(monkeypatch, capsys, *args):
    monkeypatch.setattr(sys, "argv", ["volcal", *map(str, args)])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return code, out.out, out.err


def test_budget_to_certificate(tmp_path, monkeypatch, capsys):
    from volcal.identify.modelfile import load_model
    from volcal.standards.decision import decide
    from volcal.standards.iso230_2_uncertainty import evaluate_with_budget
    from volcal.standards.positioning_data import from_measurement
    from volcal.uncertainty.budget import read_budget

    b, s, model, out = (tmp_path / n for n in ("b.toml", "S", "model.json", "R"))
    assert run(monkeypatch, capsys, "budget", "--template", "-o", b)[0] == 0
    code, _, err = run(monkeypatch, capsys, "plan", "--travel", "0:400,0:300,0:250",
                       "--steps", "4", "--runs", "3", "-o", s)
    assert code == 0, err
    code, o, err = run(monkeypatch, capsys, "simulate", s, "--budget", b, "--seed", "2",
                       "--noise-um", "0.3")
    assert code == 0 and "systematic errors drawn" in o, err
    with (s / "session.toml").open("a", encoding="utf-8") as f:
        f.write(CALIBRATION)
    code, o, err = run(monkeypatch, capsys, "identify", s, "-o", model, "--budget", b)
    assert code == 0, err
    r = load_model(model)
    assert r.sys_factor is not None and "laser wavelength" in r.sys_labels

    # evaluate session: U of every parameter, the guarded verdict, the model's U_E_V*
    code, o, err = run(monkeypatch, capsys, "evaluate", "session", s, "--budget", b,
                       "--tolerance-um", "X=10", "--decision-rule", "guarded", "--model",
                       model, "--json")
    assert code == 0, err
    ev = json.loads(o)
    sess, bud = read_session(s), read_budget(b)
    worst = None
    for mid, m in ev["measurements"].items():
        res, unc, _ = evaluate_with_budget(from_measurement(sess.get(mid), s), bud)
        assert m["A"] == pytest.approx(res.A, abs=1e-9)
        assert m["U_A"] == pytest.approx(unc.parameters["A"].U, rel=1e-9)
        assert [t["U_um"] for t in m["targets"]] == pytest.approx([e.U for e in unc.targets])
        if m["axis"] == "X" and (worst is None or res.A > worst[0]):
            worst = (res.A, unc.parameters["A"].U)
    v = ev["verdict"][0]
    assert v["before_um"] == pytest.approx(worst[0]) and v["U_before_um"] == pytest.approx(
        worst[1])
    assert v["before"] == decide(worst[0], 10.0, "guarded", U=worst[1]).verdict
    assert ev["decision_rule"]["name"] == "guarded"
    vol = ev["volumetric"]
    for k in ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range"):
        assert vol[f"U_{k}"] > 0
        parts = vol["uncertainty"]["volumetric"][k]
        # both parts are in U, and the systematic part is not zero (budget in the model)
        assert parts["u_sys"] > 0 and vol[f"U_{k}"] >= 2 * parts["u_noise"] * 0.9
    assert set(ev["straightness"]) == {"EYX", "EZX", "EXY", "EZY", "EXZ", "EYZ"}
    assert set(ev["squareness"]) == {"EC0Y", "EB0Z", "EA0Z"}

    # report + certificate (issued: the session has [calibration] and [[equipment]])
    if not shutil.which("pdftotext"):
        pytest.skip("poppler-utils is not installed (make browser-deps installs it)")
    # the figures are drawn by their own tests (tests/plot): here each is a blank page, and
    # the deviation plot's call is recorded (its ± U error bars)
    import volcal.report.sections as sections
    from volcal.plot._figure import new_figure

    bars = {}

    def deviation(m, fig=None, uncertainty=None):
        bars[m.id] = uncertainty
        return new_figure(1.0, 1.0)

    monkeypatch.setattr(sections, "linear_deviation_plot", deviation)
    # figures are built by the process that draws them: this one, where the calls are
    # recorded (a drawing worker would record them in its own memory)
    from volcal.report.figures import WORKERS_ENV

    monkeypatch.setenv(WORKERS_ENV, "0")
    for name in ("error_functions_plot", "diagonal_fit_plot", "identifiability_plot",
                 "volumetric_map_plot"):
        monkeypatch.setattr(sections, name, lambda *a, **k: new_figure(1.0, 1.0))
    code, o, err = run(monkeypatch, capsys, "report", s, "--model", model, "--budget", b,
                       "--tolerance-um", "X=10", "--decision-rule", "guarded", "-o", out)
    assert code == 0, err
    cert = json.loads((out / "certificate.json").read_text("utf-8"))
    assert cert["uncertainty"]["given"] and cert["uncertainty"]["budgets"]
    assert "No correction by the budget" in cert["uncertainty"]["statement"]
    st = cert["conformity"]["statements"][0]
    # the certificate states the value the U belongs to (the readings' own, issue 25)
    assert st["value_um"] == pytest.approx(worst[0]) and st["U_um"] == pytest.approx(
        worst[1])
    assert st["verdict"] == v["before"] and cert["conformity"]["decision_rule"] == "guarded"
    # every diagonal's E_D with its U (ISO 230-6)
    from volcal.standards.iso230_6_uncertainty import evaluate_diagonal_with_budget

    diags = cert["results"]["as_found"]["diagonals"]
    assert diags
    for d in diags:
        res, du = evaluate_diagonal_with_budget(sess.get(d["measurement"]), bud)
        assert d["E_D_um"] == pytest.approx(res.E_D) and d["U_E_D_um"] == pytest.approx(
            du.E_D.U)
    # the model's volumetric indices with the same U as evaluate session (same draws)
    cv = cert["results"]["as_found"]["volumetric"]
    for k in ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range"):
        assert cv[k] == pytest.approx(vol[k]) and cv["U_um"][k] == pytest.approx(vol[f"U_{k}"])
    # the deviation plots got the mean of each target with its U (the evaluation's)
    for mid, (t, mean, U) in bars.items():
        m = ev["measurements"][mid]
        assert list(t) == pytest.approx([x["target_mm"] for x in m["targets"]])
        assert list(mean) == pytest.approx([x["mean"] for x in m["targets"]])
        assert list(U) == pytest.approx([x["U_um"] for x in m["targets"]])
    assert len(bars) == 3  # one plot per axis
    import subprocess

    text = subprocess.run(["pdftotext", "-layout", str(out / "report.pdf"), "-"],
                          capture_output=True, text=True, check=True).stdout
    for words in ("Expanded uncertainty of the ISO 230-2 parameters", "Measurement "
                  "uncertainty", "u systematic", "U(x̄", "U [µm]", "U(E_D) [µm]"):
        assert words.replace("x̄", "x") in text.replace("x̄", "x"), words
