"""``volcal budget`` and ``volcal evaluate iso230-2 --budget/--tolerance-um/--decision-rule``
end to end, with the exact option and key names of the issue."""

import json

import pytest
from test_cli_evaluate import write_cycle
from test_iso230_2 import EXPECTED

from volcal.standards.iso230_2 import AXIS_KEYS
from volcal.uncertainty.budget import TEMPLATE
from volcal_cli_helpers import run_volcal


@pytest.fixture
def files(tmp_path, monkeypatch, capsys):
    code, out, _ = run_volcal(monkeypatch, capsys, "budget", "--template")
    assert code == 0 and out == TEMPLATE
    b = tmp_path / "budget.toml"
    b.write_text(out, encoding="utf-8")
    return write_cycle(tmp_path / "x.csv"), b


def test_template_to_file_never_overwrites(tmp_path, monkeypatch, capsys):
    f = tmp_path / "b.toml"
    assert run_volcal(monkeypatch, capsys, "budget", "--template", "-o", str(f))[0] == 0
    assert f.read_text(encoding="utf-8") == TEMPLATE
    code, _, err = run_volcal(monkeypatch, capsys, "budget", "--template", "-o", str(f))
    assert code == 2 and "overwrite" in err
    g = tmp_path / "c.toml"                     # `budget --template FILE` writes FILE too
    assert run_volcal(monkeypatch, capsys, "budget", "--template", str(g))[0] == 0
    assert g.read_text(encoding="utf-8") == TEMPLATE
    code, out, _ = run_volcal(monkeypatch, capsys, "budget", str(f), "--length-mm", "500")
    assert code == 0 and "U = 2.00 u" in out


def test_json_has_U_of_every_key_targets_and_k(files, monkeypatch, capsys):
    f, b = files
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f), "--budget",
                                str(b), "--json")
    assert code == 0, err
    d = json.loads(out)
    for k in AXIS_KEYS:
        assert d[f"U_{k}"] > 0, k
        assert d[k] == pytest.approx(EXPECTED[k], abs=0.01), k   # template: t_m = 20 C
    assert all(t["U_um"] > 0 for t in d["targets"])
    assert d["k"] == d["uncertainty"]["parameters"]["A"]["k"] and d["k"] >= 2.0
    assert "no correction by the budget" in d["corrections"]["text"]
    assert d["corrections"]["largest_correction_um"] == 0.0
    assert "verdict" not in d


@pytest.mark.parametrize("args,verdict", [
    (["--tolerance-um", "14"], "pass"),                                   # A = 14 = T
    (["--tolerance-um", "14", "--decision-rule", "simple"], "pass"),
    (["--tolerance-um", "13.9"], "fail"),
    (["--tolerance-um", "14", "--decision-rule", "guarded"], "conditional"),
    (["--tolerance-um", "40", "--decision-rule", "guarded"], "pass"),
    (["--tolerance-um", "15", "--decision-rule", "guarded", "--guard-band-um", "1"], "pass"),
    (["--tolerance-um", "A=20,E=10,R=8"], "fail"),                        # R = 9
    (["--tolerance-um", "A=20,E=10,R=10"], "pass"),
    (["--tolerance-um", "A=14.5", "--decision-rule", "guarded", "--guard-band-um", "20"],
     "conditional"),                                                      # w > T
])
def test_verdict(files, monkeypatch, capsys, args, verdict):
    f, b = files
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f), "--budget",
                                str(b), "--json", *args)
    assert code == 0, err
    d = json.loads(out)
    assert d["verdict"] == verdict
    rule = "guarded" if "guarded" in args else "simple"
    assert d["decision_rule"]["name"] == rule
    assert all(v["rule"] == rule for v in d["verdicts"])
    if "20" in args:
        assert "no pass is possible" in d["verdicts"][0]["note"]


def test_text_output_names_the_rule(files, monkeypatch, capsys):
    f, b = files
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f), "--budget",
                              str(b), "--tolerance-um", "14", "--decision-rule", "guarded")
    assert code == 0 and "decision rule: guarded" in out and "conditional" in out
    assert "uncertainty budget" in out and "no correction by the budget" in out
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f),
                              "--tolerance-um", "14")
    assert code == 0 and "decision rule: simple" in out and "pass" in out


@pytest.mark.parametrize("args,words", [
    (["--tolerance-um", "14", "--decision-rule", "guarded"], "--budget"),
    (["--tolerance-um", "14", "--decision-rule", "maybe"], "simple, guarded"),
    (["--tolerance-um", "14", "--guard-band-um", "1"], "guarded"),
    (["--tolerance-um", "Q=3"], "unknown ISO 230-2 parameter"),
])
def test_bad_options(files, monkeypatch, capsys, args, words):
    f, _ = files
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f), *args)
    assert code == 2 and words in err and "Traceback" not in err and out == ""


@pytest.mark.parametrize("old,new,key", [
    ("pressure_pa = 101325.0", "pressure_pa = 1013.25", "air.pressure_pa"),
    ("u_pressure_pa = 58.0", "u_pressure_pa = -58.0", "air.u_pressure_pa"),
    ("u_wavelength_ppm = 0.029", "u_wavelength_ppm = nan", "laser.u_wavelength_ppm"),
    ("humidity_pct = 50.0", "humidity_percent = 50.0", "air.humidity_percent"),
    ("temperature_c = 20.0\npressure_pa", "pressure_pa", "air.temperature_c"),
])
def test_bad_budget_file(files, monkeypatch, capsys, old, new, key):
    f, b = files
    text = b.read_text(encoding="utf-8")
    assert old in text
    b.write_text(text.replace(old, new, 1), encoding="utf-8")
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f), "--budget",
                                str(b), "--json")
    assert code == 2 and out == "" and "Traceback" not in err
    assert str(b) in err and f"'{key}'" in err
