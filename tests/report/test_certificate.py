"""The calibration certificate (issue 17, deliver 5): PDF read back with pdftotext, JSON
validated against its schema, expired equipment, --strict, as-found / as-left.

One simulated machine is measured twice: as found, and as left after its positioning
errors were taken out (what perfect pitch tables do). The certificate is rendered ONCE,
through the command line, in the module fixture; every number the tests expect is
computed here independently (ISO 230-2 evaluated directly, the environment from the
values written into the CSV, the tables' manifest hashed from its file). The technical
report beside it is written with blank figures (tests/report_stubs.py: its pages and
their footers are read here, its figures are drawn by tests/report/test_report_*.py).
"""

import datetime as dt
import hashlib
import json
import shutil
import subprocess
import tomllib
from pathlib import Path
from types import SimpleNamespace

import jsonschema
import numpy as np
import pytest
import tomli_w

from report_stubs import use_blank_figures
from timing import scaled_timeout
from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.errorfunctions import MachineErrors
from volcal.plan.planner import plan_session
from volcal.report.certificate import (
    build_certificate,
    conformity_verdict,
    report_id,
    tables_of,
)
from volcal.report.certificate_files import schema
from volcal.report.certificate_layout import layout
from volcal.session.format import read_session, write_session
from volcal.session.provenance import readings_digest
from volcal.standards.iso230_2 import evaluate
from volcal.standards.positioning_data import from_measurement
from volcal_cli_helpers import volcal_process

TRAVEL = np.array([[0, 400], [0, 300], [0, 250]], float)
FOUND_DATE, LEFT_DATE = dt.date(2026, 11, 23), dt.date(2026, 11, 24)
TOLERANCE = "X=15,Y=9,Z=12,V=60"
N_ENV = 30  # the air temperature column cycles through 20.10, 20.11, ... 20.39 degC


def _run(*args):
    """``volcal *args`` (in-process unless VOLCAL_TEST_SUBPROCESS=1: volcal_cli_helpers)."""
    p = volcal_process(*args, timeout=scaled_timeout(600))
    p.stdout, p.stderr = " ".join(p.stdout.split()), " ".join(p.stderr.split())
    return p


def _identity(folder: Path, date: dt.date) -> None:
    """Write the identity keys, the equipment (an expired air sensor) and environment."""
    p = folder / "session.toml"
    doc = tomllib.loads(p.read_text(encoding="utf-8"))
    doc["machine"].update(make="Hermle", model="C 42", serial="42-1187",
                          control="Heidenhain TNC 640", location="Hall 2, bay 4")
    doc["calibration"] = {"date": date, "operator": "A. Technician", "customer": "Shop Ltd",
                          "laboratory": "Metrology Service GmbH",
                          "laboratory_address": "Messweg 1, 12345 Prüfstadt",
                          "approved_by": "B. Manager"}
    doc["equipment"] = [
        {"role": "laser", "make": "Renishaw", "model": "XL-80", "serial": "L-12345",
         "certificate": "CAL-2026-0815", "calibrated": dt.date(2026, 3, 1),
         "due": dt.date(2027, 3, 1)},
        {"role": "air sensor", "make": "Renishaw", "model": "XC-80", "serial": "XC-777",
         "certificate": "CAL-2025-0042", "calibrated": dt.date(2025, 1, 10),
         "due": dt.date(2026, 1, 10)}]
    for m in doc["measurements"]:
        if m["id"] == "linear-x1":
            m["environment"] = {"air_pressure_pa": 100870.0, "material_temperature_c": 20.6}
    csv = folder / "linear-x1.csv"
    lines = csv.read_text(encoding="utf-8").splitlines()
    rows = [lines[0] + ",air_temperature_c,humidity_pct"]
    rows += [f"{line},{20.10 + 0.01 * (i % N_ENV):.2f},{45 + i % 3}"
             for i, line in enumerate(lines[1:])]
    csv.write_text("\n".join(rows) + "\n", encoding="utf-8")
    p.write_text(tomli_w.dumps(doc), encoding="utf-8")


def _iso230_2_A(folder: Path) -> dict[str, float]:
    s = read_session(folder)
    out = {}
    for m in s.measurements:
        if m.kind == "linear":
            d = from_measurement(m, s.path)
            out[m.id] = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, "2014",
                                 **d.evaluate_kwargs()).A
    return out


