"""Issue 25, findings 1, 2 and 7: the referral to 20 C is a property of the readings.

A session's measurement records whether its readings are referred to 20 C
(``referred_to_20c``); volcal refers them once, where the session is read, from the
measurement's own environment. The budget gives uncertainties only: every ISO 230-2
parameter has the same value with and without ``--budget``; the as-left session is
referred with its own material temperature; bad environment values and an unknown
``readings`` value are refused naming the file and the key.
"""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from volcal.session.format import read_session
from volcal.uncertainty.budget import TEMPLATE, parse_budget
from volcal_cli_helpers import run_volcal

X = [0.0, 297.5, 595.0, 892.5, 1190.0]  # a 1.19 m line on X (the issue's gantry)
ALPHA_STEEL = 11.5                       # ppm/K (volcal.environment.materials)
ISO_KEYS = ("A", "A_up", "A_down", "E", "E_up", "E_down", "M", "R", "R_up", "R_down", "B",
            "B_mean")


def rows():
    """Three bidirectional runs: x [mm], run, direction, deviation [um] (first row 0)."""
    out = []
    for run in (1, 2, 3):
        for d, xs in (("+", X), ("-", X[::-1])):
            for x in xs:
                out.append((x, run, d, 0.018 * x + (0.8 if d == "-" else 0.0)
                            + 0.3 * (run - 1)))
    return out


def write_session(folder, keys="", env="", csv_extra=None):
    """A one-line session; ``keys`` and ``env`` are TOML lines of the measurement."""
    folder.mkdir(parents=True, exist_ok=True)
    head = "x_mm,y_mm,z_mm,deviation_um,run,direction"
    lines = []
    for i, (x, run, d, v) in enumerate(rows()):
        extra = "" if csv_extra is None else f",{csv_extra(i)}"
        lines.append(f"{x:g},400,300,{v:.6f},{run},{d}{extra}")
    if csv_extra is not None:
        head += ",material_temperature_c"
    (folder / "lin-x.csv").write_text(head + "\n" + "\n".join(lines) + "\n", encoding="utf-8")
    (folder / "session.toml").write_text(f"""format = "volcal-session/1"

[machine]
name = "gantry"
chain = "FXYZ"

[machine.travel_mm]
x = [0, 1200]
y = [0, 800]
z = [0, 600]

[[measurements]]
id = "lin-x"
kind = "linear"
target = "retroreflector"
file = "lin-x.csv"
axis = "X"
{keys}
{"[measurements.environment]" if env else ""}
{env}
""", encoding="utf-8")
    return folder


def write_budget(path, material_c=21.4, referred=None):
    """The template with the material at ``material_c`` (and the retired key if given)."""
    text = TEMPLATE.replace("[material]\n", "[material]\n" + (
        "" if referred is None else f"referred_to_20c = {str(referred).lower()}\n"))
    doc = tomllib.loads(text)
    doc["material"]["temperature_c"] = material_c
    text = text.replace("temperature_c = 20.0\n# Typical material",
                        f"temperature_c = {material_c}\n# Typical material")
    assert tomllib.loads(text)["material"] == doc["material"]
    path.write_text(text, encoding="utf-8")
    return path


def referred_by_hand(t_m, alpha_ppm=ALPHA_STEEL):
    """ISO 1 by hand: L = C + d from the first row, L20 = L / (1 + alpha (t - 20))."""
    out = []
    for x, _run, _d, v in rows():
        c = x - X[0]
        out.append(((c + v * 1e-3) / (1.0 + alpha_ppm * 1e-6 * (t_m - 20.0)) - c) * 1e3)
    return np.array(out)


def evaluate_json(monkeypatch, capsys, folder, *args):
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(folder),
                                "--json", *args)
    assert code == 0, err
    return json.loads(out)["measurements"]["lin-x"], err


# ------------------------------------------------------------------ finding 1


