"""Missed captures and incomplete runs, and the plausibility of readings (issue 20, items 2-3).

A missed capture never stops a command: the other tests are evaluated, an incomplete linear
test is evaluated target by target over the runs that reached it (hand-computed below), an
incomplete diagonal is marked and left out of the largest E_D, and the report lists what
was not measured. Readings 1000x too small, and readings below the absolute floors, are
warned about naming the measurement, in every command that reads them.
"""

from __future__ import annotations

import csv
import json
import re
import shutil
import sys
from html import unescape
from pathlib import Path

import numpy as np
import pytest
from test_iso230_2 import EXPECTED, cycle

from volcal.cli import main
from volcal.errors import VolcalInputError
from volcal.standards.iso230_2 import evaluate

TRAVEL = np.array([[0.0, 1200.0], [0.0, 800.0], [0.0, 600.0]])


def run_cli(monkeypatch, capsys, *args):
    monkeypatch.setattr(sys, "argv", ["volcal", *map(str, args)])
    monkeypatch.setenv("COLUMNS", "250")
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return code, out.out, " ".join(out.err.split())


def _rows(p: Path) -> list[list[str]]:
    return list(csv.reader(p.open()))


def _write(p: Path, rows: list[list[str]]) -> None:
    with p.open("w") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)


def set_cell(p: Path, row: int, col: str, value: str) -> list[str]:
    """Set one cell (row 1 = header); return the row as it was."""
    r = _rows(p)
    old = list(r[row - 1])
    r[row - 1][r[0].index(col)] = value
    _write(p, r)
    return old


def scale(p: Path, factor: float) -> None:
    r = _rows(p)
    j = r[0].index("deviation_um")
    for x in r[1:]:
        x[j] = f"{float(x[j]) * factor:.7f}"
    _write(p, r)


# ------------------------------------------------------------------ ISO 230-2, by hand

def _drop(index_run: int, target: float, sign: str):
    t, r, d, v = cycle()
    keep = ~((r == index_run) & (t == target) & (d == sign))
    assert keep.sum() == t.size - 1
    return t[keep], r[keep], d[keep], v[keep]


def test_one_missed_reading_is_evaluated_over_the_runs_that_reached_the_target():
    # run 1 '+' at 610 mm missed: the 4 readings left are 2 + 1.5 * (-1, 0, 1, 1)
    # mean = (0.5 + 2 + 3.5 + 3.5) / 4 = 2.375; squares about it 3.515625 + 0.140625
    # + 2 * 1.265625 = 6.1875; s = sqrt(6.1875 / (4 - 1)) = sqrt(2.0625) (n of that target)
    res = evaluate(*_drop(1, 610.0, "+"), allow_incomplete=True)
    s = np.sqrt(2.0625)
    assert not res.complete
    row = res.targets.rows()[3]
    assert row["target_mm"] == 610.0
    assert row["mean_up"] == pytest.approx(2.375, abs=1e-12)
    assert row["s_up"] == pytest.approx(s, abs=1e-12)
    assert (row["n_up"], row["n_down"], row["n"]) == (4, 5, 4)
    assert [r["n"] for r in res.targets.rows()] == [5, 5, 5, 4, 5]
    # B_3 = 2.375 - 3 = -0.625: B_mean = (2 + 2 + 1 - 0.625 + 3) / 5; R_up = 4 s there
    assert res.B_mean == pytest.approx(7.375 / 5, abs=1e-12)
    assert res.R_up == pytest.approx(4 * s, abs=1e-12)
    # the envelopes 2.375 +- 2 s stay inside the others, the means inside E and M
    for k in ("A", "A_up", "A_down", "E", "E_up", "E_down", "M", "R", "R_down", "B"):
        assert getattr(res, k) == pytest.approx(EXPECTED[k], abs=1e-12), k
    assert res.notes == ["incomplete: run 1 has no reading at target 610 mm in direction '+' "
                         "(missed capture); that target is evaluated over the 4 of 5 runs "
                         "that reached it"]
    d = res.to_dict()
    assert d["complete"] is False
    assert d["missing"] == [{"run": 1, "target_mm": 610.0, "direction": "+"}]
    assert d["targets"][3]["n"] == 4


def test_complete_test_is_unchanged_and_marked_complete():
    res = evaluate(*cycle(), allow_incomplete=True)
    assert res.complete and res.notes == [] and res.to_dict()["complete"] is True
    assert [r["n"] for r in res.targets.rows()] == [5] * 5
    for k, v in EXPECTED.items():
        assert getattr(res, k) == pytest.approx(v, abs=1e-12), k