@pytest.fixture(scope="module")
def cert(tmp_path_factory):
    from volcal.compensate.formats import CompensationOptions, write_compensation
    from volcal.identify import identify

    if not (shutil.which("pdftotext") and shutil.which("pdfinfo")):
        pytest.skip("poppler-utils is not installed (make browser-deps installs it)")
    root = tmp_path_factory.mktemp("certificate")
    found = random_machine(TRAVEL, "XYFZ", seed=5, n_nodes=21)
    values = [v.copy() for v in found.values]
    for k in range(3):
        values[k][:, k] = 0.0  # as left: the positioning errors compensated
    left = MachineErrors(found.chain, found.nodes, values, found.squareness, found.reversal)
    for name, machine, seed, date in (("found", found, 1, FOUND_DATE),
                                      ("left", left, 2, LEFT_DATE)):
        s = plan_session(TRAVEL, "XYFZ", 5, ("diagonal", "linear"), 3, name="CERT-VMC")
        simulate_session(s, machine, SimulationOptions(noise_um=0.3, seed=seed))
        write_session(s, root / name)
        _identity(root / name, date)
    s = read_session(root / "found")
    r = identify(s)
    r.to_json(root / "model.json")
    write_compensation(r.errors, "heidenhain", root / "comp",
                       CompensationOptions("error", 25.0), "model.json")
    out = root / "out"
    with pytest.MonkeyPatch.context() as mp:
        use_blank_figures(mp)
        p = _run("report", str(root / "found"), "--model", str(root / "model.json"),
                 "--as-left", str(root / "left"), "--tables", str(root / "comp"),
                 "--tolerance-um", TOLERANCE, "-o", str(out))
    assert p.returncode == 0, p.stderr
    text = subprocess.run(["pdftotext", "-layout", str(out / "certificate.pdf"), "-"],
                          capture_output=True, text=True, check=True).stdout
    pages = text.split("\f")
    if not pages[-1].strip():
        pages = pages[:-1]
    return SimpleNamespace(root=root, out=out, stdout=p.stdout, text=text, pages=pages,
                           flat=" ".join(text.split()),
                           doc=json.loads((out / "certificate.json").read_text("utf-8")),
                           found=s, left=read_session(root / "left"), model=r)


def test_the_certificate_pdf_holds_every_required_field(cert):
    t, doc = cert.flat, cert.doc
    rid = doc["report_id"]
    # the derived id: laboratory initials, date of measurement, and the SHA-256 of all
    # it states (canonical JSON, numbers to 9 significant digits; issue 25) but the
    # number itself, the date of issue and the program's version; the model's numbers
    # enter through its digest
    def nine(x):
        if isinstance(x, dict):
            return {k: nine(v) for k, v in x.items()}
        if isinstance(x, list):
            return [nine(v) for v in x]
        return float(f"{x:.9g}") if isinstance(x, float) else x

    body = json.loads(json.dumps({k: v for k, v in doc.items() if k not in (
        "report_id", "report_id_source", "content_sha256", "issued", "generator")}))
    del body["dates"]["issued"]
    vol = body["results"]["as_found"]["volumetric"]
    assert len(vol["model_sha256"]) == 64
    body["results"]["as_found"]["volumetric"] = {
        k: v for k, v in vol.items() if not k.startswith(("E_V", "U_um", "k"))}
    for row in body["conformity"]["statements"]:
        if row["quantity"].startswith("volumetric"):
            del row["value_um"], row["U_um"]
    h = hashlib.sha256(json.dumps(nine(body), sort_keys=True, separators=(",", ":"),
                                  ensure_ascii=False).encode())
    assert doc["content_sha256"] == h.hexdigest()
    assert rid == f"MSG-20261123-{h.hexdigest()[:8].upper()}"
    assert doc["results"]["as_found"]["readings_sha256"] == readings_digest(cert.found)
    assert doc["results"]["as_left"]["readings_sha256"] == readings_digest(cert.left)
    for field in ["Calibration certificate", f"Certificate number {rid}",
                  "Metrology Service GmbH", "Messweg 1, 12345 Prüfstadt", "Shop Ltd",
                  "Hermle", "C 42", "42-1187", "Heidenhain TNC 640", "Hall 2, bay 4",
                  "CERT-VMC", "0 to 400, 0 to 300, 0 to 250",
                  "Date of measurement (as-found) 2026-11-23",
                  "Date of measurement (as-left) 2026-11-24",
                  f"Date of issue {dt.date.today().isoformat()}",
                  "ISO 230-2:2014", "ISO 230-6:2002", "ISO 230-1:2012",
                  "Environment as measured", "Measuring equipment",
                  "L-12345", "CAL-2026-0815", "2027-03-01", "XC-777", "CAL-2025-0042",
                  "2026-01-10", "[µm]", "No measurement-uncertainty budget given",
                  "Statement of conformity", "simple acceptance (ILAC-G8:09/2019",
                  "Performed by: A. Technician", "Approved by: B. Manager"]:
        assert field in t, field
    # environment as measured: the ranges written into linear-x1.csv and its table
    n = cert.found.get("linear-x1").n
    t_max = 20.10 + 0.01 * min(n - 1, N_ENV - 1)
    assert f"linear-x1 20.10 to {t_max:.2f} 100870 45.0 to 47.0 20.60" in t
    # results with units: ISO 230-2 A of every linear test, evaluated independently
    for mid, a in _iso230_2_A(cert.root / "found").items():
        assert f"{a:.2f}" in t, mid
    # the end mark, once, on the last page after the signatures
    assert t.count("End of certificate") == 1
    assert "End of certificate" in cert.pages[-1]
    assert cert.pages[-1].index("Approved by") < cert.pages[-1].index("End of certificate")
    assert f"certificate {rid}" in cert.stdout