def test_issue_scenario_same_A_with_and_without_a_budget(tmp_path, monkeypatch, capsys):
    """The template's budget with the material at 21.4 C and referred_to_20c = false."""
    s = write_session(tmp_path / "S", env="material_temperature_c = 21.4\nmaterial = "
                      '"steel"')
    b = write_budget(tmp_path / "budget.toml", 21.4, referred=False)
    plain, _ = evaluate_json(monkeypatch, capsys, s)
    with_b, err = evaluate_json(monkeypatch, capsys, s, "--budget", str(b))
    for k in ISO_KEYS:
        assert with_b[k] == plain[k], k          # exactly: the budget changes no value
    assert with_b["U_A"] > 0 and plain["thermal"]["referred_by"] == "not stated"
    # the retired key, cross-checked against the session: a warning on standard error
    assert "warning:" in err and "referred_to_20c = false is retired" in err
    assert err.count("is retired") == 1 and "Traceback" not in err
    assert "not recorded (no referred_to_20c in session.toml" in err
    # evaluate iso230-2 of the same CSV: the same A with and without the budget
    code, o1, _ = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(s / "lin-x.csv"),
                             "--json")
    code2, o2, e2 = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2",
                               str(s / "lin-x.csv"), "--json", "--budget", str(b))
    assert code == code2 == 0
    assert json.loads(o1)["A"] == json.loads(o2)["A"] == plain["A"]


def test_the_value_of_A_is_the_readings_A(tmp_path, monkeypatch, capsys):
    """A by hand for the session without the key (ISO 230-2: 2 s over three runs)."""
    s = write_session(tmp_path / "S")
    plain, _ = evaluate_json(monkeypatch, capsys, s)
    dev = {}
    for x, _run, d, v in rows():
        dev.setdefault((x, d), []).append(v)
    hi = max(np.mean(v) + 2 * np.std(v, ddof=1) for v in dev.values())
    lo = min(np.mean(v) - 2 * np.std(v, ddof=1) for v in dev.values())
    assert plain["A"] == pytest.approx(hi - lo, abs=1e-9)


def test_referred_to_20c_false_at_21_4_c_gives_the_hand_computed_values(tmp_path, monkeypatch,
                                                                        capsys):
    s = write_session(tmp_path / "S", keys="referred_to_20c = false",
                      env='material_temperature_c = 21.4\nmaterial = "steel"')
    m = read_session(s).get("lin-x")
    assert m.deviation == pytest.approx(referred_by_hand(21.4), abs=1e-9)
    # at 1190 mm: 1190 mm * 11.5e-6 * 1.4 / (1 + ...) = 19.16 um shorter (the issue's 19 um)
    far = int(np.argmax([r[0] for r in rows()]))
    assert rows()[far][3] - m.deviation[far] == pytest.approx(
        (1190.0 + rows()[far][3] * 1e-3) * 16.1e-6 / (1 + 16.1e-6) * 1e3, abs=1e-9)
    assert 19.1 < rows()[far][3] - m.deviation[far] < 19.2
    # the same values with and without a budget (whatever its material temperature)
    b = write_budget(tmp_path / "b.toml", 23.0)
    plain, _ = evaluate_json(monkeypatch, capsys, s)
    with_b, err = evaluate_json(monkeypatch, capsys, s, "--budget", str(b))
    assert all(with_b[k] == plain[k] for k in ISO_KEYS)
    assert "warning" not in err  # the fresh template states no referred_to_20c
    # the retired key agreeing with the session (not referred by the software): no warning
    _, err = evaluate_json(monkeypatch, capsys, s, "--budget",
                           str(write_budget(tmp_path / "b2.toml", 21.4, referred=False)))
    assert "warning" not in err
    _, err = evaluate_json(monkeypatch, capsys, s, "--budget",
                           str(write_budget(tmp_path / "b3.toml", 21.4, referred=True)))
    assert "referred_to_20c = true is retired" in err and "by volcal from the session" in err
    th = plain["thermal"]
    assert th["referred_by"] == "volcal" and th["material_temperature_c"] == 21.4
    assert th["compensated_by"] == "laser software" and th["expansion_ppm_per_k"] == 11.5
    # the budget's sensitivities at the session's 21.4 C, not the budget's 23 C:
    # U of the expansion-coefficient term of the far target's mean = k L |t - 20| u(alpha)
    comp = {c["label"]: c for c in with_b["uncertainty"]["budget"]["components"]}
    u_alpha = parse_budget(tomllib.loads(TEMPLATE)).inputs["material.u_expansion_ppm_per_k"].u
    assert comp["expansion coefficient"]["u"] == pytest.approx(
        1190.0e3 * 1.4 * u_alpha * 1e-6, rel=1e-9)
    # the text says how the readings were referred
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s))
    assert code == 0
    assert ("readings lin-x: compensated by the laser software; referred to 20 °C by volcal at "
            "t = 21.4 °C (alpha = 11.5 ppm/K)") in out