def test_target_reached_by_one_run_is_left_out_of_R_and_A():
    t, r, d, v = cycle()
    keep = ~((t == 800.0) & (d == "-") & (r >= 2))  # 800 mm '-' only in run 1
    res = evaluate(t[keep], r[keep], d[keep], v[keep], allow_incomplete=True)
    assert res.targets.rows()[4]["n_down"] == 1 and res.targets.rows()[4]["s_down"] is None
    # 800 mm down gave R_down = 8 and the lowest envelope -8: without it R_down = 4,
    # A_down = max[0, 2, 6, 4] - min[-4, 0, 2, 2] = 10 (its mean, run 1's -4 - 2 * -1 ... is
    # kept in E: x = -4 + 2 * OFFS[(0 + 2) % 5] = -4)
    assert res.R_down == pytest.approx(4.0) and res.A_down == pytest.approx(10.0)
    assert res.E_down == pytest.approx(8.0)
    assert any("target 800 mm reached by 1 run(s) in direction '-'" in n for n in res.notes)


def test_strict_evaluation_names_the_column_given():
    with pytest.raises(VolcalInputError) as exc:
        evaluate(*_drop(2, 420.0, "-"), file="linear-y1.csv", target_column="y_mm")
    assert exc.value.column == "y_mm"
    assert exc.value.message.startswith(
        "missing reading: run 2 has no reading at target 420 mm in direction '-'")


# ------------------------------------------------------------------ files and sessions

def _positioning_csv(path: Path, missed_row: int | None = None) -> Path:
    t, r, d, v = cycle()
    lines = [f"{a:g},{b},{c},{e:.6f}" for a, b, c, e in zip(t, r, d, v, strict=True)]
    if missed_row is not None:
        parts = lines[missed_row - 2].split(",")
        lines[missed_row - 2] = ",".join([*parts[:3], "missed"])
    path.write_text("target_mm,run,direction,deviation_um\n" + "\n".join(lines) + "\n")
    return path


def test_evaluate_iso230_2_file_with_a_missed_cell(tmp_path, monkeypatch, capsys):
    # row 5 of the file = run 1, '+', 610 mm: the case worked by hand above
    f = _positioning_csv(tmp_path / "x.csv", missed_row=5)
    code, out, err = run_cli(monkeypatch, capsys, "evaluate", "iso230-2", f, "--json")
    assert code == 0, err
    d = json.loads(out)
    assert d["complete"] is False and d["targets"][3]["n_up"] == 4
    assert d["R_up"] == pytest.approx(4 * np.sqrt(2.0625), abs=1e-9)
    assert f"note: {f}: missed capture skipped (row 5)" in err
    code, out, err = run_cli(monkeypatch, capsys, "evaluate", "iso230-2", f)
    assert code == 0
    text = " ".join(out.split())
    assert "incomplete: 1 missed reading(s)" in text
    assert "run 1 has no reading at target 610 mm in direction '+'" in text


@pytest.fixture(scope="module")
def measured(tmp_path_factory) -> Path:
    """A gantry-like session (FXYZ, 1200 x 800 x 600 mm): 9 lines of 5 runs and the four
    body diagonals of 11 points, simulated."""
    from volcal.measure.simulate import SimulationOptions, simulate_session
    from volcal.measure.virtual import random_machine
    from volcal.plan.planner import plan_session
    from volcal.session.format import write_session
    from volcal.session.provenance import simulated_provenance

    s = plan_session(TRAVEL, "FXYZ", steps=10, tests=("diagonal", "linear"), runs=5)
    simulate_session(s, random_machine(TRAVEL, "FXYZ", 3), SimulationOptions(seed=3))
    s.provenance = simulated_provenance(s, seed=3, noise_um=0.5)
    return write_session(s, tmp_path_factory.mktemp("gantry") / "S")


@pytest.fixture
def S(measured, tmp_path) -> Path:
    d = tmp_path / "S"
    shutil.copytree(measured, d)
    return d


def test_session_with_one_missed_capture_is_evaluated(S, monkeypatch, capsys):
    old = set_cell(S / "linear-y1.csv", 30, "deviation_um", "missed")
    target, run, sign = float(old[1]), int(old[4]), old[5]
    code, out, err = run_cli(monkeypatch, capsys, "evaluate", "session", S, "--json")
    assert code == 0, err
    d = json.loads(out)
    assert len(d["measurements"]) == 9  # the other tests evaluated as usual
    assert d["incomplete"] == ["linear-y1"]
    y1 = d["measurements"]["linear-y1"]
    assert y1["complete"] is False
    assert y1["missing"] == [{"run": run, "target_mm": pytest.approx(target), "direction": sign}]
    ns = {round(r["target_mm"], 3): (r["n_up"], r["n_down"]) for r in y1["targets"]}
    assert ns[round(target, 3)] == ((4, 5) if sign == "+" else (5, 4))
    assert sum(n for pair in ns.values() for n in pair) == 2 * 5 * len(ns) - 1
    assert all(v["complete"] for k, v in d["measurements"].items() if k != "linear-y1")
    code, out, err = run_cli(monkeypatch, capsys, "evaluate", "session", S)
    assert code == 0
    text = " ".join(out.split())
    assert "4-5 incomplete" in text
    assert (f"linear-y1 incomplete: run {run} has no reading at target {target:g} mm in "
            f"direction '{sign}' (missed capture); that target is evaluated over the 4 of 5 "
            "runs that reached it") in text


