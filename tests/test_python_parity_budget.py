"""Python does what the command line does with an uncertainty budget, a decision rule and
a certificate (issue 20, deliver 1 and 9): `Calibration.evaluate/verdict/report` with
`budget=`, `decision_rule=`, `guard_band_um=`, `certificate=` give the numbers of `volcal
evaluate session/report` with the same options. Simulate and identify are one step
function behind both faces (volcal.steps; tests/test_steps_signature.py): their tests here
check the budget's effect, not the parity.

One small virtual machine (steps 3, 2 runs) is planned once; the CLI runs in-process.
"""

from __future__ import annotations

import hashlib
import json
import sys
import tomllib
from types import SimpleNamespace

import numpy as np
import pytest

from report_stubs import use_stub_pdfs
from volcal import Calibration
from volcal.uncertainty.budget import TEMPLATE

TRAVEL = [[0, 500], [0, 400], [0, 300]]


def _run(monkeypatch, capsys, *args: str) -> SimpleNamespace:
    """``volcal ARGS`` in-process (a subprocess costs seconds on the shared box)."""
    from volcal.cli import main

    monkeypatch.setattr(sys, "argv", ["volcal", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return SimpleNamespace(code=code, out=out.out, err=out.err)


@pytest.fixture(scope="module")
def budget(tmp_path_factory):
    """The template budget with the material at 23 degC: nonzero systematic terms."""
    b = tmp_path_factory.mktemp("b") / "budget.toml"
    b.write_text(TEMPLATE.replace("temperature_c = 20.0\n# Typical material",
                                  "temperature_c = 23.0\n# Typical material"), "utf-8")
    return b


@pytest.fixture(scope="module")
def sessions(tmp_path_factory, budget):
    """The same planned session simulated with the budget by Python and by the CLI."""
    root = tmp_path_factory.mktemp("sim")
    plan = Calibration.plan(TRAVEL, steps=3, runs=2, tests=["diagonal", "linear"],
                            name="PAR-500")
    plan.save(root / "py")
    plan.save(root / "cli")
    mp = pytest.MonkeyPatch()
    try:
        from volcal.cli import main

        mp.setattr(sys, "argv", ["volcal", "simulate", str(root / "cli"), "--seed", "7",
                                 "--budget", str(budget)])
        with pytest.raises(SystemExit) as e:
            main()
        assert not e.value.code
    finally:
        mp.undo()
    py = Calibration.open(root / "py").simulate(seed=7, budget=budget).save(root / "py")
    return SimpleNamespace(root=root, py=py, budget=budget)


def test_simulate_with_a_budget_applies_the_draw(sessions):
    """The draw recorded in truth/systematic.toml is in the readings (the CLI calls the
    same step, volcal.steps.simulate: tests/test_steps_signature.py)."""
    root = sessions.root
    py = sessions.py
    t_py = tomllib.loads((root / "py" / "truth" / "systematic.toml").read_text("utf-8"))
    assert t_py["budget"] == str(sessions.budget)
    # and the draw is in the readings: without the budget they differ by it
    plain = Calibration.open(root / "py")
    plain.simulate(seed=7)
    lin = next(m for m in plain.session.measurements if m.kind == "linear")
    d = lin.positions - lin.positions[0]
    eps = (t_py["wavelength_ppm"] + t_py["air_ppm"][lin.id]) * 1e-6
    k = lin.axis
    want = eps * (d @ lin.beam_direction) * 1e3 + (
        t_py["material_ppm"]["XYZ"[k]] * 1e-6 * d[:, k] * lin.beam_direction[k] * 1e3)
    drawn = py.session.get(lin.id).deviation - lin.deviation
    assert np.abs(drawn).max() > 0.05  # [um]: visible at 23 degC
    np.testing.assert_allclose(drawn, want, atol=2e-3)  # CSV rounding


def test_identify_with_a_budget_keeps_the_systematic_part_apart(sessions, tmp_path,
                                                                 monkeypatch, capsys):
    from volcal.identify import load_model
    from volcal.identify.identifiability import grid_points
    from volcal.steps.identify import identify

    r = identify(sessions.root / "py", budget=sessions.budget)
    res = r.result
    q = grid_points(res.design)
    u_all, u_noise = res.predict(q)[1], res.predict(q, systematic=False)[1]
    assert (u_all - u_noise).max() > 1e-3  # the systematic part is there [um]
    plain = Calibration.open(sessions.root / "py").identify()
    np.testing.assert_allclose(plain.predict(q)[1], u_noise, rtol=1e-9)
    # the summary the command prints: the largest u of each part over the grid
    u = r.systematic
    assert u is not None and u.budget == str(sessions.budget)
    assert u.total_um == pytest.approx(u_all.max(), rel=1e-12)
    assert u.noise_um == pytest.approx(u_noise.max(), rel=1e-12)
    assert u.systematic_um == pytest.approx(np.sqrt(u_all**2 - u_noise**2).max(), rel=1e-9)
    assert u.n_inputs == len(res.sys_labels) > 0
    out = _run(monkeypatch, capsys, "identify", str(sessions.root / "py"), "-o",
               str(tmp_path / "m.json"), "--budget", str(sessions.budget))
    assert out.code == 0, out.err
    assert (f"noise and prior {u.noise_um:.3f} um, systematic (budget: {u.n_inputs} inputs) "
            f"{u.systematic_um:.3f} um, both {u.total_um:.3f} um") in out.out
    np.testing.assert_allclose(load_model(tmp_path / "m.json").predict(q)[1], u_all,
                               rtol=1e-6)  # the model file keeps the systematic part


def test_evaluate_and_guarded_verdict_equal_evaluate_session(sessions, monkeypatch, capsys):
    folder = str(sessions.root / "py")
    cal = Calibration.open(folder)
    ev = cal.evaluate(budget=sessions.budget)
    r = _run(monkeypatch, capsys, "evaluate", "session", folder, "--json", "--budget",
             str(sessions.budget), "--tolerance-um", "X=6,Y=6,Z=6,X.R=3",
             "--decision-rule", "guarded")
    assert r.code == 0, r.err
    out = json.loads(r.out)
    assert set(ev.iso230_2) == set(out["measurements"]) and cal.uncertainties
    for k, res in ev.iso230_2.items():
        m = out["measurements"][k]
        for p in ("A", "E", "R", "B"):  # the same values as the CLI's
            assert getattr(res, p) == pytest.approx(m[p], rel=1e-12, abs=1e-12)
            assert cal.uncertainties[k].parameters[p].U == pytest.approx(m[f"U_{p}"],
                                                                         rel=1e-12)
    plain = Calibration.open(folder).evaluate()  # issue 25: the budget changes no value
    for k in ev.iso230_2:
        assert all(getattr(plain.iso230_2[k], p) == getattr(ev.iso230_2[k], p)
                   for p in ("A", "E", "M", "R", "B", "B_mean")), k
    v = cal.verdict("X=6,Y=6,Z=6,X.R=3", decision_rule="guarded", budget=sessions.budget)
    assert [x.to_dict() for x in v] == out["verdict"]
    assert {x.rule for x in v} == {"guarded"} and all(x.U_before_um > 0 for x in v)
    # a guard band instead of U
    r = _run(monkeypatch, capsys, "evaluate", "session", folder, "--json", "--tolerance-um",
             "X=6,Y=6,Z=6", "--decision-rule", "guarded", "--guard-band-um", "1.5")
    assert r.code == 0, r.err
    v = cal.verdict({"X": 6, "Y": 6, "Z": 6}, decision_rule="guarded", guard_band_um=1.5)
    assert [x.to_dict() for x in v] == json.loads(r.out)["verdict"]
    assert {x.guard_band_um for x in v} == {1.5}


def _identity(folder) -> None:
    """Give the session the [calibration] keys of a certificate (measured on a date)."""
    import tomli_w

    p = folder / "session.toml"
    doc = tomllib.loads(p.read_text("utf-8"))
    doc["machine"].update(make="Hermle", model="C 42", serial="42-1187")
    doc["calibration"] = {"date": "2026-11-23", "operator": "A. Technician",
                          "laboratory": "Metrology Service GmbH"}
    p.write_text(tomli_w.dumps(doc), "utf-8")


@pytest.fixture
def fast_report(monkeypatch):
    """The technical report's rendering stubbed (its HTML is the title, its PDF one page):
    rendered, it costs about 12 s per report, and tests/report checks it. The certificate
    (its document, JSON and HTML) is written for real; its PDF too, unless the test stubs
    it (:func:`report_stubs.use_stub_pdfs`, where it compares the JSON only: the PDF, some
    2-3 s of drawing per certificate, is read back in tests/report/test_certificate.py)."""
    import volcal.report.writer as w

    def write_pdf(report, path, **keywords):  # no PNGs: the stubbed png_bytes below
        path.write_bytes(b"%PDF-1.4 stub")
        return 1

    monkeypatch.setattr(w, "render_html", lambda report: f"<title>{report.title}</title>")
    monkeypatch.setattr(w, "write_pdf", write_pdf)
    monkeypatch.setattr(w, "png_bytes", lambda fig: b"")


def test_certificate_from_python_equals_the_clis(sessions, tmp_path, monkeypatch, capsys,
                                                 fast_report):
    """certificate.json from Calibration.report equals `volcal report`'s (guarded rule,
    guard band, budget), the date of issue apart."""
    import shutil

    shutil.copytree(sessions.root / "py", tmp_path / "s")
    _identity(tmp_path / "s")
    cal = Calibration.open(tmp_path / "s")
    # with a budget the certificate's model carries its systematic part (issue 25): a
    # model file identified without one is refused, so both identify with it
    cal.identify(budget=sessions.budget)
    cal.result.to_json(tmp_path / "m.json")
    files = cal.report(tmp_path / "py", tolerance_um="X=6,Y=6,Z=6,X.R=3,V=40",
                       decision_rule="guarded", guard_band_um=0.5, budget=sessions.budget)
    assert cal.certificate is not None  # automatic: the session has [calibration] keys
    assert cal.certificate.pdf.is_file() and cal.certificate.pdf_pages >= 1  # drawn
    use_stub_pdfs(monkeypatch)  # the CLI's certificate: its JSON compared, not its PDF
    r = _run(monkeypatch, capsys, "report", str(tmp_path / "s"), "-o", str(tmp_path / "cli"),
             "--model", str(tmp_path / "m.json"), "--tolerance-um", "X=6,Y=6,Z=6,X.R=3,V=40",
             "--decision-rule", "guarded", "--guard-band-um", "0.5", "--budget",
             str(sessions.budget))
    assert r.code == 0, r.err
    assert cal.certificate.json == tmp_path / "py" / "certificate.json"
    py = json.loads(cal.certificate.json.read_text("utf-8"))
    cli = json.loads((tmp_path / "cli" / "certificate.json").read_text("utf-8"))
    for doc in (py, cli):
        assert doc.pop("issued", None) is not None
    _close(py, cli, "certificate")  # the model file keeps 9 digits
    # the technical report names its certificate, as the CLI's does
    title = files.html.read_text("utf-8")
    assert title == (tmp_path / "cli" / "report.html").read_text("utf-8")
    assert title.endswith(f"technical report to certificate {py['report_id']}</title>")
    conf = py["conformity"]
    assert conf["decision_rule"] == "guarded" and conf["guard_band_um"] == 0.5
    (x_r,) = [s for s in conf["statements"] if s["quantity"].startswith("X: ISO 230-2 R ")]
    assert x_r["tolerance_um"] == 3.0 and x_r["U_um"] > 0  # U of R from the budget
    ev = cal.evaluate()  # R is a spread: referred to 20 degC or not, the same to 1e-4
    r_x = max(ev.iso230_2[k].R for k, a in ev.axis.items() if a == "X")
    assert x_r["value_um"] == pytest.approx(r_x, rel=1e-4)
    assert x_r["verdict"] == ("fail" if r_x > 3 else "pass" if r_x <= 2.5 else "conditional")


def test_as_found_as_left_certificate_equals_the_clis(sessions, tmp_path, monkeypatch,
                                                     capsys, fast_report):
    """as_left= (a Calibration or a folder) and tables= as --as-left and --tables; a
    budget without a tolerance gives U of both sessions' tests. The certificates' JSON is
    compared; their PDFs are stubbed (an as-found/as-left certificate's PDF is read back in
    tests/report/test_certificate.py)."""
    import shutil

    use_stub_pdfs(monkeypatch)
    shutil.copytree(sessions.root / "py", tmp_path / "found")
    shutil.copytree(sessions.root / "py", tmp_path / "left")
    Calibration.open(tmp_path / "left").simulate(seed=8).save(tmp_path / "left")
    for name in ("found", "left"):
        _identity(tmp_path / name)
    cal = Calibration.open(tmp_path / "found")
    cal.identify()
    cal.result.to_json(tmp_path / "m.json")
    cal.compensate(tmp_path / "tables", format="csv")
    left = Calibration.open(tmp_path / "left")
    cal.report(tmp_path / "py", as_left=left, tables=tmp_path / "tables")
    r = _run(monkeypatch, capsys, "report", str(tmp_path / "found"), "-o",
             str(tmp_path / "cli"), "--model", str(tmp_path / "m.json"), "--as-left",
             str(tmp_path / "left"), "--tables", str(tmp_path / "tables"))
    assert r.code == 0, r.err
    py = json.loads(cal.certificate.json.read_text("utf-8"))
    cli = json.loads((tmp_path / "cli" / "certificate.json").read_text("utf-8"))
    for doc in (py, cli):
        doc.pop("issued")
    _close(py, cli, "certificate")
    assert py["as_found_as_left"]["tables"]["manifest_sha256"] == hashlib.sha256(
        (tmp_path / "tables" / "volcal-compensation.toml").read_bytes()).hexdigest()
    (pair,) = [p for p in py["as_found_as_left"]["pairs"]
               if p["measurement"] == "linear-x1" and p["quantity"] == "A"]
    a_found = cal.evaluate().iso230_2["linear-x1"].A
    a_left = left.evaluate().iso230_2["linear-x1"].A
    assert abs(a_found - a_left) > 0.1  # two sets of readings
    assert pair["as_found_um"] == pytest.approx(a_found, rel=1e-12)
    assert pair["as_left_um"] == pytest.approx(a_left, rel=1e-12)
    # a folder works as well as a Calibration; a budget gives U of the as-left tests
    cal.report(tmp_path / "py2", as_left=tmp_path / "left", tables=tmp_path / "tables",
               budget=sessions.budget)
    py2 = json.loads(cal.certificate.json.read_text("utf-8"))
    # other content (the budget's U and tables): another number (issue 25)
    assert py2["report_id"] != py["report_id"] and py2["as_found_as_left"]["tables"] == \
        py["as_found_as_left"]["tables"]
    left.evaluate(budget=sessions.budget)
    (x1,) = [p for p in py2["results"]["as_left"]["positioning"]
             if p["measurement"] == "linear-x1"]
    assert x1["U_um"]["A"] == pytest.approx(
        left.uncertainties["linear-x1"].parameters["A"].U, rel=1e-12)
    assert x1["U_um"]["A"] > 0.1  # [um]


def test_report_refuses_another_machines_tables_unless_forced(sessions, tmp_path,
                                                              fast_report):
    """report(compensation=..., force=True) as `volcal report --compensation --force`."""
    import warnings

    from volcal.errors import VolcalInputError

    other = Calibration.plan(TRAVEL, steps=3, runs=2, tests=["linear"], name="OTHER-500")
    other.simulate(seed=1).identify()
    other.compensate(tmp_path / "t", format="csv")
    cal = Calibration.open(sessions.root / "py")
    cal.identify()
    with pytest.raises(VolcalInputError) as e:
        cal.report(tmp_path / "r", compensation=tmp_path / "t")
    assert "OTHER-500" in str(e.value) and "force=True" in str(e.value)
    assert "--force" not in str(e.value)  # Python's keyword, not the CLI's option
    assert not (tmp_path / "r").exists()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        files = cal.report(tmp_path / "r", compensation=tmp_path / "t", force=True)
    assert files.html.is_file()
    (warned,) = [str(x.message) for x in w if "OTHER-500" in str(x.message)]
    assert warned.startswith("force=True: the compensation tables")


def test_a_folder_of_other_files_is_never_replaced(sessions, tmp_path):
    """report, compensate and program refuse a non-empty folder they did not write, as
    `volcal report/compensate/program -o` do (atomic replacement would delete its files);
    their own earlier output is replaced."""
    from volcal.errors import VolcalInputError

    cal = Calibration.open(sessions.root / "py")
    cal.identify()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.txt").write_text("precious", "utf-8")
    for what, call in (("report", lambda: cal.report(mine)),
                       ("compensation", lambda: cal.compensate(mine, format="csv")),
                       ("program", lambda: cal.program(mine, "linuxcnc"))):
        with pytest.raises(VolcalInputError) as e:
            call()
        assert str(e.value) == (f"{mine}: exists and is not a volcal {what} folder; choose "
                                "a new or empty folder")
    assert [p.name for p in mine.iterdir()] == ["thesis.txt"]
    assert (mine / "thesis.txt").read_text("utf-8") == "precious"
    files = cal.compensate(tmp_path / "c", format="csv")
    assert cal.compensate(tmp_path / "c", format="csv") == files  # its own: replaced
    folder, _ = cal.program(tmp_path / "p", "linuxcnc")
    assert cal.program(tmp_path / "p", "linuxcnc")[0] == folder


def _close(a, b, where):
    """Equal JSON, numbers to 1e-6 relative (model.json holds 9 significant digits)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), where
        for k in a:
            _close(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _close(x, y, f"{where}[{i}]")
    elif isinstance(a, float) and not isinstance(b, bool):
        assert b == pytest.approx(a, rel=1e-6, abs=1e-9), where
    else:
        assert a == b, where