def test_referred_by_the_laser_software_is_taken_as_it_is(tmp_path, monkeypatch, capsys):
    s = write_session(tmp_path / "S", keys="referred_to_20c = true",
                      env="material_temperature_c = 21.4\nexpansion_ppm_per_k = 11.5")
    m = read_session(s).get("lin-x")
    assert m.deviation == pytest.approx([r[3] for r in rows()], abs=1e-6)
    b = write_budget(tmp_path / "b.toml", 21.4, referred=False)
    d, err = evaluate_json(monkeypatch, capsys, s, "--budget", str(b))
    assert d["thermal"]["referred_by"] == "laser software"
    assert "referred_to_20c = false is retired" in err
    assert "were referred to 20 °C by the laser software" in err


def test_a_written_back_session_is_not_referred_twice(tmp_path):
    from volcal.session.format import write_session as write

    s = write_session(tmp_path / "S", keys="referred_to_20c = false",
                      env='material_temperature_c = 21.4\nmaterial = "steel"')
    first = read_session(s)
    write(first, tmp_path / "T")
    again = read_session(tmp_path / "T").get("lin-x")
    assert again.deviation == pytest.approx(referred_by_hand(21.4), abs=1e-5)
    assert again.meta["referral"]["material_temperature_c"] == 21.4


def test_the_per_row_material_temperature_refers_each_reading(tmp_path):
    temps = [21.0 + 0.01 * i for i in range(len(rows()))]
    s = write_session(tmp_path / "S", keys="referred_to_20c = false",
                      env="expansion_ppm_per_k = 11.5", csv_extra=lambda i: f"{temps[i]:g}")
    m = read_session(s).get("lin-x")
    for i, (x, _r, _d, v) in enumerate(rows()):
        want = ((x + v * 1e-3) / (1 + 11.5e-6 * (temps[i] - 20.0)) - x) * 1e3
        assert m.deviation[i] == pytest.approx(want, abs=1e-9)


def test_referred_false_without_a_material_temperature_is_refused(tmp_path, monkeypatch,
                                                                  capsys):
    s = write_session(tmp_path / "S", keys="referred_to_20c = false",
                      env='material = "steel"')
    code, _, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s))
    assert code == 2 and "Traceback" not in err
    assert "session.toml" in err and "measurements[0].environment.material_temperature_c" in err
    assert "referred_to_20c = false" in err
    s2 = write_session(tmp_path / "S2", keys="referred_to_20c = false",
                       env="material_temperature_c = 21.4")
    code, _, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s2))
    assert code == 2 and "measurements[0].environment.expansion_ppm_per_k" in err


# ------------------------------------------------------------------ finding 2