def test_test_with_too_few_captures_is_skipped_and_the_others_evaluated(S, monkeypatch,
                                                                         capsys):
    r = _rows(S / "linear-z1.csv")
    for x in r[1:]:
        if x[5] == "-":
            x[3] = "missed"
    _write(S / "linear-z1.csv", r)
    code, out, err = run_cli(monkeypatch, capsys, "evaluate", "session", S, "--json")
    assert code == 0, err
    d = json.loads(out)
    assert len(d["measurements"]) == 8 and "linear-z1" not in d["measurements"]
    assert d["skipped"] == ["linear-z1"]
    assert d["skipped_reasons"]["linear-z1"] == (
        "too many missed captures: no readings in direction '-': ISO 230-2 needs "
        "bidirectional runs")


def test_incomplete_diagonal_is_marked(S, monkeypatch, capsys):
    for row in range(8, 13):  # the last 5 of 11 points of diag-ppp missed: 6 of 11
        set_cell(S / "diag-ppp.csv", row, "deviation_um", "missed")
    code, out, err = run_cli(monkeypatch, capsys, "evaluate", "iso230-6", S, "--json")
    assert code == 0, err
    d = json.loads(out)
    by = {r["id"]: r for r in d["diagonals"]}
    ppp = by["diag-ppp"]
    assert (ppp["complete"], ppp["points_measured"], ppp["points_planned"]) == (False, 6, 11)
    assert [m["row"] for m in ppp["missed"]] == [8, 9, 10, 11, 12]
    assert all(by[k]["complete"] and by[k]["points_measured"] == 11 for k in
               ("diag-npp", "diag-pnp", "diag-ppn"))
    full = max(by[k]["E_D"] for k in ("diag-npp", "diag-pnp", "diag-ppn"))
    assert d["max_E_D"] == pytest.approx(full) and d["incomplete"] == ["diag-ppp"]
    assert d["max_E_D_id"] != "diag-ppp"
    code, out, err = run_cli(monkeypatch, capsys, "evaluate", "iso230-6", S)
    assert code == 0
    text = " ".join(out.split())
    assert "6/11 incomplete" in text and "11/11" in text
    assert ("incomplete: diag-ppp: incomplete diagonal, 6 of 11 points measured (missed: rows "
            "8, 9, 10, 11, 12); E_D covers the measured points only and is left out of the "
            "largest E_D") in text
    assert f"largest E_D of the complete diagonals: {full:.3f} um" in text


def test_report_lists_missed_readings_and_unmeasured_tests(S, tmp_path, monkeypatch, capsys):
    old = set_cell(S / "linear-x2.csv", 14, "deviation_um", "missed")
    set_cell(S / "diag-ppp.csv", 12, "deviation_um", "missed")
    r = _rows(S / "linear-z3.csv")  # planned, not measured
    for x in r[1:]:
        x[3] = ""
    _write(S / "linear-z3.csv", r)
    code, _, err = run_cli(monkeypatch, capsys, "report", S, "-o", tmp_path / "R")
    assert code == 0, err
    # the one PDF drawn of a report with missed readings and an unmeasured test (the
    # missed-capture flow of tests/cli stubs its own)
    assert (tmp_path / "R" / "report.pdf").read_bytes()[:5] == b"%PDF-"
    assert (tmp_path / "R" / "report.pdf").stat().st_size > 20_000
    html = (tmp_path / "R" / "report.html").read_text()
    text = " ".join(html.replace("<", " <").replace(">", "> ").split())
    assert "Completeness and plausibility of the readings" in text
    assert ("1 of the 13 planned tests were not measured (no readings): linear-z3." in text)
    assert "Missed readings" in text
    # the missed linear reading: measurement, kind, file row, run, direction, target, n
    rows = [[unescape(c).strip() for c in re.findall(r"<td[^>]*>(.*?)</td>", tr, re.S)]
            for tr in re.findall(r"<tr[^>]*>(.*?)</tr>", html, re.S)]
    row = next(r for r in rows if r[:1] == ["linear-x2"] and r[2:3] == ["14"])
    assert row[1] == "linear" and row[3:5] == [old[4], old[5]]
    assert float(row[5]) == pytest.approx(float(old[0]), abs=1e-3)
    assert row[6] == "n = 4 of 5 runs"
    assert "10 of 11 points" in text
    assert "incomplete tests (missed readings): diag-ppp, linear-x2" in text
    assert "diag-ppp: incomplete diagonal, 10 of 11 points measured (missed: row 12)" in text


