import subprocess
import sys

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.importer import import_csv, parse_mapping, read_laser_csv
from volcal.importer.units import unit_from_header
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session
from volcal_cli_helpers import volcal_process

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
EXPORT = """Laser XL export;;;
Date;2026-11-20;;
Target (mm);Run;Dir;Error (\u00b5m)
0;1;fwd;0,0
100;1;fwd;1,2
200;1;fwd;2,5
200;1;bwd;3,1
100;1;bwd;1,9
0;1;bwd;0,4
"""
MAP = "target=Target,run=Run,direction=Dir,deviation=Error"


def test_vendor_style_export_windows_1252(tmp_path):
    f = tmp_path / "x.csv"
    f.write_bytes(EXPORT.encode("cp1252"))  # the micro sign as byte 0xB5
    r = import_csv(f, parse_mapping(MAP), "x", [100.0, 50.0, 20.0], tmp_path / "s", "lx1",
                   travel=TRAVEL)
    assert r.created
    m = read_session(tmp_path / "s").get("lx1")
    np.testing.assert_array_equal(m.positions[:, 0], [100, 200, 300, 300, 200, 100])
    np.testing.assert_array_equal(m.positions[:, 1:], np.tile([50.0, 20.0], (6, 1)))
    np.testing.assert_allclose(m.deviation, [0.0, 1.2, 2.5, 3.1, 1.9, 0.4])
    assert list(m.direction) == ["+", "+", "+", "-", "-", "-"]
    assert list(m.run) == [1] * 6
    assert m.kind == "linear" and m.axis == 0 and list(m.beam_direction) == [1, 0, 0]
    assert "target column 'Target (mm)': mm (detected from the header)" in r.notes
    assert "deviation column 'Error (\u00b5m)': um (detected from the header)" in r.notes


def test_reading_column_in_inches(tmp_path):
    # deviation = reading - target: 0.0001 in = 2.54 um exactly (1 in = 25.4 mm)
    f = tmp_path / "r.csv"
    f.write_text("pos,laser\n0.0,0.00000\n1.0,1.00010\n2.0,1.99990\n")
    t = read_laser_csv(f, parse_mapping("target=pos,reading=laser"), units="in")
    np.testing.assert_allclose(t.target_mm, [0.0, 25.4, 50.8])
    np.testing.assert_allclose(t.deviation_um, [0.0, 2.54, -2.54], atol=1e-9)
    assert "target column 'pos': in (given)" in t.notes
    assert "reading column 'laser': in (given)" in t.notes
    assert list(t.columns["direction"]) == ["+", "+", "+"]


def test_deviation_units_for_inch_files_must_be_known(tmp_path):
    f = tmp_path / "r.csv"
    f.write_text("pos [in],err\n0,0\n1,40\n")
    with pytest.raises(VolcalInputError, match="no unit in the header") as e:
        read_laser_csv(f, parse_mapping("target=pos,deviation=err"))
    assert e.value.column == "err"
    t = read_laser_csv(f, parse_mapping("target=pos,deviation=err"), deviation_units="uin")
    np.testing.assert_allclose(t.deviation_um, [0.0, 40 * 0.0254])


@pytest.mark.parametrize("header,unit", [("Position (mm)", "mm"), ("Error [\u00b5m]", "um"),
                                         ("dev_um", "um"), ("X [inch]", "in"), ("E (uin)", "uin"),
                                         ("Deviation", None), ("Error (nm)", "nm")])
def test_unit_from_header(header, unit):
    assert unit_from_header(header) == unit