def test_as_left_is_referred_with_its_own_material_temperature(tmp_path):
    from volcal.report.certificate import build_certificate
    from volcal.report.certificate_inputs import session_uncertainties
    from volcal.report.certificate_layout import layout

    keys = "referred_to_20c = false"
    found = read_session(write_session(tmp_path / "found", keys=keys, env=(
        'material_temperature_c = 21.4\nmaterial = "steel"')))
    left = read_session(write_session(tmp_path / "left", keys=keys, env=(
        'material_temperature_c = 21.0\nmaterial = "steel"')))
    b = parse_budget(tomllib.loads(TEMPLATE.replace("temperature_c = 20.0\n# Typical material",
                                                    "temperature_c = 21.4\n# Typical material")))
    assert b.values["material.temperature_c"] == 21.4
    uf = session_uncertainties(found, b, "2014")
    ul = session_uncertainties(left, b, "2014")
    doc = build_certificate(found, as_left=left, uncertainties=uf, as_left_uncertainties=ul,
                            issued="2026-11-26")
    a_left = doc["results"]["as_left"]["positioning"][0]
    a_found = doc["results"]["as_found"]["positioning"][0]
    # the as-left readings referred at 21.0 C by hand; ISO 230-2 A of them (2 s, 3 runs)
    def iso_a(dev):
        g = {}
        for (x, _r, d, _v), v in zip(rows(), dev, strict=True):
            g.setdefault((x, d), []).append(v)
        return (max(np.mean(v) + 2 * np.std(v, ddof=1) for v in g.values())
                - min(np.mean(v) - 2 * np.std(v, ddof=1) for v in g.values()))

    assert a_left["values_um"]["A"] == pytest.approx(iso_a(referred_by_hand(21.0)), abs=1e-9)
    assert a_found["values_um"]["A"] == pytest.approx(iso_a(referred_by_hand(21.4)), abs=1e-9)
    assert a_left["values_um"]["A"] != pytest.approx(iso_a(referred_by_hand(21.4)), abs=1e-3)
    # and its U from the as-left's own 21.0 C: the expansion-coefficient term at 1 K
    comp = {c.label: c for c in ul["lin-x"].unc.reading.components}
    assert comp["expansion coefficient"].u == pytest.approx(
        1190.0e3 * 1.0 * b.inputs["material.u_expansion_ppm_per_k"].u * 1e-6, rel=1e-9)
    # the certificate says per state how the readings were referred
    env = doc["environment"]
    assert env["as_left"]["measurements"][0]["readings"]["material_temperature_c"] == 21.0
    assert env["as_found"]["measurements"][0]["readings"]["material_temperature_c"] == 21.4
    text = [b for s in layout(doc) for b in s.blocks]
    how = next(b for b in text if b.kind == "table" and "referred to 20 °C by" in b.columns)
    assert [r[-1].split(" (")[0] for r in how.rows] == ["volcal at t = 21.4 °C",
                                                        "volcal at t = 21 °C"]
    assert any(b.kind == "p" and "Deviations are referred to 20 °C (ISO 1)." in b.text
               for b in text)


def test_as_left_through_the_command_line(tmp_path, monkeypatch, capsys, stub_pdfs):
    """``volcal report FOUND --as-left LEFT --budget B --certificate``: as-left at 21.0 C
    (certificate.json; the PDFs stubbed, tests/report_stubs.py)."""
    import volcal.report.sections as sections
    from volcal.plot._figure import new_figure

    for name in ("linear_deviation_plot", "error_functions_plot", "diagonal_fit_plot",
                 "identifiability_plot", "volumetric_map_plot"):
        monkeypatch.setattr(sections, name, lambda *a, **k: new_figure(1.0, 1.0))
    keys = "referred_to_20c = false"
    f = write_session(tmp_path / "found", keys=keys,
                      env='material_temperature_c = 21.4\nmaterial = "steel"')
    left = write_session(tmp_path / "left", keys=keys,
                         env='material_temperature_c = 21.0\nmaterial = "steel"')
    b = write_budget(tmp_path / "b.toml", 21.4)
    code, _, err = run_volcal(monkeypatch, capsys, "report", str(f), "--as-left", str(left),
                              "--budget", str(b), "--certificate", "-o", str(tmp_path / "out"))
    assert code == 0, err
    cert = json.loads((tmp_path / "out" / "certificate.json").read_text("utf-8"))
    g = {}
    for (x, _r, d, _v), v in zip(rows(), referred_by_hand(21.0), strict=True):
        g.setdefault((x, d), []).append(v)
    a_left = (max(np.mean(v) + 2 * np.std(v, ddof=1) for v in g.values())
              - min(np.mean(v) - 2 * np.std(v, ddof=1) for v in g.values()))
    assert cert["results"]["as_left"]["positioning"][0]["values_um"]["A"] == pytest.approx(
        a_left, abs=1e-9)
    assert a_left == pytest.approx(9.7349, abs=1e-4)  # 4.2609 at the as-found's 21.4 C
    assert cert["results"]["as_found"]["positioning"][0]["values_um"]["A"] == pytest.approx(
        4.2609, abs=1e-4)
    left_env = cert["environment"]["as_left"]["measurements"][0]["readings"]
    assert left_env == {"compensated_by": "laser software", "referred_by": "volcal",
                        "material_temperature_c": 21.0, "expansion_ppm_per_k": 11.5}


def test_the_certificate_does_not_claim_a_referral_nobody_stated(tmp_path):
    from volcal.report.certificate import build_certificate
    from volcal.report.certificate_layout import layout

    doc = build_certificate(read_session(write_session(tmp_path / "S")), issued="2026-11-26")
    ps = [b.text for s in layout(doc) for b in s.blocks if b.kind == "p"]
    assert not any(t.startswith("Deviations are referred to 20 °C (ISO 1). ") for t in ps)
    assert any("for lin-x the referral to 20 °C is not stated" in t for t in ps)


