"""``volcal evaluate`` and ``volcal env`` end to end, including bad files."""

import json

import numpy as np
import pytest
from test_iso230_2 import EXPECTED, cycle

from volcal_cli_helpers import run_volcal


def write_cycle(path, header="target_mm,run,direction,deviation_um", mutate=None):
    t, r, d, v = cycle()
    lines = [f"{a:g},{b},{c},{e:.6f}" for a, b, c, e in zip(t, r, d, v, strict=True)]
    if mutate:
        lines = mutate(lines)
    path.write_text(header + "\n" + "\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_iso230_2_json(tmp_path, monkeypatch, capsys):
    f = write_cycle(tmp_path / "x.csv")
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f), "--json")
    assert code == 0
    d = json.loads(out)
    for k, v in EXPECTED.items():
        assert d[k] == pytest.approx(v, abs=1e-9), k
    assert len(d["targets"]) == 5 and d["targets"][3]["R"] == pytest.approx(6.0)


def test_iso230_2_session_measurement_csv(tmp_path, monkeypatch, capsys):
    t, r, d, v = cycle()
    rows = [f"{a:g},250,100,{e:.6f},{b},{c}" for a, b, c, e in zip(t, r, d, v, strict=True)]
    f = tmp_path / "linear-x1.csv"
    f.write_text("x_mm,y_mm,z_mm,deviation_um,run,direction\n" + "\n".join(rows) + "\n")
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f), "--json")
    assert code == 0
    assert json.loads(out)["R"] == pytest.approx(9.0)
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f))
    assert code == 0 and "repeatability" in out


@pytest.mark.parametrize("header, mutate, row, column", [
    ("target_mm,run,deviation_um", lambda ls: [",".join(x.split(",")[i] for i in (0, 1, 3))
                                               for x in ls], 1, "direction"),
    (None, lambda ls: [x for x in ls if ",1," in x], None, "run"),        # a single run
    (None, lambda ls: ls[:3] + [ls[3].rsplit(",", 1)[0] + ",nan"] + ls[4:], 5, "deviation_um"),
    (None, lambda ls: ls + [ls[0]], 52, "target_mm"),                     # duplicate row
    ("target_mm,run,direction,deviation_mm", None, 1, "deviation_mm"),   # unknown unit
    ("target_in,run,direction,deviation_um", None, 1, "target_in"),
    (None, lambda ls: ls[:6] + [ls[6].replace(",+,", ",up,").replace(",-,", ",up,")] + ls[7:],
     8, "direction"),
])
def test_bad_files_name_file_row_column(tmp_path, monkeypatch, capsys, header, mutate, row,
                                        column):
    f = write_cycle(tmp_path / "bad.csv", header or "target_mm,run,direction,deviation_um",
                    mutate)
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2", str(f), "--json")
    assert code == 2
    flat = " ".join(err.split())  # rich may wrap long messages
    assert "Traceback" not in err and out == ""
    assert "bad.csv" in err.replace("\n", "")
    assert f"column '{column}'" in flat
    if row is not None:
        assert f"row {row}" in flat


def test_session_and_iso230_6_and_vdi(tmp_path, monkeypatch, capsys):
    s = tmp_path / "s"
    assert run_volcal(monkeypatch, capsys, "plan", "-o", str(s), "--steps", "4")[0] == 0
    assert run_volcal(monkeypatch, capsys, "simulate", str(s))[0] == 0
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s), "--json")
    assert code == 0
    d = json.loads(out)
    ms = d["measurements"]
    assert {v["axis"] for v in ms.values()} == {"X", "Y", "Z"}
    first = {}
    for v in ms.values():
        first.setdefault(v["axis"], v["M"])
    assert d["ELv"] == pytest.approx(np.sqrt(sum(x * x for x in first.values())))
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "iso230-6", str(s), "--json")
    assert code == 0
    diags = json.loads(out)["diagonals"]
    assert len(diags) == 4 and all(x["E_D"] > 0 for x in diags)
    f = write_cycle(tmp_path / "x.csv")
    code, out, _ = run_volcal(monkeypatch, capsys, "evaluate", "vdi3441", str(f), "--json")
    assert code == 0 and json.loads(out)["P"] == pytest.approx(15.75)


def test_env_refractive_index(monkeypatch, capsys):
    # NIST EMToolbox check values (Stone & Zimmerman, section VII table): 20 degC, 60 kPa,
    # 0 % RH, 633 nm: Ciddor 1.000160924, modified Edlen 1.000160920
    for formula, n in (("ciddor", 1.000160924), ("edlen", 1.000160920)):
        code, out, _ = run_volcal(monkeypatch, capsys, "env", "refractive-index",
                                  "--temperature-c", "20", "--pressure-pa", "60000",
                                  "--humidity-pct", "0", "--wavelength-nm", "633",
                                  "--formula", formula, "--co2-ppm", "450")
        assert code == 0
        assert abs(float(out) - n) < 2e-8
    code, _, err = run_volcal(monkeypatch, capsys, "env", "refractive-index", "--temperature-c",
                              "20", "--pressure-pa", "1013", "--humidity-pct", "50")
    assert code == 2 and "--pressure-pa 1013 outside" in err and "hPa" in err
