"""Session files: round trip, the issue's example, validation messages."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import TRAVEL, machine
from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.plan.planner import plan_session
from volcal.session.format import read_measurement_csv, read_session, write_session

EXAMPLE_TOML = """\
format = "volcal-session/1"
[machine]
name = "VMC-1"
chain = "XYFZ"
[machine.travel_mm]
x = [0, 800]
y = [0, 600]
z = [0, 500]
[[measurements]]
id = "step-ppp"
kind = "step_diagonal"
target = "flat_mirror"
beam_direction = [0.715541753, 0.536656315, 0.447213595]
tool_offset_mm = [0, 0, 0]
file = "step-ppp.csv"
[[measurements]]
id = "line"
kind = "linear"
file = "line.csv"
"""


def test_issue_example_loads(tmp_path):
    """A session written by another tool with exactly the required fields loads."""
    (tmp_path / "session.toml").write_text(EXAMPLE_TOML)
    (tmp_path / "step-ppp.csv").write_text(
        "x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n80,0,0,1.5\n80,60,0,2.25\n80,60,50,-0.5\n")
    (tmp_path / "line.csv").write_text("x_mm,y_mm,z_mm,deviation_um\n0,10,20,0\n400,10,20,3\n"
                                       "800,10,20,5\n")
    s = read_session(tmp_path)
    assert s.chain == "XYFZ" and s.name == "VMC-1"
    np.testing.assert_array_equal(s.travel, TRAVEL)
    a, b = s.measurements
    np.testing.assert_allclose(a.beam_direction, [0.715541753, 0.536656315, 0.447213595],
                               rtol=1e-8)
    np.testing.assert_allclose(a.deviation, [0, 1.5, 2.25, -0.5])
    # defaults: target retroreflector, beam from the first row to the farthest row
    assert b.target == "retroreflector"
    np.testing.assert_allclose(b.beam_direction, [1, 0, 0])
    assert b.axis == 0


def test_roundtrip_simulated_session(tmp_path):
    s = plan_session(TRAVEL, "YFXZ", steps=4, runs=2,
                     tests=("step-diagonal", "diagonal", "linear", "face-diagonal"),
                     tool_offset=(1.5, -2.0, 100.0))
    simulate_session(s, machine("YFXZ"), SimulationOptions(seed=4))
    write_session(s, tmp_path / "S")
    r = read_session(tmp_path / "S")
    assert [m.id for m in r.measurements] == [m.id for m in s.measurements]
    for a, b in zip(s.measurements, r.measurements, strict=True):
        np.testing.assert_allclose(b.positions, a.positions, atol=1e-6)
        np.testing.assert_allclose(b.deviation, a.deviation, atol=1e-6)
        np.testing.assert_allclose(b.beam_direction, a.beam_direction, atol=1e-12)
        np.testing.assert_allclose(b.tool_offset, a.tool_offset)
        assert (a.kind, a.target) == (b.kind, b.target)
        for c, v in a.columns.items():
            np.testing.assert_array_equal(b.columns[c], v)
        assert b.meta.get("notes") == a.meta.get("notes")


def test_planned_skeleton_needs_flag(tmp_path):
    s = plan_session(TRAVEL, steps=2, tests=("diagonal",))
    write_session(s, tmp_path / "P")
    with pytest.raises(VolcalInputError) as exc:
        read_session(tmp_path / "P")
    assert exc.value.file.endswith("session.toml") and exc.value.row is None
    assert exc.value.column == "deviation_um"
    assert exc.value.message == (
        "no readings yet: the deviation_um column of all 4 measurements is empty (measure "
        "them, `volcal import` or `volcal simulate` first)")
    assert all(m.deviation is None for m in read_session(tmp_path / "P", False).measurements)


@pytest.mark.parametrize("text,row,column,words", [
    ("x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n", 1, "deviation_um", "missing required column"),
    ("x_mm,y_mm,z_in,deviation_um\n0,0,0,0\n1,0,0,0\n", 1, "z_in", "unit"),
    ("x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n1,0,abc,0\n", 3, "z_mm", "not a number"),
    ("x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n1,0,0,nan\n", 3, "deviation_um", "finite"),
    ("x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n1,0,0\n", 3, None, "fields"),
    ("x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n", 2, None, "at least 2"),
    ("x_mm,y_mm,z_mm,deviation_um,direction\n0,0,0,0,+\n1,0,0,0,up\n", 3, "direction", "'+'"),
    ("x_mm,y_mm,z_mm,deviation_um,run\n0,0,0,0,1\n1,0,0,0,1.5\n", 3, "run", "whole"),
    ("x_mm,x_mm,z_mm,deviation_um\n0,0,0,0\n1,0,0,0\n", 1, "x_mm", "duplicate"),
])
def test_csv_validation_names_row_and_column(tmp_path, text, row, column, words):
    p = tmp_path / "m.csv"
    p.write_text(text)
    with pytest.raises(VolcalInputError) as exc:
        read_measurement_csv(p)
    e = exc.value
    assert e.file == str(p) and e.row == row and e.column == column
    assert words in e.message


@pytest.mark.parametrize("edit,key", [
    (("volcal-session/1", "volcal-session/9"), "format"),
    (('chain = "XYFZ"', 'chain = "XYZ"'), "machine.chain"),
    (("x = [0, 800]", "x = [800, 0]"), "machine.travel_mm.x"),
    (('kind = "step_diagonal"', 'kind = "spiral"'), "measurements[0].kind"),
    (('target = "flat_mirror"', 'target = "cat-eye"'), "measurements[0].target"),
    (("beam_direction = [0.715541753, 0.536656315, 0.447213595]", "beam_direction = [0, 0, 0]"),
     "measurements[0].beam_direction"),
    (("tool_offset_mm = [0, 0, 0]", 'tool_offset_mm = [0, "a", 0]'),
     "measurements[0].tool_offset_mm"),
    (('file = "line.csv"', 'file = "nowhere.csv"'), "measurements[1].file"),
    (('id = "line"', 'id = "step-ppp"'), "measurements[1].id"),
])
def test_toml_validation_names_key(tmp_path, edit, key):
    (tmp_path / "session.toml").write_text(EXAMPLE_TOML.replace(*edit))
    (tmp_path / "step-ppp.csv").write_text("x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n1,0,0,0\n"
                                           "1,1,0,0\n1,1,1,0\n")
    (tmp_path / "line.csv").write_text("x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n1,0,0,0\n")
    with pytest.raises(VolcalInputError) as exc:
        read_session(tmp_path)
    assert exc.value.file == str(tmp_path / "session.toml")
    assert exc.value.column == key