# ------------------------------------------------------------------ finding 7


@pytest.mark.parametrize("env,key,words", [
    ("air_temperature_c = 2000.0", "air_temperature_c", "kelvin?"),
    ("material_temperature_c = 2000.0", "material_temperature_c", "kelvin?"),
    ("air_temperature_c = nan", "air_temperature_c", "finite"),
    ("air_pressure_pa = -5.0", "air_pressure_pa", "outside [10000, 140000] Pa"),
    ("air_pressure_pa = 1013.25", "air_pressure_pa", "hPa or kPa?"),
    ("humidity_pct = 150.0", "humidity_pct", "outside [0, 100] %"),
    ("expansion_ppm_per_k = 115.0", "expansion_ppm_per_k", "11.5 for steel"),
    ("air_temp = 20.0", "air_temp", "unknown key (units?)"),
    ('material = "unobtainium"', "material", "steel"),
    ('formula = "magic"', "formula", "ciddor"),
])
def test_a_bad_environment_value_is_refused_naming_the_key(tmp_path, monkeypatch, capsys, env,
                                                           key, words):
    s = write_session(tmp_path / "S", env=env)
    code, _, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s))
    assert code == 2, err
    assert "Traceback" not in err and "session.toml" in err
    assert f"measurements[0].environment.{key}" in err
    if words:
        assert words in err
    if key == "material":  # the valid materials listed
        assert "cast_iron" in err and "granite" in err


def test_a_bad_per_row_environment_value_names_row_and_column(tmp_path, monkeypatch, capsys):
    s = write_session(tmp_path / "S", csv_extra=lambda i: "2000" if i == 4 else "21")
    code, _, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s))
    assert code == 2 and "Traceback" not in err
    assert "lin-x.csv" in err and "row 6" in err and "material_temperature_c" in err
    assert "kelvin?" in err


@pytest.mark.parametrize("keys,key,words", [
    ('readings = "Raw"', "readings", "expected one of deviation, compensated, raw"),
    ('readings = 1', "readings", "expected one of"),
    ('referred_to_20c = "no"', "referred_to_20c", "true or false"),
])
def test_an_unknown_readings_value_is_refused(tmp_path, monkeypatch, capsys, keys, key, words):
    s = write_session(tmp_path / "S", keys=keys, env="air_temperature_c = 20.0\n"
                      "air_pressure_pa = 101325.0\nhumidity_pct = 50.0")
    code, _, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s))
    assert code == 2 and "Traceback" not in err
    assert "session.toml" in err and f"measurements[0].{key}" in err and words in err


def test_raw_readings_still_compensated_and_recorded(tmp_path):
    s = write_session(tmp_path / "S", keys='readings = "raw"', env=(
        "air_temperature_c = 20.0\nair_pressure_pa = 101325.0\nhumidity_pct = 50.0\n"
        'material_temperature_c = 21.0\nmaterial = "steel"'))
    m = read_session(s).get("lin-x")
    from volcal.environment.apply import thermal_record

    r = thermal_record(m)
    assert r["compensated_by"] == "volcal (raw readings)" and r["referred_by"] == "volcal"
    assert r["material_temperature_c"] == 21.0


@pytest.mark.parametrize("keys,key,words", [
    ('axis_order = "xyq"', "axis_order", "each once"),
    ('plane = "xw"', "plane", "expected one of xy, yz, xz"),
])
def test_other_enumerated_keys_are_refused(tmp_path, monkeypatch, capsys, keys, key, words):
    s = write_session(tmp_path / "S", keys=keys)
    code, _, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s))
    assert code == 2 and "Traceback" not in err
    assert f"measurements[0].{key}" in err and words in err


