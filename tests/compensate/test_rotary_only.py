"""A calibration without a linear model: a machine whose rotary axis alone is calibrated.

``volcal compensate --session S`` without a model writes the rotary tables alone (their
A before and after checked, in arcsec on request), ``volcal history add S`` without
``--model`` stores the rotary results, ``history show/trend/compare --units arcsec``
print them in arcsec, and the report and the certificate say that no linear model was
identified. Every number is checked against the ISO 230-2 rotary evaluation of the same
readings (``evaluate_rotary_measurement``).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from volcal_cli_helpers import run_volcal

ARCSEC_URAD = 4.8481368110953599


@pytest.fixture(scope="module")
def rotary_only(tmp_path_factory):
    """A simulated session with one test of a full-circle C axis and nothing else."""
    from volcal.steps.plan import plan
    from volcal.steps.simulate import save, simulate

    s = tmp_path_factory.mktemp("rot") / "session"
    plan([[0, 400], [0, 300], [0, 200]], tests="rotary:c", steps=6, runs=2, output=s)
    save(simulate(s, seed=3), s)
    return s


def _A(folder) -> float:
    from volcal.session.format import read_session
    from volcal.standards.iso230_2_rotary import evaluate_rotary_measurement

    m = read_session(folder).measurements[0]
    return float(evaluate_rotary_measurement(m).iso.A)


def test_compensate_without_a_model_writes_the_rotary_tables_alone(rotary_only, tmp_path,
                                                                    monkeypatch, capsys):
    import tomllib

    a = _A(rotary_only)
    out = tmp_path / "comp"
    code, stdout, err = run_volcal(monkeypatch, capsys, "compensate", "--session",
                                   str(rotary_only), "--format", "linuxcnc", "-o", str(out))
    assert code == 0, err
    assert "no linear model given: only the session's rotary tables" in err
    assert "wrote linuxcnc rotary tables (correction, the controller's convention)" in stdout
    man = tomllib.loads((out / "volcal-compensation.toml").read_text())
    assert man["linear"] is False and man["model"] == "" and man["files"] == [
        "C.comp", "ROTARY_NOTES.TXT"]
    assert man["rotary"][0]["id"] == "rotary-c" and man["machine"]["name"] == "VMC-1"
    row = next(x for x in stdout.splitlines() if "rotary-c" in x).split("│")
    before, after = float(row[3]), float(row[4])
    assert before == pytest.approx(a, abs=0.005)  # the test's own ISO 230-2 A [urad]
    assert after < before / 3
    # the same in arcsec (display only: the tables are the same)
    code, stdout2, err = run_volcal(monkeypatch, capsys, "compensate", "--session",
                                    str(rotary_only), "--format", "linuxcnc", "-o", str(out),
                                    "--units", "arcsec")
    assert code == 0, err
    row2 = next(x for x in stdout2.splitlines() if "rotary-c" in x).split("│")
    assert float(row2[3]) == pytest.approx(a / ARCSEC_URAD, abs=0.005)
    assert float(row2[4]) == pytest.approx(after / ARCSEC_URAD, abs=0.01)
    # the full-circle closure is stated, in the unit asked for
    from volcal.session.format import read_session
    from volcal.standards.iso230_2_rotary import evaluate_rotary_measurement

    clo = evaluate_rotary_measurement(read_session(rotary_only).measurements[0]).closure_urad
    assert (f"rotary-c: full circle, 0 and 360 deg are one position (closure "
            f"{clo['up'] / ARCSEC_URAD:.2f} up, {clo['down'] / ARCSEC_URAD:.2f} down arcsec"
            ) in stdout2
    # the folder holds no linear tables: reading them back (report --compensation) says so
    from volcal.compensate.readback import read_written_tables
    from volcal.errors import VolcalInputError

    with pytest.raises(VolcalInputError, match="rotary tables only"):
        read_written_tables(out)
    # a format without rotary tables, and no model nor session: clear errors
    code, _, err = run_volcal(monkeypatch, capsys, "compensate", "--session",
                              str(rotary_only), "--format", "csv", "-o", str(tmp_path / "x"))
    assert code != 0 and "no rotary table in the csv format" in err
    code, _, err = run_volcal(monkeypatch, capsys, "compensate", "--format", "linuxcnc",
                              "-o", str(tmp_path / "y"))
    assert code != 0 and "no model given" in err
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_calibration_of_a_rotary_only_session(rotary_only, tmp_path, monkeypatch):
    """Python: compensate writes the rotary tables; report is given no model to identify."""
    import volcal.steps.report as report_step
    from volcal.flow import Calibration

    c = Calibration.open(rotary_only)
    with pytest.warns(UserWarning, match="only the rotary tables were written"):
        files = c.compensate(tmp_path / "h", "heidenhain")
    assert files == ["C.COM", "ROTARY_NOTES.TXT", "VOLCAL_ROTARY.CMA"]
    assert c.result is None  # nothing was identified
    seen = {}

    def spy(session, **kw):
        seen.update(kw)
        raise RuntimeError("stop")

    monkeypatch.setattr(report_step, "report", spy)
    with pytest.raises(RuntimeError, match="stop"):
        c.report(tmp_path / "r")
    assert "model" in seen and seen["model"] is None


def test_history_of_a_rotary_only_calibration(rotary_only, tmp_path, monkeypatch, capsys):
    pytest.importorskip("sqlalchemy")
    a = _A(rotary_only)
    db = str(tmp_path / "h.sqlite")
    code, out, err = run_volcal(monkeypatch, capsys, "history", "add", str(rotary_only),
                                "--db", db, "--create")
    assert code == 0, err
    rid = out.strip()
    assert "no model given: stored without a linear model" in err
    code, out, err = run_volcal(monkeypatch, capsys, "history", "show", rid, "--db", db,
                                "--json")
    d = json.loads(out)
    assert d["payload"]["model"] is None
    assert d["results"]["C.A"]["value"] == pytest.approx(a, rel=1e-9)
    assert d["results"]["C.A"]["unit"] == "urad"
    code, out, err = run_volcal(monkeypatch, capsys, "history", "show", rid, "--db", db,
                                "--units", "arcsec")
    line = next(x for x in out.splitlines() if x.startswith("C.A\t"))
    assert line.split("\t")[3] == "arcsec"
    assert float(line.split("\t")[1]) == pytest.approx(a / ARCSEC_URAD, abs=1e-4)
    code, out, err = run_volcal(monkeypatch, capsys, "history", "trend", "VMC-1",
                                "--parameter", "C.A", "--db", db, "--units", "arcsec",
                                "--json")
    rows = json.loads(out)
    assert rows[0]["unit"] == "arcsec"
    assert rows[0]["value"] == pytest.approx(a / ARCSEC_URAD, rel=1e-9)
    code, out, err = run_volcal(monkeypatch, capsys, "history", "trend", "VMC-1",
                                "--parameter", "C.A", "--db", db, "--units", "deg")
    assert code != 0 and "urad or arcsec" in err


def test_report_and_certificate_say_no_linear_model(rotary_only):
    from volcal.report.certificate import build_certificate
    from volcal.report.pipeline import collect_inputs
    from volcal.report.rotary import NO_LINEAR_MODEL
    from volcal.report.sections import build_report
    from volcal.session.format import read_session
    from volcal.standards.session import evaluate_session

    s = read_session(rotary_only)
    ev = evaluate_session(s)
    inp = collect_inputs(s, None, model_uncertainty=False, evaluation=ev)
    inp.angle_units = "arcsec"
    sec = next(x for x in build_report(inp).sections if x.id == "rotary")
    assert NO_LINEAR_MODEL in sec.paragraphs
    a = float(ev.rotary["rotary-c"].iso.A)
    assert sec.tables[0].rows[0][2] == f"{a / ARCSEC_URAD:.3f}"  # A in arcsec
    doc = build_certificate(s, None, evaluation=ev)
    assert any("no linear model was identified" in w for w in doc["warnings"])
    iso = next(m for m in doc["methods"] if m["id"] == "ISO 230-2")
    assert iso["measurements"] == ["rotary-c"] and iso["reference"] == "ISO 230-2:2014"
    assert doc["results"]["as_found"]["volumetric"] is None
    rot = doc["results"]["as_found"]["rotary"][0]
    assert rot["values"]["A"] == pytest.approx(a) and rot["closure"] is not None
    np.testing.assert_allclose(rot["closure"]["up"], ev.rotary["rotary-c"].closure_urad["up"])
    # printed in arcsec on request (certificate.json keeps urad)
    from volcal.report.certificate_layout import layout

    blocks = [b for sec in layout(doc, "arcsec") for b in sec.blocks
              if b.kind == "table" and "rotary axes" in (b.title or "")]
    assert "[arcsec]" in blocks[0].title
    assert blocks[0].rows[0][2] == f"{a / ARCSEC_URAD:.2f}"


def test_previous_calibration_section_compares_the_rotary_results(rotary_only, tmp_path):
    """The report's "Previous calibration" lists C.A ... (in the report's angle unit)."""
    pytest.importorskip("sqlalchemy")
    from volcal.history.api import History
    from volcal.history.previous import previous_section
    from volcal.report.pipeline import collect_inputs
    from volcal.session.format import read_session
    from volcal.steps.plan import plan
    from volcal.steps.simulate import save, simulate

    earlier = tmp_path / "earlier"
    plan([[0, 400], [0, 300], [0, 200]], tests="rotary:c", steps=6, runs=2, output=earlier)
    save(simulate(earlier, seed=11), earlier)
    toml = earlier / "session.toml"
    toml.write_text(toml.read_text() + "\n[calibration]\ndate = 2020-01-01\n")
    db = str(tmp_path / "h.sqlite")
    with History(db, create=True) as h:
        h.add(earlier)
    s = read_session(rotary_only)
    inp = collect_inputs(s, None, model_uncertainty=False)
    inp.angle_units = "arcsec"
    sec = previous_section(inp, db)
    table = next(t for t in sec.tables if t.title.startswith("Results"))
    row = next(r for r in table.rows if r[0] == "C.A")
    d = (_A(rotary_only) - _A(earlier)) / ARCSEC_URAD
    assert row[1] == f"{d:.2f}" and row[3] == "arcsec"


def test_evaluate_verdict_in_arcsec(rotary_only, monkeypatch, capsys):
    """``--units arcsec`` prints the verdict line in arcsec too (the tolerance is urad)."""
    a = _A(rotary_only)
    tol = a + 1.0
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2",
                                str(rotary_only / "rotary-c.csv"), "--tolerance-urad",
                                f"{tol}", "--units", "arcsec")
    assert code == 0, err
    assert (f"A: {a / ARCSEC_URAD:.3f} arcsec, tolerance {tol / ARCSEC_URAD:.4g} arcsec: "
            "pass") in out
