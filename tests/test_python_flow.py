"""The Python flow (volcal.Calibration): safe compensation defaults, parity with the CLI,
tables of the results, and every mistake a VolcalInputError naming the valid choices."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from typer.testing import CliRunner

from volcal import Calibration
from volcal.errors import VolcalInputError

TRAVEL = [[0, 600], [0, 400], [0, 300]]


@pytest.fixture(scope="module")
def cal(tmp_path_factory):
    """A simulated and identified virtual machine (about 1 s)."""
    c = Calibration.plan(TRAVEL, steps=4, runs=2, name="PY-600")
    c.simulate(seed=5, noise_um=0.2).save(tmp_path_factory.mktemp("s") / "session")
    c.identify()
    return c


def _exx(c: Calibration, q: np.ndarray) -> np.ndarray:
    return c.result.errors.function("EXX", q)


def test_fanuc_tables_from_python_carry_fanucs_own_sign(cal, tmp_path):
    from volcal.compensate.fanuc import read_fanuc

    files = cal.compensate(tmp_path / "f", format="fanuc")  # no sign given
    assert "FANUC_PITCH.TXT" in files
    man = tomllib.loads((tmp_path / "f" / "volcal-compensation.toml").read_text())
    assert man["sign"] == "correction"
    x = read_fanuc(tmp_path / "f", "correction")[0]
    assert np.allclose(np.diff(x.positions), 20.0)  # the CLI's 20 mm, not 50
    e = _exx(cal, x.positions)
    assert np.abs(e).max() > 3.0  # large enough for a wrong sign to show
    # value = -error, to the 1 um of the detection unit (cumulated increments)
    np.testing.assert_allclose(x.values, -e, atol=1.0)
    assert np.abs(x.values - e).max() > 5.0  # the doubling sign="error" would give


def test_linuxcnc_tables_from_python_carry_linuxcncs_own_sign(cal, tmp_path):
    from volcal.compensate.linuxcnc import read_linuxcnc

    cal.compensate(tmp_path / "l", format="linuxcnc")
    x = read_linuxcnc(tmp_path / "l")[0]
    assert np.allclose(np.diff(x.positions), 20.0)
    e = _exx(cal, x.positions)
    np.testing.assert_allclose(x.values, -e, atol=0.001)  # trims [um], 1 nm resolution


def test_a_sign_override_is_warned(cal, tmp_path):
    with pytest.warns(UserWarning, match="doubles the error"):
        cal.compensate(tmp_path / "w", format="fanuc", sign="error")


BAD_CALLS = [
    # (call, expected text): the two leaks of issue 20 first
    (lambda c: c.simulate(noise=1), "unknown option 'noise' (did you mean 'noise_um'?)"),
    (lambda c: Calibration.plan([[0, 800], [0, 600]]), "shape (2, 2)"),
    (lambda c: Calibration.plan([0, 800, 0, 600, 0, 500]), "shape (6,)"),
    (lambda c: Calibration.plan([[0, 8], [0, 6], [5, 5]]), "max > min"),
    (lambda c: Calibration.plan("0:800,0:600"), "shape (2, 2)"),
    (lambda c: Calibration.plan(TRAVEL, stepz=3), "did you mean 'steps'?"),
    (lambda c: Calibration.plan(TRAVEL, multilateration={"grids": [3, 3, 3]}),
     "did you mean 'grid'?"),
    (lambda c: c.compensate("x"), "missing a required argument: 'format'"),
    (lambda c: c.compensate("x", format="fanuk"), "expected one of fanuc, siemens"),
    (lambda c: c.compensate("x", format="fanuc", sign="minus"), "sign"),
    (lambda c: c.compensate("x", format="grid", tool_offset=(1, 2)), "three finite"),
    (lambda c: c.identify(nois_um=1), "did you mean 'noise_um'?"),
    (lambda c: c.identify(known_u=1.0),
     "Calibration.identify: known_u needs known (the error table it applies to)"),
    (lambda c: c.advise(rol="zero"), "did you mean 'roll'?"),
    (lambda c: c.evaluate(edition="2099"), "expected one of 1988, 1997, 2006, 2014"),
    (lambda c: c.evaluate("2014", "x"), "too many positional arguments"),
    (lambda c: c.simulate(noise_um=-1),
     "Calibration.simulate: noise_um=-1: must not be negative"),
    (lambda c: c.simulate(machine=3), "expected MachineErrors"),
    (lambda c: c.simulate(machine="machine.csv"), "machine.csv"),
    (lambda c: c.program("p", dialect="haas"), "expected one of"),
    (lambda c: c.program("p", "fanuc", feed=1e6),
     "Calibration.program: feed=1000000.0: expected 0 < feed <= 10000 mm/min"),
    (lambda c: c.report("r", tolerance_um="abc"), "not a positive number"),
    (lambda c: c.report("r", compensation="nowhere"), "not a folder written by compensate"),
    (lambda c: c.evaluation.to_rows("iso230-9") if c.evaluate() else None,
     "expected one of iso230-2, iso230-6"),
    (lambda c: Calibration.import_("x.csv", "target=T", "s", axis="X", id="a"),
     "exactly one of deviation"),
    (lambda c: Calibration.import_("x.csv", "target=T,deviation=E", "s"),
     "Calibration.import_: give axis and id (a new linear measurement) or "
     "measurement=ID (a planned one)"),
    (lambda c: Calibration.open("no-such-folder"), "session folder not found"),
    (lambda c: c.result.predict([1, 2]), "expected points x, y, z [mm]"),
    (lambda c: c.result.predict("a"), "expected points x, y, z [mm]"),
    (lambda c: Calibration.plan(TRAVEL, steps="4"), "steps='4': expected a whole number"),
    (lambda c: Calibration.plan(TRAVEL, runs=2.5), "runs=2.5: expected a whole number"),
    (lambda c: c.identify(known={"EXX": 3}), "known['EXX']"),
    (lambda c: c.identify(known={"EQX": ([0, 1], [0, 1])}), "known['EQX']"),
    (lambda c: c.save(_a_file()), "is a file; give a folder for the session"),
    (lambda c: c.identify(max_nodes="a"), "max_nodes='a': expected a whole number"),
    (lambda c: c.identify(max_nodes=2), "max_nodes=2: expected 3..2001"),
    (lambda c: c.identify(noise_um=-1),
     "Calibration.identify: noise_um=-1: expected a positive repeatability [um]"),
    (lambda c: c.identify(measurements="nope"),
     "Calibration.identify: measurements: no measurement nope in the session"),
    (lambda c: c.identify(measurements=[]),
     "Calibration.identify: measurements=[]: no measurement id given"),
    (lambda c: c.identify(monte_carlo=-1), "monte_carlo=-1: expected 0 (off) or more"),
    (lambda c: Calibration.import_("x.csv", "target=T,deviation=E"),
     "Calibration.import_: give session=FOLDER (the session to add the readings to)"),
    (lambda c: Calibration.import_("x.csv", "target=T,deviation=E", "s", measurement="m",
                                   sign="x"),
     "Calibration.import_: sign='x': expected + (the tool side"),
    (lambda c: c.identify(drift="yes"), "drift='yes': expected True or False"),
    (lambda c: c.program("p", "fanuc", feed="fast"), "feed='fast': expected a finite number"),
    (lambda c: c.compensate("x", format="fanuc", magnification=1.5),
     "magnification=1.5: expected a whole number"),
    (lambda c: c.compensate("x", format="grid", spacing="20"),
     "spacing='20': expected a finite number"),
    (lambda c: c.simulate(drift_um_per_h=float("inf")), "drift_um_per_h=inf"),
    (lambda c: Calibration.plan(TRAVEL, iso_spacing="no"), "expected True or False"),
    # decision rules, guard band, budget, certificate (the CLI's options, Python's names)
    (lambda c: c.verdict("X=10", decision_rule="guardd"),
     "decision_rule='guardd': expected one of simple, guarded"),
    (lambda c: c.verdict("X=10", guard_band_um=1),
     "guard_band_um applies to decision_rule='guarded' (valid rules: simple, guarded)"),
    (lambda c: c.verdict("X=10", decision_rule="guarded", guard_band_um=-1),
     "guard_band_um=-1: expected a finite number >= 0 [um]"),
    (lambda c: c.verdict("X=10", decision_rule="guarded"),
     "Calibration.verdict: decision_rule='guarded' needs the expanded uncertainty "
     "(budget=FILE) or a guard band (guard_band_um=W)"),
    (lambda c: c.report("r", decision_rule="guarded"),
     "decision_rule='guarded' judges a tolerance: give tolerance_um too"),
    (lambda c: c.evaluate(budget="no-budget.toml"), "no-budget.toml: no such budget file"),
    (lambda c: c.identify(budget=3), "budget=3: expected the path of a budget file"),
    (lambda c: c.identify(budgte="b.toml"), "did you mean 'budget'?"),
    (lambda c: c.simulate(budget="no-budget.toml"), "no such budget file"),
    (lambda c: c.report("r", tables="t"), "tables= names the compensation loaded between "
     "the as-found and the as-left measurement: give as_left= (the second session) too"),
    (lambda c: c.report("r", strict=True), "strict=True applies to the certificate"),
    (lambda c: c.report("r", as_left="no-such-folder"), "session folder not found"),
]


def _a_file():
    from pathlib import Path

    Path("model.json").write_text("{}")
    return "model.json"



@pytest.mark.parametrize("i", range(len(BAD_CALLS)))
def test_every_mistake_is_a_volcal_input_error(cal, i, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    call, text = BAD_CALLS[i]
    with pytest.raises(VolcalInputError) as e:
        call(cal)
    assert text in str(e.value)


def test_unknown_keyword_lists_every_valid_option(cal):
    with pytest.raises(VolcalInputError) as e:
        cal.simulate(noise=1)
    assert str(e.value) == (
        "Calibration.simulate: unknown option 'noise' (did you mean 'noise_um'?); valid "
        "options: machine, seed, noise_um, mirror_misalignment_urad, drift_um_per_h, "
        "reversal_um, budget, compensation, force")


def test_identified_functions_as_a_table(cal):
    rows = cal.result.to_rows()
    r = cal.result
    nodes = [r.layout.nodes[k].size for k in range(3)]
    assert len(rows) == 6 * sum(nodes) + 3
    exx = [row for row in rows if row["function"] == "EXX"]
    q = np.array([row["position_mm"] for row in exx])
    np.testing.assert_array_equal(q, r.layout.nodes[0])
    np.testing.assert_allclose([row["value"] for row in exx], r.errors.function("EXX", q),
                               atol=1e-12)
    np.testing.assert_allclose([row["u"] for row in exx], r.function_std("EXX", q),
                               rtol=1e-9, atol=1e-12)
    assert {row["unit"] for row in exx} == {"um"}
    eby = [row for row in rows if row["function"] == "EBY"]
    assert {row["unit"] for row in eby} == {"urad"} and eby[0]["axis"] == "Y"
    sq = rows[-3:]
    assert [s["function"] for s in sq] == ["EC0Y", "EB0Z", "EA0Z"]
    assert math.isnan(sq[0]["position_mm"])
    assert sq[0]["value"] == pytest.approx(float(r.errors.squareness[0]))
    df = r.to_dataframe()
    assert list(df.columns) == ["function", "axis", "position_mm", "value", "u", "unit"]
    assert len(df) == len(rows)
    assert df.loc[df.function == "EXX", "value"].to_numpy() == pytest.approx(
        [row["value"] for row in exx])


def test_iso230_2_and_diagonal_tables(cal):
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.positioning_data import from_measurement

    ev = cal.evaluate()
    rows = ev.to_rows("iso230-2")
    assert [r["id"] for r in rows] == list(ev.iso230_2)
    m = cal.session.get("linear-x1")
    d = from_measurement(m, cal.session.path)
    ref = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um)  # independent call
    row = rows[0]
    assert row["axis"] == "X"
    assert row["A_um"] == pytest.approx(ref.A) and row["R_um"] == pytest.approx(ref.R)
    per_target = ev.iso230_2["linear-x1"].to_rows()
    np.testing.assert_allclose([t["target_mm"] for t in per_target], ref.targets.target_mm)
    np.testing.assert_allclose([t["mean_um"] for t in per_target], ref.targets.mean)
    # mean bidirectional deviation = (mean up + mean down) / 2 at every target
    for t in per_target:
        assert t["mean_um"] == pytest.approx((t["mean_up_um"] + t["mean_down_um"]) / 2)
    df = ev.iso230_2["linear-x1"].to_dataframe()
    assert df["R_um"].max() == pytest.approx(ref.R)  # R = max R_i
    diag = ev.to_dataframe("iso230-6")
    assert list(diag["id"]) == list(ev.iso230_6)
    one = ev.iso230_6["diag-ppp"]
    assert diag.loc[0, "E_D_um"] == pytest.approx(one.E_D)
    assert diag.loc[0, "complete"] and diag.loc[0, "points_measured"] == one.points_planned
    assert per_target[0]["n_up"] == per_target[0]["n_down"] == 2  # runs=2, none missed
    assert one.to_rows()[0]["length_mm"] == pytest.approx(math.hypot(600 - 10, 400 - 10,
                                                                     300 - 10), rel=0.05)


EXPORT = "Target (mm);Run;Dir;Error (um)\n" + "".join(
    f"{t};1;{d};{v}\n" for t, d, v in [(0, "fwd", "0,0"), (100, "fwd", "1,2"),
                                      (200, "fwd", "2,5"), (200, "bwd", "3,1"),
                                      (100, "bwd", "1,9"), (0, "bwd", "0,4")])


def test_import_into_a_new_session(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text(EXPORT, encoding="utf-8")
    c = Calibration.import_(f, {"target": "Target", "run": "Run", "direction": "Dir",
                                "deviation": "Error"}, tmp_path / "s", axis="X", id="lx1",
                            line_mm=(100, 50, 20), travel="0:800,0:600,0:500")
    m = c.session.get("lx1")
    np.testing.assert_array_equal(m.positions[:, 0], [100, 200, 300, 300, 200, 100])
    np.testing.assert_allclose(m.deviation, [0.0, 1.2, 2.5, 3.1, 1.9, 0.4])
    assert c.imported is not None and c.imported.created
    assert any("mm (detected from the header)" in n for n in c.imported.notes)


def test_to_dataframe_without_pandas_names_to_rows(cal, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas -> ImportError
    with pytest.raises(VolcalInputError, match=r"needs pandas .* to_rows\(\)"):
        cal.result.to_dataframe()
    assert len(cal.result.to_rows()) > 0


def test_python_simulation_is_known_as_simulated_by_the_cli(tmp_path):
    """Calibration.simulate records its provenance as `volcal simulate` does, so the CLI
    may simulate the folder again without --overwrite (it refuses measured readings)."""
    from volcal.cli import app

    c = Calibration.plan(TRAVEL, tests=["diagonal"], steps=3)
    c.simulate(seed=2).save(tmp_path / "s")
    prov = tomllib.loads((tmp_path / "s" / "session.toml").read_text())["provenance"]
    assert prov["readings"] == "simulated" and prov["seed"] == 2
    r = CliRunner().invoke(app, ["simulate", str(tmp_path / "s"), "--seed", "3"])
    assert r.exit_code == 0, r.output


def test_save_never_overwrites_measured_readings(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text(EXPORT, encoding="utf-8")
    Calibration.import_(f, "target=Target,run=Run,direction=Dir,deviation=Error",
                        tmp_path / "m", axis="X", id="lx1", travel="0:800,0:600,0:500")
    before = (tmp_path / "m" / "lx1.csv").read_text()
    c = Calibration.plan("0:800,0:600,0:500", tests=["diagonal"], steps=3).simulate(seed=1)
    with pytest.raises(VolcalInputError, match=r"holds measured readings \(lx1\)"):
        c.save(tmp_path / "m")
    assert (tmp_path / "m" / "lx1.csv").read_text() == before
    # a planned or simulated folder is replaced, its other files kept
    c.save(tmp_path / "sim")
    (tmp_path / "sim" / "notes.txt").write_text("mine")
    c.simulate(seed=2).save(tmp_path / "sim")
    assert (tmp_path / "sim" / "notes.txt").read_text() == "mine"
    assert c.session.path == tmp_path / "sim" and c.session.provenance["seed"] == 2


def test_verdict_equals_the_cli(cal, tmp_path):
    import json

    from volcal.cli import app

    cal.compensate(tmp_path / "c", format="csv")
    py = cal.verdict({"X": 8, "Y": 8, "Z": 8, "V": 12}, compensation=tmp_path / "c")
    cal.result.to_json(tmp_path / "m.json")
    r = CliRunner().invoke(app, ["evaluate", "session", str(cal.session.path), "--json",
                                 "--tolerance-um", "X=8,Y=8,Z=8,V=12", "--model",
                                 str(tmp_path / "m.json"), "--compensation",
                                 str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    cli = json.loads(r.stdout)["verdict"]
    assert len(py) == len(cli)
    for a, b in zip([v.to_dict() for v in py], cli, strict=True):  # the same verdicts
        assert {k: v for k, v in a.items() if isinstance(v, str)} == {
            k: v for k, v in b.items() if isinstance(v, str)}
        for k in ("tolerance_um", "before_um", "after_um"):  # model.json holds 9 digits
            assert a[k] == pytest.approx(b[k], rel=1e-6)
    assert len(py) == 4 and py[-1].quantity.startswith("Z: ISO 230-2 A")
    assert all(v.after_um is not None for v in py)  # every verdict has its "after"
