"""The ISO 230-1 name table against the standard's naming rule and against the exact model.

ISO 230-1:2012, 3.4: ``E`` + direction of the translation (X, Y, Z) or axis of the rotation
(A, B, C = about X, Y, Z) + moving axis. The roll of an axis is its rotation about its own
direction, the tilts its rotations about the two axes across the motion. The checks below
derive every entry from that rule (not from the table's own code) and from the kinematic
model: a single error function switched on moves the tool along, or turns it about, the
axis the table says.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from volcal.model import names
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import exact_pose, volumetric_error_exact
from volcal.model.names import (
    COMPONENT_NAMES,
    ERROR_TABLE,
    ROLL_NAMES,
    SQUARENESS_NAMES,
    TILT_NAMES,
    describe,
    info,
    kind,
    names_of_kind,
)

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
DOCS = Path(__file__).resolve().parents[2] / "docs" / "conventions.md"


def _iso_rule(name: str) -> tuple[str, str, str]:
    """(kind, unit, direction) from the letters alone, per ISO 230-1 3.4."""
    d, k = name[1], name[2]
    if d in "XYZ":
        return ("positioning" if d == k else "straightness"), "um", d
    about = "XYZ"["ABC".index(d)]
    return ("roll" if about == k else "tilt"), "urad", about


def test_the_table_holds_the_21_names_in_model_order():
    assert tuple(ERROR_TABLE) == COMPONENT_NAMES + SQUARENESS_NAMES
    assert len(ERROR_TABLE) == 21
    counts = {k: len(names_of_kind(k)) for k in names.KINDS}
    assert counts == {"positioning": 3, "straightness": 6, "roll": 3, "tilt": 6,
                      "squareness": 3}


@pytest.mark.parametrize("name", COMPONENT_NAMES)
def test_component_entry_follows_the_iso_naming_rule(name):
    e = info(name)
    assert (e.kind, e.unit, e.direction) == _iso_rule(name)
    assert e.axis == name[2] and e.reference == ""
    assert kind(name) == e.kind and names.unit(name) == e.unit
    assert e.unit_symbol == {"um": "µm", "urad": "µrad"}[e.unit]


def test_rolls_tilts_and_straightnesses_per_axis():
    # each axis: its roll turns it about itself; its tilts about the two other axes
    assert ROLL_NAMES == ("EAX", "EBY", "ECZ")
    assert names.POSITIONING_NAMES == ("EXX", "EYY", "EZZ")
    assert names.STRAIGHTNESS_NAMES == ("EYX", "EZX", "EXY", "EZY", "EXZ", "EYZ")
    tilts = {k: {n for n in TILT_NAMES if n[2] == k} for k in "XYZ"}
    assert tilts == {"X": {"EBX", "ECX"}, "Y": {"EAY", "ECY"}, "Z": {"EAZ", "EBZ"}}
    assert [describe(n) for n in ("EXY", "EYY", "EAY", "EBY", "EAZ", "ECZ")] == [
        "EXY (straightness of Y in X)", "EYY (positioning of Y)",
        "EAY (tilt of Y about X; pitch)", "EBY (roll of Y)", "EAZ (tilt of Z about X)",
        "ECZ (roll of Z)"]
    assert info("EYX").iso_term == "straightness error motion of the X-axis in the Y-axis direction"
    assert info("EAZ").iso_term == "tilt error motion of the Z-axis around the X-axis"


@pytest.mark.parametrize("name", TILT_NAMES)
def test_pitch_and_yaw_only_for_the_horizontal_axes(name):
    """Z vertical: pitch about the horizontal axis across the motion, yaw about Z; a
    vertical axis has neither, only tilts."""
    e = info(name)
    if e.axis == "Z":
        assert e.conventional == ""
        assert e.label == f"tilt of Z about {e.direction}"
    else:
        expected = "yaw" if e.direction == "Z" else "pitch"
        assert e.conventional == expected
        assert e.label == f"tilt of {e.axis} about {e.direction}; {expected}"


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ"])
@pytest.mark.parametrize("name", COMPONENT_NAMES)
def test_each_function_acts_along_or_about_the_axis_the_table_names(name, chain):
    """Exact model: a translation moves the tool along ``direction``; a rotation turns
    it about ``direction``; the roll leaves a tool point on the moving axis' own line in
    place, a tilt moves it."""
    e = info(name)
    k = "XYZ".index(e.axis)
    d = "XYZ".index(e.direction)
    m = MachineErrors.zero(chain, TRAVEL)
    m.values[k][:, COMPONENT_NAMES.index(name) % 6] = 50.0
    q = np.zeros((1, 3))
    if e.unit == "um":
        err = volumetric_error_exact(m, q)[0]
        np.testing.assert_allclose(err, 50.0 * np.eye(3)[d], atol=1e-9)
        return
    _, R = exact_pose(m, q)
    w = np.array([R[0, 2, 1] - R[0, 1, 2], R[0, 0, 2] - R[0, 2, 0],
                  R[0, 1, 0] - R[0, 0, 1]]) / 2  # small rotation vector [rad]
    np.testing.assert_allclose(w / np.linalg.norm(w), np.eye(3)[d], atol=1e-9)
    along = volumetric_error_exact(m, q, 200.0 * np.eye(3)[k])[0]  # tool on the axis' line
    if e.kind == "roll":
        assert np.abs(along).max() < 1e-9
    else:
        assert np.abs(along).max() == pytest.approx(50e-6 * 200.0 * 1e3, rel=1e-6)


@pytest.mark.parametrize("name", SQUARENESS_NAMES)
def test_squareness_entry_against_the_model(name):
    """A squareness error tilts its axis about ``direction`` towards its reference axis."""
    e = info(name)
    assert (e.kind, e.unit) == ("squareness", "urad")
    assert e.meaning == f"squareness of {e.axis} to {e.reference}"
    assert {e.axis, e.reference, e.direction} == {"X", "Y", "Z"}
    m = MachineErrors.zero("XYFZ", TRAVEL)
    m.squareness[SQUARENESS_NAMES.index(name)] = 100.0
    q = np.zeros((1, 3))
    q[0, "XYZ".index(e.axis)] = 400.0
    err = volumetric_error_exact(m, q)[0]
    ref = "XYZ".index(e.reference)
    assert abs(err[ref]) == pytest.approx(100e-6 * 400.0 * 1e3, rel=1e-4)
    assert abs(err[ref]) > 1e3 * np.abs(np.delete(err, ref)).max()


def test_unknown_name_and_kind_are_refused_clearly():
    with pytest.raises(KeyError, match="not an ISO 230-1 error name"):
        info("EQX")
    with pytest.raises(ValueError, match="kind must be one of"):
        names_of_kind("pitch")
    assert info("eby") is ERROR_TABLE["EBY"]


def test_conventions_doc_shows_the_table_of_the_code():
    text = DOCS.read_text(encoding="utf-8")
    begin = text.index("<!-- generated by volcal.model.names.markdown_table()")
    table = text[text.index("\n", begin) + 1:text.index("<!-- end of generated table -->")]
    assert table == names.markdown_table()
    assert all(f"| {n} |" in table for n in ERROR_TABLE)
