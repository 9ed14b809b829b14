"""CLI output when redirected (issue 20, item 9 of the findings): tables with units in the
headers and every number in full, and ``-o -`` for standard output."""

from __future__ import annotations

import csv
import io
import json
import re
import subprocess
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

from timing import scaled_timeout
from volcal import Calibration
from volcal.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    d = tmp_path_factory.mktemp("out")
    c = Calibration.plan([[0, 1200], [0, 800], [0, 600]], chain="FXYZ", steps=4, runs=2,
                         name="GANTRY")
    c.simulate(seed=11, noise_um=0.3, reversal_um=4.0).save(d / "S")
    return d / "S"


def _cli(*args, env=None):
    return subprocess.run([sys.executable, "-c", "from volcal.cli import main; main()",
                           *map(str, args)], capture_output=True, text=True, env=env,
                          timeout=scaled_timeout(300))


def _cells(out: str) -> list[list[str]]:
    """The body rows of a Rich table as printed (box characters stripped)."""
    rows = []
    for line in out.splitlines():
        if line.startswith("│"):
            rows.append([c.strip() for c in line.strip("│").split("│")])
    return rows


def test_session_table_redirected_keeps_every_number_and_unit(session):
    import os

    env = {**os.environ, "COLUMNS": "40"}  # a narrow "terminal" must not cut numbers
    r = _cli("evaluate", "session", session, env=env)
    assert r.returncode == 0, r.stderr
    assert "…" not in r.stdout and "..." not in r.stdout
    header = next(ln for ln in r.stdout.splitlines() if ln.startswith("┃"))
    for h in ("runs", "A [um]", "E [um]", "M [um]", "R [um]", "B [um]", "B_mean [um]"):
        assert h in header
    js = json.loads(_cli("evaluate", "session", session, "--json").stdout)["measurements"]
    rows = _cells(r.stdout)
    assert [row[0] for row in rows] == list(js)
    for row in rows:  # the same numbers as --json, to the 3 decimals shown
        m = js[row[0]]
        assert row[1] == m["axis"] and row[2] == "2"  # runs
        assert [float(v) for v in row[3:]] == pytest.approx(
            [m[k] for k in ("A", "E", "M", "R", "B", "B_mean")], abs=5e-4)


def test_per_target_table_in_full_with_units(session):
    f = session / "linear-x1.csv"
    r = runner.invoke(app, ["evaluate", "iso230-2", str(f)])  # CliRunner: not a terminal
    assert r.exit_code == 0, r.output
    assert "…" not in r.output
    assert "per target [um]" in r.output and "value [um]" in r.output
    for h in ("target [mm]", "n↑", "x̄↑ [um]", "x̄ [um]", "R_i [um]"):
        assert h in r.output
    js = json.loads(runner.invoke(app, ["evaluate", "iso230-2", str(f), "--json"]).output)
    rows = [row for row in _cells(r.output) if len(row) == 12]
    assert len(rows) == len(js["targets"])
    for row, t in zip(rows, js["targets"], strict=True):
        assert [int(row[1]), int(row[2])] == [t["n_up"], t["n_down"]]
        assert [float(v) for v in row[:1] + row[3:]] == pytest.approx(
            [t[k] for k in ("target_mm", "mean_up", "mean_down", "mean", "s_up", "s_down",
                            "B", "R_up", "R_down", "R")], abs=5e-4)
    assert any(v.startswith("-") and len(v) >= 6 for row in rows for v in row)  # -x.xxx


def test_diagonal_table_headers_carry_units(session):
    r = runner.invoke(app, ["evaluate", "iso230-6", str(session)])
    assert r.exit_code == 0, r.output
    for h in ("length [mm]", "points", "E_D [um]", "max |dev| [um]"):
        assert h in r.output
    # the title (the session's path first) wraps at the console's width: words, not lines
    assert "ISO 230-6 diagonal displacement" in " ".join(r.output.split())


def test_identify_and_predict_to_standard_output(session, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = _cli("identify", session, "-o", "-")
    assert r.returncode == 0, r.stderr
    model = json.loads(r.stdout)  # only the model on stdout
    assert model["format"] == "volcal-model/2" and model["name"] == "GANTRY"
    assert "model -> standard output" in r.stderr
    assert not (tmp_path / "-").exists()
    (tmp_path / "m.json").write_text(r.stdout)
    (tmp_path / "p.csv").write_text("x_mm,y_mm,z_mm\n0,0,0\n600,400,300\n1200,800,600\n")
    r = runner.invoke(app, ["predict", "m.json", "--points", "p.csv", "-o", "-"])
    assert r.exit_code == 0, r.output
    r2 = runner.invoke(app, ["predict", "m.json", "--points", "p.csv", "-o", "f.csv"])
    assert r2.exit_code == 0, r2.output
    rows = list(csv.reader(io.StringIO(r.stdout)))
    assert rows[0][:4] == ["x_mm", "y_mm", "z_mm", "ex_um"]
    assert r.stdout == (tmp_path / "f.csv").read_text()  # the same file, on stdout
    assert not (tmp_path / "-").exists()
    # the numbers are the model's prediction
    from volcal.identify import load_model

    e, _ = load_model(tmp_path / "m.json").predict(np.array([[600.0, 400.0, 300.0]]))
    assert [float(v) for v in rows[2][3:6]] == pytest.approx(e[0], abs=1e-4)


def test_classic_abbe_to_standard_output_and_two_files_refused(session, tmp_path):
    files = [str(session / f"linear-x{i}.csv") for i in (1, 2, 3)]
    r = runner.invoke(app, ["classic", "abbe", *files, "--axis", "X", "--chain", "FXYZ",
                            "-o", "-"])
    assert r.exit_code == 0, r.output
    r2 = runner.invoke(app, ["classic", "abbe", *files, "--axis", "X", "--chain", "FXYZ",
                             "-o", str(tmp_path / "a.csv")])
    assert r2.exit_code == 0
    assert r.stdout.startswith("x_mm,EXX_um,EBX_urad,ECX_urad\n")
    assert r.stdout == (tmp_path / "a.csv").read_text()
    r = _cli("classic", "step-diagonal", session, "-o", "-")
    assert r.returncode == 2 and "writes two files" in r.stderr
    assert re.search(r"give a file name", r.stderr)


@pytest.mark.parametrize("args, what", [
    (["program", "{S}", "--dialect", "fanuc", "-o", "-"], "the program is a folder"),
    (["compensate", "{M}", "--format", "fanuc", "-o", "-"], "the compensation is a folder"),
    (["plan", "-o", "-"], "the session is a folder"),
])
def test_folder_outputs_refuse_standard_output(session, tmp_path, monkeypatch, args, what):
    monkeypatch.chdir(tmp_path)
    from volcal.measure.virtual import random_machine
    from volcal.session.errortable import write_error_table

    write_error_table(random_machine(np.array([[0, 1200], [0, 800], [0, 600]], float),
                                     "FXYZ", 1), tmp_path / "m.csv")
    args = [a.replace("{S}", str(session)).replace("{M}", str(tmp_path / "m.csv"))
            for a in args]
    r = _cli(*args)
    assert r.returncode == 2, r.stderr
    assert f"-o -: {what} of files, which cannot go to standard output" in r.stderr
    assert not (tmp_path / "-").exists()
