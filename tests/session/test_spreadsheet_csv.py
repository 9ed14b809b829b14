"""A session CSV saved by a spreadsheet (``;`` and decimal commas) reads like the original;
a mistyped column is named with its header line and the closest name (issue 20, Why 8)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from typer.testing import CliRunner

from volcal.cli import app
from volcal.errors import VolcalInputError
from volcal.session.format import read_session


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    d = tmp_path_factory.mktemp("sheet") / "S"
    runner = CliRunner()
    r = runner.invoke(app, ["plan", "--travel", "0:400,0:300,0:200", "--steps", "3", "--runs",
                            "2", "-o", str(d)])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["simulate", str(d), "--seed", "5"])
    assert r.exit_code == 0, r.output
    return d


def _european(text: str) -> str:
    """What a spreadsheet with a German locale saves: ``;`` between fields, ``,`` decimals."""
    return text.replace(",", ";").replace(".", ",")


def test_semicolons_and_decimal_commas_read_like_the_original(measured, tmp_path):
    s = tmp_path / "S"
    shutil.copytree(measured, s)
    for f in s.glob("*.csv"):
        f.write_text(_european(f.read_text()), encoding="utf-8-sig")  # Excel writes a BOM
    assert (s / "linear-x1.csv").read_text(encoding="utf-8-sig").startswith(
        "x_mm;y_mm;z_mm;deviation_um;run;direction;time_s\n5;0;0;0,000000;1;+;")
    a, b = read_session(measured), read_session(s)
    assert [m.id for m in a.measurements] == [m.id for m in b.measurements]
    for m, n in zip(a.measurements, b.measurements, strict=True):
        np.testing.assert_array_equal(m.positions, n.positions)
        np.testing.assert_array_equal(m.deviation, n.deviation)
        assert m.columns.keys() == n.columns.keys()
        for k in m.columns:
            np.testing.assert_array_equal(m.columns[k], n.columns[k])


def test_a_mistyped_column_names_the_closest_header(measured, tmp_path):
    s = tmp_path / "S"
    shutil.copytree(measured, s)
    p = s / "diag-ppp.csv"
    p.write_text(_european(p.read_text()).replace("deviation_um", "Deviation_um", 1))
    with pytest.raises(VolcalInputError) as e:
        read_session(s)
    assert str(e.value) == (
        f"{p}, row 1, column 'deviation_um': missing required column 'deviation_um' (closest: "
        "'Deviation_um') (header: x_mm,y_mm,z_mm,Deviation_um,time_s)")
