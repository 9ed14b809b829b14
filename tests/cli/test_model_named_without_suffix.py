"""A model written by ``volcal identify -o NAME`` without the ``.json`` suffix is read as
the model it is by every command that takes a model or an error table (session 18: the
model ``M`` went to ``report --model`` but ``compensate`` refused it, "expected an
identified model (.json) or an error table (.csv)", and ``evaluate volumetric`` read it
as a table with a broken header); and ``python -m volcal`` is the ``volcal`` command."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from timing import scaled_timeout
from volcal import Calibration
from volcal.cli import app
from volcal.io.sniff import is_model_file

runner = CliRunner()


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    d = tmp_path_factory.mktemp("nosuffix")
    Calibration.plan([[0, 800], [0, 600], [0, 500]], steps=4, runs=1,
                     name="NOSUFFIX").simulate(seed=5).save(d / "S")
    r = runner.invoke(app, ["identify", str(d / "S"), "-o", str(d / "M")])
    assert r.exit_code == 0, r.output
    assert (d / "M").is_file() and (d / "M.npz").is_file()
    shutil.copy(d / "M", d / "M.json")  # the same model with the suffix (its part: M.npz)
    return d


def test_is_model_file(tmp_path, folder):
    table = tmp_path / "errors"
    table.write_text("axis,name,position_mm,value\n", encoding="utf-8")
    bom = tmp_path / "bom.model"
    bom.write_bytes(b"\xef\xbb\xbf \n{\"format\": 1}")
    assert is_model_file(folder / "M") and is_model_file(bom)
    assert not is_model_file(table) and not is_model_file(tmp_path / "missing")
    assert is_model_file(tmp_path / "x.JSON") and not is_model_file(tmp_path / "x.csv")


def test_compensate_and_volumetric_read_the_model_without_suffix(folder):
    tables = {}
    for name in ("M", "M.json"):
        out = folder / f"C-{name}"
        r = runner.invoke(app, ["compensate", str(folder / name), "--format", "linuxcnc",
                                "-o", str(out)])
        assert r.exit_code == 0, r.output
        tables[name] = (out / "X.comp").read_text(encoding="utf-8")
    assert tables["M"].splitlines()[-20:] == tables["M.json"].splitlines()[-20:]
    idx = {}
    for name in ("M", "M.json"):
        r = runner.invoke(app, ["evaluate", "volumetric", str(folder / name), "--json"])
        assert r.exit_code == 0, r.output
        idx[name] = json.loads(r.output)
    assert idx["M"] == idx["M.json"] and idx["M"]["E_VXYZ"] > 0


def test_python_dash_m_volcal_is_the_command():
    r = subprocess.run([sys.executable, "-m", "volcal", "--version"], capture_output=True,
                       text=True, timeout=scaled_timeout(60))
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("volcal ")