def test_a_measurement_built_in_python_says_it_is_not_referred():
    from volcal.environment.apply import refer_measurement, thermal_record
    from volcal.session.format import Measurement

    pos = np.array([[0.0, 0, 0], [500.0, 0, 0], [1000.0, 0, 0]])
    m = Measurement("m", "linear", "retroreflector", pos, np.array([0.0, 2.0, 4.0]),
                    np.array([1.0, 0, 0]), meta={"referred_to_20c": False, "environment": {
                        "material_temperature_c": 22.0, "expansion_ppm_per_k": 10.0}})
    r = thermal_record(m)
    assert r["referred_by"] == "not referred" and r["referred_to_20c"] is False
    done = refer_measurement(m)
    # by hand: 1000.004 / 1.00002 = 1000.004 - 0.02000008 + 0.0000004 = 999.98400032 mm
    assert done.deviation[2] == pytest.approx((1000.004 / 1.00002 - 1000.0) * 1e3, abs=1e-9)
    assert done.deviation[2] == pytest.approx(-15.99968, abs=1e-5)
    assert thermal_record(done)["referred_by"] == "volcal"


def test_raw_readings_of_a_direct_optic_are_refused():
    from volcal.environment.apply import prepare_readings
    from volcal.errors import VolcalInputError
    from volcal.session.format import Measurement
    from volcal.session.kinds import kinds

    pos = np.array([[0.0, 0, 0], [500.0, 0, 0], [1000.0, 0, 0]])
    m = Measurement("ang", "angular", "angular_optics", pos, np.zeros(3),
                    np.array([1.0, 0, 0]), meta={"readings": "raw"})
    with pytest.raises(VolcalInputError, match="kind 'angular' has none") as e:
        prepare_readings(m, "S/session.toml [ang]", "measurements[3]", kinds())
    assert e.value.column == "measurements[3].readings"


def test_the_identification_systematic_part_uses_the_recorded_material_temperature():
    """identify --budget: the material sensitivity at the session's 22 C, not the budget's."""
    from types import SimpleNamespace

    from volcal.identify.systematic import systematic_inputs
    from volcal.session.format import Measurement

    pos = np.array([[0.0, 0, 0], [500.0, 0, 0], [1000.0, 0, 0]])
    doc = tomllib.loads(TEMPLATE)
    doc["material"].update(temperature_c=20.0, u_temperature_k=0.0,
                           u_expansion_ppm_per_k=1.0)
    b = parse_budget(doc)

    def material_column(meta):
        m = Measurement("m", "linear", "retroreflector", pos, np.zeros(3),
                        np.array([1.0, 0, 0]), meta=meta)
        d = SimpleNamespace(A=np.zeros((3, 1)), measurements=[m], rows={"m": np.arange(3)})
        return dict(systematic_inputs(d, b)).get("material, X")

    assert material_column({}) is None  # at the budget's 20 C: no sensitivity to alpha
    # u_mat = |t - 20| u(alpha) at 22 C (u(t) = 0): 2 K x 1 ppm/K x L
    col = material_column({"environment": {"material_temperature_c": 22.0}})
    assert col == pytest.approx([0.0, 500e3 * 2e-6, 1000e3 * 2e-6], abs=1e-12)


def test_simulated_readings_are_recorded_as_referred(tmp_path, monkeypatch, capsys):
    """The virtual machine is at 20 C: simulate records its laser readings as referred,
    replacing a planned ``referred_to_20c = false`` (which would refer them twice)."""
    s = tmp_path / "S"
    assert run_volcal(monkeypatch, capsys, "plan", "-o", str(s), "--steps", "4")[0] == 0
    toml = (s / "session.toml").read_text(encoding="utf-8")
    first = toml.index("[[measurements]]")
    toml = (toml[:first] + toml[first:].replace(
        "[[measurements]]", "[[measurements]]\nreferred_to_20c = false\n"
        "environment = { material_temperature_c = 21.4, material = \"steel\" }", 1))
    (s / "session.toml").write_text(toml, encoding="utf-8")
    assert run_volcal(monkeypatch, capsys, "simulate", str(s), "--seed", "3",
                      "--noise-um", "0")[0] == 0
    doc = tomllib.loads((s / "session.toml").read_text(encoding="utf-8"))
    laser = [e for e in doc["measurements"]
             if e["kind"] in ("linear", "diagonal", "step_diagonal")]
    assert laser and all(e["referred_to_20c"] is True for e in laser)
    sess = read_session(s)
    from volcal.environment.apply import thermal_record

    m = sess.measurements[0]
    assert thermal_record(m)["referred_by"] == "laser software"
    assert "referral" not in m.meta  # not referred a second time at 21.4 C