def test_every_page_carries_the_report_id_and_page_n_of_m(cert):
    rid = cert.doc["report_id"]
    n = len(cert.pages)
    assert n >= 2
    info = subprocess.run(["pdfinfo", str(cert.out / "certificate.pdf")], capture_output=True,
                          text=True, check=True).stdout
    assert f"Pages: {n}" in " ".join(info.split())
    for i, page in enumerate(cert.pages, start=1):
        flat = " ".join(page.split())
        assert f"page {i} of {n}" in flat, i
        assert flat.count(rid) >= 2, i  # header and footer


def test_the_technical_report_names_the_certificate_on_every_page(cert):
    text = subprocess.run(["pdftotext", str(cert.out / "report.pdf"), "-"],
                          capture_output=True, text=True, check=True).stdout
    pages = [p for p in text.split("\f") if p.strip()]
    assert len(pages) > 3
    for i, page in enumerate(pages, start=1):
        assert cert.doc["report_id"] in page, i


def test_the_json_validates_against_its_schema(cert):
    sch = schema()
    jsonschema.Draft202012Validator.check_schema(sch)
    jsonschema.validate(cert.doc, sch, cls=jsonschema.Draft202012Validator)
    assert cert.doc["format"] == "volcal-certificate/1"
    # the schema is not vacuous: a verdict outside pass|fail|conditional, a missing report
    # id, an unknown top-level key are refused
    bad = json.loads(json.dumps(cert.doc))
    bad["conformity"]["statements"][0]["verdict"] = "FAIL"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, sch, cls=jsonschema.Draft202012Validator)
    for mutate in (lambda d: d.pop("report_id"), lambda d: d.update(extra=1),
                   lambda d: d["results"]["as_found"]["positioning"][0]["values_um"].pop("A")):
        bad = json.loads(json.dumps(cert.doc))
        mutate(bad)
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(bad, sch, cls=jsonschema.Draft202012Validator)


def test_the_html_is_the_same_certificate(cert):
    html = (cert.out / "certificate.html").read_text(encoding="utf-8")
    assert cert.doc["report_id"] in html and "End of certificate" in html
    assert 'counter(page) " of " counter(pages)' in html  # page n of m when printed
    # highlighted rows: the expired air sensor and every failed statement of conformity
    fails = sum(r["verdict"] == "fail" for r in cert.doc["conformity"]["statements"])
    assert html.count('class="flagged"') == 1 + fails
    assert '<tr class="flagged"><td>air sensor</td>' in html


def test_expired_equipment_is_flagged(cert):
    eq = {e["serial"]: e for e in cert.doc["equipment"]}
    assert eq["XC-777"]["expired"] and eq["XC-777"]["expired_on"] == ["2026-11-23",
                                                                      "2026-11-24"]
    assert not eq["L-12345"]["expired"]
    assert eq["XC-777"]["used_in"] == ["as_found", "as_left"]
    row = [ln for ln in cert.text.splitlines() if "XC-777" in ln and "CAL-2025-0042" in ln]
    assert row and "EXPIRED" in row[0]
    laser = [ln for ln in cert.text.splitlines() if "L-12345" in ln and "CAL-2026" in ln]
    assert laser and "EXPIRED" not in laser[0] and "valid" in laser[0]
    assert any(w.startswith("EXPIRED EQUIPMENT") and "XC-777" in w
               for w in cert.doc["warnings"])


