"""`plan --tests direct`: the direct set, its reference groups, programs naming the optic."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from volcal.plan.planner import plan_session
from volcal.program import ProgramOptions, build_steps
from volcal.program.steps import setup_comments
from volcal.session.format import read_session, write_session
from volcal.session.optics import check_references

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def _ids(s):
    return {m.id: m for m in s.measurements}


def test_direct_set_reads_every_error_once_and_the_rolls():
    s = plan_session(TRAVEL, "XYFZ", 6, ("direct",), runs=1)
    ms = _ids(s)
    kinds = [(m.kind, m.target) for m in s.measurements]
    assert kinds.count(("linear", "retroreflector")) == 3
    assert kinds.count(("straightness", "straightness_optics")) == 7  # 6 + Z at a 2nd offset
    assert kinds.count(("angular", "angular_optics")) == 6  # pitch and yaw of each axis
    assert kinds.count(("angular", "level")) == 2  # rolls of the horizontal axes X, Y
    # every component error of ISO 230-1 read directly by one line
    read = set()
    for m in s.measurements:
        a = m.meta["axis"].upper()
        if m.kind == "linear":
            read.add(f"E{a}{a}")
        elif m.kind == "straightness":
            read.add(f"E{m.meta['error_direction'].upper()}{a}")
        else:
            read.add(f"E{m.meta['rotation'].upper()}{a}")
    assert len(read - {"ECZ"}) == 17 and "ECZ" not in read  # Z's roll: by two offsets
    a, b = ms["str-zx"], ms["str-zx-roll"]
    assert a.meta["reference"] == b.meta["reference"] == "xz"
    np.testing.assert_allclose(b.tool_offset - a.tool_offset, [0.0, 150.0, 0.0])
    # squareness: each plane's two straightness lines share one optical square
    groups = {}
    for m in s.measurements:
        if m.kind == "straightness":
            groups.setdefault(m.meta["reference"], set()).add(m.meta["axis"])
    assert groups == {"xy": {"x", "y"}, "xz": {"x", "z"}, "yz": {"y", "z"}}
    check_references(s.measurements, {})  # no error: one square per group


def test_direct_set_mixes_with_diagonals_and_round_trips(tmp_path):
    s = plan_session(TRAVEL, "FXYZ", 4, ("direct", "diagonal"), runs=1)
    write_session(s, tmp_path / "s")
    r = read_session(tmp_path / "s", require_deviation=False)
    assert {m.kind for m in r.measurements} == {"linear", "straightness", "angular", "diagonal"}
    assert len(r.measurements) == 18 + 4


def test_program_headers_name_the_optic_and_its_set_up():
    s = plan_session(TRAVEL, "XYFZ", 4, ("direct",), runs=1)
    ms = _ids(s)
    text = "\n".join(setup_comments(ms["str-yx"]))
    assert "straightness optics" in text and "along +X while Y moves" in text
    assert "reference group 'xy'" in text and "optical square" in text
    assert "differential electronic level" in "\n".join(setup_comments(ms["lev-xa"]))
    assert "rotation about +Y (EBX" in "\n".join(setup_comments(ms["ang-xb"]))
    steps = build_steps(ms["str-zx-roll"], TRAVEL, ProgramOptions())
    read = [st.reading for st in steps.steps if st.kind == "dwell" and st.reading is not None]
    assert read == list(range(ms["str-zx-roll"].n))  # one dwell per reading, in order


def test_cli_plan_direct(tmp_path, monkeypatch, capsys):
    from volcal.cli import main

    out = tmp_path / "p"
    monkeypatch.setattr(sys, "argv", ["volcal", "plan", "--tests", "direct,diagonal", "--runs",
                                      "1", "-o", str(out)])
    try:
        main()
    except SystemExit as exc:
        assert not exc.code, capsys.readouterr().err
    assert (out / "lev-xa.csv").read_text().startswith("x_mm,y_mm,z_mm,angle_urad")
    assert (out / "str-zx-roll.csv").read_text().startswith("x_mm,y_mm,z_mm,deviation_um")


def test_parts_of_the_direct_set():
    from volcal.errors import VolcalInputError
    from volcal.plan.planner import _direct, _Plan  # the builder plan --tests direct:x uses

    s = plan_session(TRAVEL, "XYFZ", 4, ("direct",), runs=1)
    c = _Plan(TRAVEL, "XYFZ", 4, 1, ("xyz",), np.zeros(3), "flat_mirror", 150.0, True, 5.0, {})
    xs = _direct(c, "x")
    assert {m.id for m in xs} == {"lin-x", "str-xy", "str-xz", "lev-xa", "ang-xb", "ang-xc"}
    assert [m.id for m in _direct(c, "level-y")] == ["lev-yb"]
    pair = _direct(c, "roll-z")
    assert [m.id for m in pair] == ["str-zx", "str-zx-roll"]
    assert {m.meta["reference"] for m in pair} == {"z-roll"}
    for bad in ("level-z", "w"):
        with pytest.raises(VolcalInputError, match="direct:"):
            _direct(c, bad)
    assert len(s.measurements) == 18


def test_optic_additions_plan_what_the_candidates_are():
    from volcal.plan.optics import optic_additions, optic_candidates
    from volcal.plan.planner import _direct, _Plan

    c = _Plan(TRAVEL, "XYFZ", 4, 1, ("xyz",), np.zeros(3), "flat_mirror", 150.0, False, 0.0, {})
    cands = optic_candidates(TRAVEL, 4)
    adds = optic_additions()
    assert [lb for lb, _ in adds] == list(cands)
    for (label, (test,)), ms in zip(adds, cands.values(), strict=True):
        planned = _direct(c, test.split(":")[1])
        assert [m.id for m in planned] == [m.id for m in ms], label
        for a, b in zip(planned, ms, strict=True):
            np.testing.assert_allclose(a.positions[: b.n], b.positions)
