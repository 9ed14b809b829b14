"""`evaluate session` and the report's verdict with a named decision rule and X.E=.."""

import json
import sys
from types import SimpleNamespace

import pytest
from test_compensation_residual import A, _linear_session

from volcal.cli import main
from volcal.session.format import write_session

A_X = A * (795**2 - 5**2) + 2.0     # hand-worked ISO 230-2 A of the session (65.2 um)


@pytest.fixture
def _cli(monkeypatch, capsys):
    """Run the CLI in-process (a subprocess costs seconds on the shared box)."""
    def run(*args):
        monkeypatch.setattr(sys, "argv", ["volcal", *args])
        code = 0
        try:
            main()
        except SystemExit as exc:
            code = exc.code or 0
        out = capsys.readouterr()
        return SimpleNamespace(returncode=code, stdout=out.out, stderr=out.err)
    return run


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    p = tmp_path_factory.mktemp("s") / "s"
    s, _ = _linear_session(2.0)
    write_session(s, p)
    return p


def test_guarded_rule_and_other_parameters(session, tmp_path, _cli):
    r = _cli("evaluate", "session", str(session), "--json", "--tolerance-um",
             "X=70,X.B=2.5", "--decision-rule", "guarded", "--guard-band-um", "6")
    assert r.returncode == 0, r.stderr
    a, b = json.loads(r.stdout)["verdict"]
    assert a["quantity"].startswith("X: ISO 230-2 A") and a["before_um"] == pytest.approx(A_X)
    assert a["before"] == "conditional" and a["rule"] == "guarded" and a["after"] is None
    assert b["quantity"].startswith("X: ISO 230-2 B") and b["before_um"] == pytest.approx(2.0)
    assert b["before"] == "conditional"      # 2 > 2.5 - 6: no pass possible
    assert "no pass is possible" in b["notes"][0]
    r = _cli("evaluate", "session", str(session), "--tolerance-um", "X=70")
    assert r.returncode == 0 and "decision rule: simple" in r.stdout
    # guarded with a budget: U of A from it (noise-free readings: the systematic terms)
    budget = tmp_path / "b.toml"
    assert _cli("budget", "--template", "-o", str(budget)).returncode == 0
    r = _cli("evaluate", "session", str(session), "--json", "--tolerance-um", "X=70",
             "--decision-rule", "guarded", "--budget", str(budget))
    assert r.returncode == 0, r.stderr
    (v,) = json.loads(r.stdout)["verdict"]
    assert 0 < v["U_before_um"] < 5 and v["before"] == ("pass" if A_X <= 70 - v["U_before_um"]
                                                        else "conditional")
    r = _cli("evaluate", "session", str(session), "--tolerance-um", "X=70",
             "--decision-rule", "guarded")
    assert r.returncode == 2 and "--budget" in r.stderr and "Traceback" not in r.stderr


def test_guarded_rule_needs_a_tolerance(session, _cli):
    r = _cli("evaluate", "session", str(session), "--decision-rule", "guarded")
    assert r.returncode == 2 and "--tolerance-um" in r.stderr


def test_session_budget_gives_U_of_every_linear_test(session, tmp_path, _cli):
    budget = tmp_path / "b.toml"
    assert _cli("budget", "--template", "-o", str(budget)).returncode == 0
    r = _cli("evaluate", "session", str(session), "--json", "--budget", str(budget))
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    (m,) = d["measurements"].values()
    assert m["A"] == pytest.approx(A_X, abs=0.01)
    # noise-free readings: U of R is zero, U of A and E from the systematic terms only,
    # k = 2; the extremes are at most 790 mm apart and the template's systematic u is
    # 0.72 um per metre (docs/uncertainty.md), so U(E) < 2 x 0.79 x 0.8 um
    assert m["U_R"] < 1e-9 and m["k"] == pytest.approx(2.0)
    assert 0 < m["U_E"] < 2 * 0.79 * 0.8 and all(t["U_um"] >= 0 for t in m["targets"])
    assert "no correction by the budget" in d["corrections"]
    assert m["thermal"]["referred_by"] == "not stated"  # the session says nothing


def test_report_section_names_the_rule_and_the_guard_band(tmp_path):
    from dataclasses import replace

    from test_compensation_residual import TRAVEL, _exx_model, _summary

    from volcal.report.sections import ReportInputs, compensation_section
    from volcal.session.format import Session
    from volcal.standards.tolerance import parse_tolerance

    s, _ = _linear_session(2.0)
    tol = replace(parse_tolerance("X=70"), rule="guarded", guard_band_um=10.0)
    c = _summary(_exx_model(reversal_x=2.0), "csv", tmp_path, 25.0, tolerance=tol, session=s)
    sec = compensation_section(ReportInputs(Session("m", "XYFZ", TRAVEL, []), compensation=c))
    t = sec.tables[-1]
    assert t.title == "Tolerance verdict (decision rule: guarded)"
    assert t.columns[3] == "w before [µm]" and "guarded acceptance" in t.note
    # A = 65.2 um before: between T - w = 60 and T = 70 -> conditional; after the pitch
    # table A is a few um -> pass
    assert t.rows[0][4] == "conditional" and t.rows[0][7] == "pass"
    # a value that passes after compensation raises no warning (as for "out of tolerance")
    assert not any("conformity not proven" in w for w in sec.warnings)