def test_strict_refuses_expired_equipment_naming_the_item(cert, tmp_path):
    out = tmp_path / "r"
    p = _run("report", str(cert.root / "found"), "--strict", "-o", str(out))
    assert p.returncode == 2, p.stderr
    assert "XC-777" in p.stderr and "equipment[2].due" in p.stderr
    assert "2026-01-10" in p.stderr and "2026-11-23" in p.stderr
    assert "Traceback" not in p.stderr and not out.exists()


def test_tables_without_as_left_and_tables_of_another_machine_are_refused(cert, tmp_path):
    p = _run("report", str(cert.root / "found"), "--tables", str(cert.root / "comp"),
             "-o", str(tmp_path / "r"))
    assert p.returncode == 2 and "--as-left" in p.stderr
    other = tmp_path / "other"
    shutil.copytree(cert.root / "comp", other)
    man = other / "volcal-compensation.toml"
    doc = tomllib.loads(man.read_text(encoding="utf-8"))
    doc["machine"] = ({**doc["machine"], "serial": "99-0001"}
                      if isinstance(doc["machine"], dict) else "ANOTHER-VMC")
    man.write_text(tomli_w.dumps(doc), encoding="utf-8")
    with pytest.raises(VolcalInputError, match="another machine"):
        tables_of(other, cert.found)


def test_as_found_and_as_left_pair_the_two_measured_results(cert):
    pair = cert.doc["as_found_as_left"]
    a_found, a_left = _iso230_2_A(cert.root / "found"), _iso230_2_A(cert.root / "left")
    rows = {p["measurement"]: p for p in pair["pairs"] if p["quantity"] == "A"}
    assert set(rows) == set(a_found) and len(rows) == 9
    for mid, p in rows.items():
        assert p["as_found_um"] == pytest.approx(a_found[mid], abs=1e-9)
        assert p["as_left_um"] == pytest.approx(a_left[mid], abs=1e-9)
        assert f"{a_found[mid]:.2f} {a_left[mid]:.2f}" in cert.flat
    # the positioning errors were taken out before the as-left measurement: on the lines
    # through the axes' reference lines (no Abbe offset) A falls to the repeatability
    for mid in ("linear-x1", "linear-y1", "linear-z1"):
        assert rows[mid]["as_left_um"] < 0.25 * rows[mid]["as_found_um"], mid
    assert sum(a_left.values()) < 0.5 * sum(a_found.values())
    tab = pair["tables"]
    man = cert.root / "comp" / "volcal-compensation.toml"
    assert tab["folder"] == "comp" and tab["controller_format"] == "heidenhain"
    assert tab["manifest_sha256"] == hashlib.sha256(man.read_bytes()).hexdigest()
    assert tab["carries"] == ["EXX", "EYY", "EZZ"]
    for words in ("Compensation tables loaded comp", "volcal-compensation.toml (sha256 "
                  + tab["manifest_sha256"][:16], "Controller format heidenhain"):
        assert words in cert.flat
    # the tables were named, not applied again: the as-left results are the session's own
    left = cert.doc["results"]["as_left"]["positioning"]
    assert {r["measurement"]: r["values_um"]["A"] for r in left} == pytest.approx(a_left)


def test_the_statement_of_conformity_follows_the_rule(cert):
    c = cert.doc["conformity"]
    assert c["decision_rule"] == "simple" and c["tolerance"] == TOLERANCE
    tol = {"X": 15.0, "Y": 9.0, "Z": 12.0}
    s = read_session(cert.root / "found")
    for state, folder in (("as_found", "found"), ("as_left", "left")):
        a = _iso230_2_A(cert.root / folder)
        for axis, t in tol.items():
            worst = max(v for k, v in a.items() if s.get(k).axis == "XYZ".index(axis))
            row = next(r for r in c["statements"] if r["state"] == state
                       and r["quantity"].startswith(f"{axis}: ISO 230-2 A"))
            assert row["value_um"] == pytest.approx(worst, abs=1e-9)
            assert row["verdict"] == ("pass" if worst <= t else "fail")
    verdicts = {r["verdict"] for r in c["statements"] if r["state"] == "as_found"}
    assert "fail" in verdicts  # the tolerance above was chosen to fail the machine as found
    vol = next(r for r in c["statements"] if r["state"] == "as_found"
               and r["quantity"].startswith("volumetric"))
    assert vol["value_um"] <= 60.0 and vol["verdict"] == "pass"