# ------------------------------------------------------------------ plausibility

def test_readings_1000x_too_small_are_flagged(S, monkeypatch, capsys):
    scale(S / "linear-y2.csv", 1e-3)  # mm typed into deviation_um
    code, _, err = run_cli(monkeypatch, capsys, "evaluate", "session", S)
    assert code == 0
    assert "warning: linear-y2: deviations ~" in err
    assert ("x smaller than the session's other linear tests" in err
            and "readings 1000x too small (mm typed into deviation_um) in linear-y2.csv?" in err)
    # the same file alone: the floors need no other test
    code, out, err = run_cli(monkeypatch, capsys, "evaluate", "iso230-2", S / "linear-y2.csv",
                             "--json")
    assert code == 0
    w = json.loads(out)["plausibility"]
    assert len(w) == 1 and w[0].startswith("linear-y2.csv: 2s repeatability ")
    assert "nm on a 790 mm line, below the 20 nm no interferometer in air reads" in w[0]
    assert w[0] in err
    # and in the report's text, naming the measurement
    from volcal.report.completeness import completeness_section
    from volcal.report.sections import ReportInputs
    from volcal.session.format import read_session

    sec = completeness_section(ReportInputs(read_session(S)))
    assert sec is not None and sec.paragraphs[0] == "All 13 planned tests were measured."
    assert any(x.startswith("implausible readings: linear-y2: deviations ~")
               and x.endswith("readings 1000x too small (mm typed into deviation_um) in "
                              "linear-y2.csv?")
               for x in sec.warnings)


def test_import_warns_about_readings_1000x_too_small(S, tmp_path, monkeypatch, capsys):
    """A vendor export without a unit in its header, holding mm: read as um, flagged."""
    rows = _rows(S / "linear-x1.csv")[1:]
    f = tmp_path / "export.csv"
    f.write_text("Target,Run,Dir,Error\n" + "".join(
        f"{r[0]},{r[4]},{'fwd' if r[5] == '+' else 'bwd'},{float(r[3]) / 1000:.7f}\n"
        for r in rows))
    code, out, err = run_cli(monkeypatch, capsys, "import", f, "--map",
                             "target=Target,run=Run,direction=Dir,deviation=Error",
                             "--session", S, "--axis", "X", "--id", "linear-x9")
    assert code == 0, err
    text = " ".join(out.split())
    assert "deviation column 'Error': um (assumed; no unit in the header)" in text
    warn = " ".join(err.split())  # warnings on standard error, the results on stdout
    assert "warning: linear-x9: deviations ~" in warn and "warning" not in text
    assert "x smaller than the session's other linear tests" in warn


def test_floor_warnings():
    from volcal.session.plausibility import REPEATABILITY_FLOOR_UM, reading_warnings

    x = np.linspace(0.0, 800.0, 9)
    dev = 5.0 * np.sin(x / 200.0)  # a 10 um range: fine
    assert reading_warnings("l1", "l1.csv", 800.0, dev) == []
    # the same in mm: 0.00999 um over 800 mm = 0.0125 um/m < 0.1 um/m
    w = reading_warnings("l1", "l1.csv", 800.0, dev / 1000.0)
    r = np.ptp(dev) / 1000.0
    assert w == [f"l1: the deviations span {r:.3g} um over 800 mm ({r / 0.8:.3g} um/m), "
                 "below the 0.1 um/m any machine shows: readings 1000x too small (mm typed "
                 "into deviation_um) in l1.csv?"]
    assert reading_warnings("l1", "l1.csv", 99.0, dev / 1000.0) == []  # too short to judge
    # a 2s repeatability of 10 nm over 5 runs at each target (range fine)
    t = np.repeat(x, 5)
    run = np.tile(np.arange(1, 6), 9)
    noise = np.tile([-0.005, -0.005, 0.0, 0.005, 0.005], 9)  # s = 0.005, 2s = 0.01 um
    w = reading_warnings("l2", "l2.csv", 800.0, np.repeat(dev, 5) + noise, t, run,
                         np.full(t.size, "+"))
    assert w == ["l2: 2s repeatability 10 nm on a 800 mm line, below the 20 nm no "
                 "interferometer in air reads: readings 1000x too small (mm typed into "
                 "deviation_um) in l2.csv?"]
    assert REPEATABILITY_FLOOR_UM == 0.02
    # 1000x too large: 10 mm over 800 mm
    w = reading_warnings("l3", "l3.csv", 800.0, dev * 1000.0)
    assert len(w) == 1 and "above the 1000 um/m of any calibrated machine axis" in w[0]