def test_add_to_existing_session_keeps_everything(tmp_path):
    s = plan_session(TRAVEL, "XYFZ", 2, ["diagonal"], 1)
    write_session(s, tmp_path / "s", {"truth/TRUTH.csv": "hidden"})
    f = tmp_path / "x.csv"
    f.write_text("T,E\n0,0\n300,1.5\n600,2\n")
    r = import_csv(f, parse_mapping("target=T,deviation=E"), "Y", [10, 0, 5], tmp_path / "s",
                   "ly")
    assert not r.created
    back = read_session(tmp_path / "s", require_deviation=False)
    assert [m.id for m in back.measurements] == [m.id for m in s.measurements] + ["ly"]
    assert (tmp_path / "s" / "truth" / "TRUTH.csv").read_text() == "hidden"
    np.testing.assert_array_equal(back.get("ly").positions[:, 1], [0, 300, 600])
    with pytest.raises(VolcalInputError, match="exists"):
        import_csv(f, parse_mapping("target=T,deviation=E"), "Y", [10, 0, 5], tmp_path / "s",
                   "ly")
    f.write_text("T,E\n0,0\n300,-1.5\n600,-2\n")
    import_csv(f, parse_mapping("target=T,deviation=E"), "Y", [10, 0, 5], tmp_path / "s", "ly",
               replace=True)
    np.testing.assert_allclose(read_session(tmp_path / "s", require_deviation=False)
                               .get("ly").deviation, [0, -1.5, -2])


@pytest.mark.parametrize("text,mapping,msg,row,col", [
    ("a,b\n1,2\n3,4\n", "target=T,deviation=E", "no header line", 1, "T"),
    ("T,E\n1,2\n3,x\n", "target=T,deviation=E", "not a number", 3, "E"),
    ("T,E\n1,2\n3,inf\n", "target=T,deviation=E", "not a finite", 3, "E"),
    ("T,E,D\n1,2,+\n3,4,sideways\n", "target=T,deviation=E,direction=D", "unknown direction",
     3, "D"),
    ("T,E,R\n1,2,1\n3,4,-1\n", "target=T,deviation=E,run=R", "whole number", 3, "R"),
    ("T,E\n1,2\n", "target=T,deviation=E", "at least 2", 3, None),
    ("T,E\n1,2\n3\n", "target=T,deviation=E", "expected 2 fields", 3, None),
])
def test_bad_files_name_row_and_column(tmp_path, text, mapping, msg, row, col):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(VolcalInputError, match=msg) as e:
        import_csv(f, parse_mapping(mapping), "X", [0, 0, 0], tmp_path / "s", "m", travel=TRAVEL)
    assert e.value.file == str(f) and e.value.row == row and e.value.column == col
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("text,msg", [
    ("deviation=E", "needs target"), ("target=T", "exactly one of"),
    ("target=T,deviation=E,reading=R", "exactly one of"), ("target=T,foo=E", "unknown key"),
    ("target=T,target=U,deviation=E", "twice"), ("target", "not key=column")])
def test_bad_mapping(text, msg):
    with pytest.raises(VolcalInputError, match=msg):
        parse_mapping(text)


def test_binary_vendor_file_is_refused(tmp_path):
    f = tmp_path / "run.rtl"
    f.write_bytes(b"RTL\x00\x01\x02\xff")
    with pytest.raises(VolcalInputError, match="binary file"):
        read_laser_csv(f, parse_mapping("target=T,deviation=E"))


def test_cli(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text(EXPORT, encoding="utf-8")
    cmd = [sys.executable, "-c", "from volcal.cli import main; main()", "import", str(f),
           "--map", MAP, "--axis", "Z", "--session", str(tmp_path / "s"), "--id", "lz"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 2 and "needs --travel" in r.stderr and "Traceback" not in r.stderr
    # the import itself in-process (volcal_process: main(), its streams and exit code);
    # the refusal above is a real process
    r = volcal_process(*cmd[3:], "--travel", "0:800,0:600,0:500", "--line-mm", "0,0,100")
    assert r.returncode == 0, r.stderr
    assert "mm (detected from the header)" in r.stdout
    np.testing.assert_array_equal(read_session(tmp_path / "s").get("lz").positions[:, 2],
                                  [100, 200, 300, 300, 200, 100])