def test_decision_rules_simple_and_guarded():
    # simple acceptance: at T passes, above fails, never conditional
    assert conformity_verdict(10.0, 10.0)[0] == "pass"
    assert conformity_verdict(10.01, 10.0)[0] == "fail"
    # guarded with w = U = 2: pass at or below T - U, conditional between, fail above T
    assert conformity_verdict(8.0, 10.0, "guarded", U_um=2.0)[0] == "pass"
    assert conformity_verdict(9.0, 10.0, "guarded", U_um=2.0)[0] == "conditional"
    assert conformity_verdict(10.0, 10.0, "guarded", U_um=2.0)[0] == "conditional"
    assert conformity_verdict(10.5, 10.0, "guarded", U_um=2.0)[0] == "fail"
    verdict, why = conformity_verdict(1.0, 10.0, "guarded", U_um=12.0)
    assert verdict == "conditional" and "no pass is possible" in why
    assert conformity_verdict(8.5, 10.0, "guarded", U_um=2.0, guard_band_um=1.0)[0] == "pass"
    with pytest.raises(VolcalInputError, match="expected one of simple, guarded"):
        conformity_verdict(1.0, 2.0, "strict")


class _Unc:
    """The shape volcal.uncertainty gives per ISO 230-2 evaluation (``to_dict``)."""

    def __init__(self, U):
        self.U = U

    def to_dict(self):
        return {**{f"U_{k}": self.U for k in ("A", "E", "M", "R", "B")}, "k": 2.05,
                "uncertainty": {"budget": {
                    "measurand": "mean bidirectional positional deviation at 380 mm",
                    "u_um": self.U / 2.05, "dof": 40.0, "k": 2.05, "U_um": self.U,
                    "components": [
                        {"label": "material temperature", "u": 0.6, "share": 0.9},
                        {"label": "laser wavelength", "u": 0.01, "share": 0.001}]}}}


def test_uncertainty_and_a_guarded_rule_when_given(cert):
    from volcal.standards.tolerance import Tolerance

    a = _iso230_2_A(cert.root / "found")
    worst = {ax: max(v for k, v in a.items() if cert.found.get(k).axis == "XYZ".index(ax))
             for ax in "XYZ"}
    U = 1.5
    # X: within T but not by U (conditional); Y: T - U above the value (pass); Z: fail
    tol = Tolerance(None, {"X": worst["X"] + 1.0, "Y": worst["Y"] + 2.0,
                           "Z": worst["Z"] - 0.5})
    doc = build_certificate(cert.found, tolerance=tol, decision_rule="guarded",
                            uncertainties={k: _Unc(U) for k in a}, issued="2026-11-25")
    jsonschema.validate(doc, schema(), cls=jsonschema.Draft202012Validator)
    assert doc["uncertainty"]["given"] and doc["issued"] == "2026-11-25"
    assert "no measurement-uncertainty budget given" not in doc["warnings"]
    verdict = {r["quantity"][0]: r for r in doc["conformity"]["statements"]}
    assert [verdict[x]["verdict"] for x in "XYZ"] == ["conditional", "pass", "fail"]
    assert all(verdict[x]["U_um"] == U for x in "XYZ")
    pos = doc["results"]["as_found"]["positioning"][0]
    assert pos["U_um"]["A"] == U and pos["k"] == 2.05
    blocks = [b for s in layout(doc) for b in s.blocks if b.kind == "table"]
    res = next(b for b in blocks if b.title.startswith("positioning"))
    assert "U(A)" in res.columns and res.rows[0][res.columns.index("U(A)")] == "1.50"
    bud = next(b for b in blocks if b.title.startswith("Uncertainty budget, linear-x1"))
    assert bud.columns == ["label", "u", "share"] and bud.rows[0][0] == "material temperature"
    assert "k = 2.050" in bud.title and "U_um = 1.500" in bud.title
    # without them: the certificate says no budget was given
    assert not cert.doc["uncertainty"]["given"]


def test_the_report_id_is_stable_and_a_given_one_wins(cert):
    # the same readings give the same id; a given [calibration] report_id wins
    assert report_id(cert.found)[0] == report_id(read_session(cert.root / "found"))[0]
    assert report_id(cert.found)[0] != report_id(cert.left)[0]
    cert.found.calibration["report_id"] = "MSG-2026-0042"
    try:
        assert report_id(cert.found) == ("MSG-2026-0042", "calibration.report_id")
    finally:
        del cert.found.calibration["report_id"]


def test_an_as_left_session_of_another_machine_is_refused(cert, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(cert.root / "left", other)
    toml = other / "session.toml"
    toml.write_text(toml.read_text(encoding="utf-8").replace('serial = "42-1187"',
                                                             'serial = "42-9999"'),
                    encoding="utf-8")
    with pytest.raises(VolcalInputError, match="two machines.*42-1187.*42-9999"):
        build_certificate(cert.found, as_left=read_session(other))
