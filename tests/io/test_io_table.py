"""The declarative table reader and the readers built on it: located errors, the
options laser exports need (sniffed delimiter, decimal comma, preamble, loose names,
pattern columns)."""

from __future__ import annotations

import numpy as np
import pytest

from volcal.compensate.generic import read_generic
from volcal.compensate.volumetric import read_grid
from volcal.errors import VolcalInputError
from volcal.io.table import Column, TableSpec, parse_table
from volcal.standards.positioning_data import read_positioning_csv

EXPORT = TableSpec((Column("pos"), Column("err"), Column("runs", pattern="Run*", required=False)),
                   delimiters=",;\t", sniff=True, decimal_comma=True, header_within=10,
                   loose_names=True, extra_fields=True)


def test_preamble_semicolons_decimal_comma_and_loose_names():
    text = ("Vendor export, v2.1;;\nDate;23.11.2026;\nPos (mm);Err [µm];Run 1;Run 2;\n"
            "0;0,5;1,0;\u22122,25;\n100,5;1;2;3;\n")
    t = parse_table(text, EXPORT, "x.csv")
    assert (t.delimiter, t.header_row) == (";", 3)
    np.testing.assert_array_equal(t["pos"], [0.0, 100.5])
    np.testing.assert_array_equal(t["err"], [0.5, 1.0])
    assert t.written == {"pos": "Pos (mm)", "err": "Err [µm]", "Run 1": "Run 1", "Run 2": "Run 2"}
    assert t.groups == {"runs": ["Run 1", "Run 2"]}
    np.testing.assert_array_equal(t["Run 2"], [-2.25, 3.0])  # U+2212 minus sign
    assert t.rows.tolist() == [4, 5]


def test_decimal_comma_only_with_another_delimiter():
    with pytest.raises(VolcalInputError) as e:
        parse_table("pos,err\n0,1\n1;5,2\n", TableSpec((Column("pos"), Column("err"))), "c.csv")
    assert (e.value.row, e.value.column) == (3, "pos")


def test_no_header_within_the_preamble_names_what_is_missing():
    with pytest.raises(VolcalInputError) as e:
        parse_table("a;b\n1;2\n", EXPORT, "x.csv")
    assert e.value.message == ("no header line with the mapped columns (missing 'pos', 'err'; "
                               "first line: 'a,b')")
    assert (e.value.row, e.value.column) == (1, "pos")


def test_custom_parser_errors_are_located():
    def sign(t: str) -> str:
        if t not in ("up", "down"):
            raise ValueError(f"unknown direction {t!r}")
        return "+" if t == "up" else "-"

    spec = TableSpec((Column("d", kind="str", parse=sign),))
    assert parse_table("d\nup\ndown\n", spec)["d"].tolist() == ["+", "-"]
    with pytest.raises(VolcalInputError) as e:
        parse_table("d\nup\nsideways\n", spec, "d.csv")
    assert (e.value.message, e.value.row, e.value.column) == ("unknown direction 'sideways'", 3,
                                                              "d")


@pytest.mark.parametrize("text,msg,row,col", [
    ("axis,point,position_mm,error_um\nX,0,0,1\nW,1,20,2\n",
     "unknown axis 'W': expected X, Y or Z", 3, "axis"),
    ("axis,point,position_mm,error_um\nX,0,0,1\nX,1,20,two\n", "not a number: 'two'", 3,
     "error_um"),
    ("axis,point,position_mm,error_um,correction_um\nX,0,0,1,1\n",
     "expected the header axis,point,position_mm,error_um|correction_um", 1, None),
    ("axis,point,position_mm,error_um,note\nX,0,0,1,a\n",
     "unknown column (expected some of: axis, point, position_mm, error_um, correction_um)", 1,
     "note"),
])
def test_generic_pitch_table_errors(tmp_path, text, msg, row, col):
    f = tmp_path / "pitch.csv"
    f.write_text(text)
    with pytest.raises(VolcalInputError) as e:
        read_generic(f)
    assert (e.value.message, e.value.row, e.value.column) == (msg, row, col)


def test_generic_pitch_table_reads_its_sign(tmp_path):
    f = tmp_path / "pitch.csv"
    f.write_text("axis,point,position_mm,correction_um\nX,0,0,1.5\nX,1,20,-2\nY,0,0,3\n")
    x, y, z = read_generic(f)
    assert x.sign == "correction"
    np.testing.assert_array_equal(x.positions, [0, 20])
    np.testing.assert_array_equal(x.values, [1.5, -2.0])
    assert y.values.tolist() == [3.0] and z.values.size == 0


@pytest.mark.parametrize("text,msg,row,col", [
    ("x_mm,y_mm,z_mm,error_x_um,error_y_um,correction_z_um\n0,0,0,1,2,3\n",
     "expected x_mm,y_mm,z_mm,<sign>_x_um,<sign>_y_um,<sign>_z_um", 1, None),
    ("x_mm,y_mm,z_mm,error_x_um,error_y_um,error_z_um\n0,0,0,1,2,3\n0,0,inf,1,2,3\n",
     "not a finite number: 'inf'", 3, "z_mm"),
])
def test_grid_errors(tmp_path, text, msg, row, col):
    f = tmp_path / "grid.csv"
    f.write_text(text)
    with pytest.raises(VolcalInputError) as e:
        read_grid(f)
    assert (e.value.message, e.value.row, e.value.column) == (msg, row, col)


@pytest.mark.parametrize("text,msg,row,col", [
    ("target_mm,run,direction,deviation_um\n0,1,up,0\n", "expected one of '+', '-', got 'up'",
     2, "direction"),
    ("target_mm,run,direction,deviation_um\n0,1.5,+,0\n", "expected a whole number, got '1.5'",
     2, "run"),
    ("target_mm,run,direction,deviation_mm\n0,1,+,0\n",
     "unknown or unsupported unit: expected 'deviation_um' [um]", 1, "deviation_mm"),
    ("target_mm,run,direction,deviation_um\n", "no readings below the header", 1, None),
    ("target_mm,run,direction,deviation_um\n0,1,+,20000\n",
     "absurd value 20000: |value| > 10000 um", 2, "deviation_um"),
])
def test_positioning_csv_errors(tmp_path, text, msg, row, col):
    f = tmp_path / "p.csv"
    f.write_text(text)
    with pytest.raises(VolcalInputError) as e:
        read_positioning_csv(f)
    assert (e.value.message, e.value.row, e.value.column) == (msg, row, col)
