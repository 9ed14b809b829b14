"""Direct optics in session files: the issue's keys, letters in either case, refusals."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import TRAVEL, machine
from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session

HEAD = """\
format = "volcal-session/1"
[machine]
name = "VMC-1"
chain = "XYFZ"
{machine_extra}
[machine.travel_mm]
x = [0, 800]
y = [0, 600]
z = [0, 500]
{references}
"""

STR_XY = """
[[measurements]]
id = "str-xy"
kind = "straightness"
axis = "X"
error_direction = "Y"
reference = "xy"
target = "straightness_optics"
tool_offset_mm = [0, 0, 0]
file = "str-xy.csv"
"""

STR_YX = """
[[measurements]]
id = "str-yx"
kind = "straightness"
axis = "y"
error_direction = "x"
reference = "xy"
target = "straightness_optics"
file = "str-yx.csv"
"""

ANG_XB = """
[[measurements]]
id = "ang-xb"
kind = "angular"
axis = "x"
rotation = "B"
target = "angular_optics"
file = "ang-xb.csv"
"""

X_LINE = "x_mm,y_mm,z_mm,{col},run,direction\n0,0,0,0,1,+\n400,0,0,1.5,1,+\n800,0,0,2.5,1,+\n"
Y_LINE = "x_mm,y_mm,z_mm,{col}\n0,0,0,0\n0,300,0,-1.25\n0,600,0,-2\n"


def _write(tmp_path, entries: str, files: dict[str, str], machine_extra: str = "",
           references: str = ""):
    (tmp_path / "session.toml").write_text(
        HEAD.format(machine_extra=machine_extra, references=references) + entries)
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    return tmp_path


def _good(tmp_path, references=""):
    return _write(tmp_path, STR_XY + STR_YX + ANG_XB,
                  {"str-xy.csv": X_LINE.format(col="deviation_um"),
                   "str-yx.csv": Y_LINE.format(col="deviation_um"),
                   "ang-xb.csv": X_LINE.format(col="angle_urad")}, references=references)


def test_issue_example_loads_with_letters_in_either_case(tmp_path):
    s = read_session(_good(tmp_path, "[references.xy]\nsquare_deviation_urad = 1.5\n"
                                     "u_square_urad = 0.8\n"))
    a, b, c = s.measurements
    assert (a.kind, a.target, a.meta["axis"], a.meta["error_direction"]) == (
        "straightness", "straightness_optics", "x", "y")
    assert a.axis == 0 and b.axis == 1 and c.axis == 0
    np.testing.assert_allclose(a.deviation, [0, 1.5, 2.5])
    np.testing.assert_allclose(c.deviation, [0, 1.5, 2.5])  # angle_urad [urad]
    assert c.meta["rotation"] == "b"
    assert list(c.direction) == ["+", "+", "+"]
    assert s.references == {"xy": {"square_deviation_urad": 1.5, "u_square_urad": 0.8}}
    # the group's roles: str-xy first (straight on), str-yx through the square
    assert a.meta["_reference"]["square"] is False
    assert b.meta["_reference"] == {"name": "xy", "first_axis": 0, "square": True,
                                    "square_deviation_urad": 1.5, "u_square_urad": 0.8}


def test_write_read_roundtrip_keeps_keys_and_format(tmp_path):
    s = plan_session(TRAVEL, "XYFZ", steps=4, runs=1, tests=("direct",))
    simulate_session(s, machine("XYFZ", seed=4), SimulationOptions(seed=2))
    s.references = {"xz": {"square_deviation_urad": -2.0, "u_square_urad": 1.0}}
    write_session(s, tmp_path / "s")
    text = (tmp_path / "s" / "session.toml").read_text()
    assert 'format = "volcal-session/1"' in text
    assert "beam_direction" not in text.split('id = "str-xy"')[1].split("[[measurements]]")[0]
    assert (tmp_path / "s" / "ang-xb.csv").read_text().startswith(
        "x_mm,y_mm,z_mm,angle_urad,run,direction")
    r = read_session(tmp_path / "s")
    assert [m.id for m in r.measurements] == [m.id for m in s.measurements]
    assert r.references == s.references
    for a, b in zip(s.measurements, r.measurements, strict=True):
        assert (a.kind, a.target) == (b.kind, b.target)
        np.testing.assert_allclose(a.deviation, b.deviation, atol=1e-6)
        np.testing.assert_allclose(a.tool_offset, b.tool_offset)
        for key in ("axis", "error_direction", "rotation", "reference"):
            assert str(a.meta.get(key, "")).lower() == str(b.meta.get(key, "")).lower()


def _refused(tmp_path, entries, files, key, match, machine_extra=""):
    _write(tmp_path, entries, files, machine_extra)
    with pytest.raises(VolcalInputError, match=match) as exc:
        read_session(tmp_path)
    assert exc.value.column == key, exc.value
    return exc.value


def test_level_about_the_vertical_axis_is_refused(tmp_path):
    entry = ANG_XB.replace('rotation = "B"', 'rotation = "c"').replace("angular_optics", "level")
    e = _refused(tmp_path, entry, {"ang-xb.csv": X_LINE.format(col="angle_urad")},
                 "measurements[0].rotation", "level cannot see a rotation about the vertical")
    assert e.file.endswith("session.toml")
    # with Y vertical the same reading is valid and a level about Y is refused
    _write(tmp_path, entry, {"ang-xb.csv": X_LINE.format(col="angle_urad")},
           'vertical_axis = "Y"')
    assert read_session(tmp_path).measurements[0].meta["rotation"] == "c"
    _refused(tmp_path, entry.replace('rotation = "c"', 'rotation = "b"'),
             {"ang-xb.csv": X_LINE.format(col="angle_urad")}, "measurements[0].rotation",
             r"vertical axis \(Y", 'vertical_axis = "y"')
    _refused(tmp_path, entry, {"ang-xb.csv": X_LINE.format(col="angle_urad")},
             "machine.vertical_axis", "vertical_axis must be", 'vertical_axis = "w"')


def test_angular_optics_about_its_own_beam_is_refused(tmp_path):
    entry = ANG_XB.replace('rotation = "B"', 'rotation = "a"')
    _refused(tmp_path, entry, {"ang-xb.csv": X_LINE.format(col="angle_urad")},
             "measurements[0].rotation", "cannot see the rotation about its beam")
    # a level or roll optics reads it
    for target in ("level", "roll_optics"):
        _write(tmp_path, entry.replace("angular_optics", target),
               {"ang-xb.csv": X_LINE.format(col="angle_urad")})
        assert read_session(tmp_path).measurements[0].target == target


@pytest.mark.parametrize(("change", "key", "match"), [
    (('error_direction = "Y"', 'error_direction = "x"'), "measurements[0].error_direction",
     "equals axis"),
    (('axis = "X"', 'axis = "Z"'), "measurements[0].axis", "move along X"),
    (('axis = "X"', 'axis = "u"'), "measurements[0].axis", "axis must be one of x, y, z"),
    (('error_direction = "Y"\n', ""), "measurements[0].error_direction",
     "missing error_direction"),
    (('target = "straightness_optics"', 'target = "level"'), "measurements[0].target",
     "needs target = one of straightness_optics"),
    (('target = "straightness_optics"', 'target = "flat_mirror"'), "measurements[0].target",
     "needs target"),
    (('reference = "xy"', 'slope_removed = true\nreference = "xy"'),
     "measurements[0].slope_removed", "slope_removed data cannot belong"),
    (('tool_offset_mm = [0, 0, 0]', 'tool_offset_mm = [0, 10, 0]\n'
      'sensor_position_mm = [0, 0, 0]'), "measurements[0].sensor_position_mm", "not both"),
])
def test_bad_straightness_keys_are_refused(tmp_path, change, key, match):
    _refused(tmp_path, STR_XY.replace(*change), {"str-xy.csv": X_LINE.format(col="deviation_um")},
             key, match)


def test_optic_target_with_another_kind_and_wrong_column_are_refused(tmp_path):
    _refused(tmp_path, ANG_XB.replace('kind = "angular"', 'kind = "linear"'),
             {"ang-xb.csv": X_LINE.format(col="deviation_um")}, "measurements[0].target",
             "belongs to kind 'angular'")
    _write(tmp_path, ANG_XB, {"ang-xb.csv": X_LINE.format(col="deviation_um")})
    with pytest.raises(VolcalInputError, match="angle_urad") as exc:
        read_session(tmp_path)
    assert exc.value.file.endswith("ang-xb.csv")


def test_pose_off_the_line_names_row_and_column(tmp_path):
    bad = X_LINE.format(col="deviation_um").replace("400,0,0", "400,0.5,0")
    e = _refused(tmp_path, STR_XY, {"str-xy.csv": bad}, "y_mm", "not on the line")
    assert e.row == 3 and e.file.endswith("str-xy.csv")


def test_reference_group_along_three_axes_is_refused(tmp_path):
    z_line = "x_mm,y_mm,z_mm,deviation_um\n0,0,0,0\n0,0,250,1\n0,0,500,0.5\n"
    str_zx = (STR_YX.replace('"str-yx"', '"str-zx"').replace('axis = "y"', 'axis = "z"')
              .replace("str-yx.csv", "str-zx.csv"))
    _refused(tmp_path, STR_XY + STR_YX + str_zx,
             {"str-xy.csv": X_LINE.format(col="deviation_um"),
              "str-yx.csv": Y_LINE.format(col="deviation_um"), "str-zx.csv": z_line},
             "measurements[2].reference", "neither parallel nor perpendicular|only parallel")


def test_bad_references_table_is_refused(tmp_path):
    _write(tmp_path, STR_XY, {"str-xy.csv": X_LINE.format(col="deviation_um")},
           references="[references.xy]\nu_square_urad = -1\n")
    with pytest.raises(VolcalInputError, match="u_square_urad must be") as exc:
        read_session(tmp_path)
    assert exc.value.column == "references.xy.u_square_urad"


def test_angles_in_the_wrong_unit_are_flagged(tmp_path):
    """mrad (or mm/m) read as urad: the angular test's spread far above the session's other
    angular tests; the message speaks of angles, not lengths."""
    s = plan_session(TRAVEL, "XYFZ", 10, ("direct",), runs=1)
    simulate_session(s, machine("XYFZ", seed=3), SimulationOptions(seed=1))
    write_session(s, tmp_path / "ok")
    assert read_session(tmp_path / "ok").warnings == []
    s.get("ang-xb").deviation = s.get("ang-xb").deviation * 300
    write_session(s, tmp_path / "bad")
    w = read_session(tmp_path / "bad").warnings
    assert len(w) == 1 and w[0].startswith("ang-xb: deviations ~")
    assert "urad/m" in w[0] and "mrad (or mm/m) entered as urad in ang-xb.csv?" in w[0]


def test_target_defaults_to_the_kinds_usual_optic(tmp_path):
    _write(tmp_path, STR_XY.replace('target = "straightness_optics"\n', "")
           + ANG_XB.replace('target = "angular_optics"\n', ""),
           {"str-xy.csv": X_LINE.format(col="deviation_um"),
            "ang-xb.csv": X_LINE.format(col="angle_urad")})
    a, b = read_session(tmp_path).measurements
    assert (a.target, b.target) == ("straightness_optics", "angular_optics")
