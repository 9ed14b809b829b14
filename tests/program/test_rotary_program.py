"""Part programs of rotary tests: LinuxCNC's own interpreter (rs274) runs them.

For a full-circle C axis and a limited A axis, LinuxCNC's standalone interpreter ``rs274``
(Debian ``linuxcnc-uspace``) runs the LinuxCNC and the Fanuc program: the only rapid is
the Z retract in machine coordinates, then the rotary axis turns to the first target, the
operator stop comes before the first dwell, every dwell stands at the planned angle in the
planned order, and every reading is approached from its planned direction (the move
before it turns the way of its ``direction``, past the target by the overrun after each
reversal). The Siemens and Heidenhain programs are replayed by the small parsers below,
written from their manuals' syntax (``G91``/``IC`` increments, ``G4 F`` in a block of
its own, ``CYCL DEF 9``).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from program.replay import RS274, WORK_OFFSET_INCH, run_rs274
from volcal.plan.planner import plan_session
from volcal.program import ProgramOptions, write_programs
from volcal.session.rotary import RotaryAxis

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
NO_RS274 = pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is missing: `make "
                              "linuxcnc-deps` installs Debian's linuxcnc-uspace")
AXES = {"c": RotaryAxis("c", (0.0, 360.0), True), "a": RotaryAxis("a", (-120.0, 30.0), False)}


def _session(axis: str):
    return plan_session(TRAVEL, tests=[f"rotary:{axis}"], steps=5, runs=2,
                        rotary={"axes": [AXES[axis]]})


def _programs(tmp_path, axis, dialect, **kw):
    s = _session(axis)
    opts = ProgramOptions(dwell_s=1.5, safe_z_mm=-10.0, overrun_deg=2.0, **kw)
    folder, warnings = write_programs(s, dialect, tmp_path / dialect, opts)
    (f,) = [p for p in folder.iterdir() if p.name != "volcal-programs.toml"]
    return s.measurements[0], f.read_text(), warnings


def _check_rs274(m, text, fanuc, seconds):
    k = 3 + "abc".index(m.meta["axis"])  # the rotary coordinate in rs274's canon
    cmds = run_rs274(text, strip_fanuc=fanuc, axes=6)
    names = [c[0] for c in cmds]
    trav = [c for c in cmds if c[0] == "STRAIGHT_TRAVERSE"]
    assert len(trav) == 1 and names.index("STRAIGHT_TRAVERSE") == 0  # safe start: Z up
    assert trav[0][1][2] == pytest.approx(-10.0 - WORK_OFFSET_INCH[2] * 25.4, abs=1e-4)
    assert names.index("PROGRAM_STOP") < names.index("DWELL") and names[-1] == "PROGRAM_END"
    pos, prev, dwells, secs, came_from = None, None, [], [], []
    for name, v in cmds:
        if name.startswith("STRAIGHT"):
            prev, pos = pos, v
            assert v[:3] == trav[0][1][:3]  # the linear axes never move after the retract
        elif name == "DWELL":
            dwells.append(pos[k])
            secs.append(v[0])
            came_from.append(prev[k])
    t = np.asarray(m.columns["target_deg"])
    np.testing.assert_allclose(dwells, t, rtol=0, atol=0.5e-3)
    np.testing.assert_allclose(secs, seconds)
    # each reading approached from its planned side
    sign = np.where(np.asarray(m.columns["direction"]) == "+", 1.0, -1.0)
    assert np.all(sign * (np.asarray(dwells) - np.asarray(came_from)) > 0)
    return cmds


@NO_RS274
@pytest.mark.parametrize("axis", ["c", "a"])
def test_rs274_runs_the_linuxcnc_and_fanuc_rotary_programs(tmp_path, axis):
    for dialect in ("linuxcnc", "fanuc"):
        m, text, warnings = _programs(tmp_path, axis, dialect)
        assert warnings == []
        secs = 1.5 if dialect == "linuxcnc" else 1500.0  # Fanuc's P is in ms
        cmds = _check_rs274(m, text, dialect == "fanuc", secs)
        k = 3 + "abc".index(axis)
        angles = [v[k] for n, v in cmds if n.startswith("STRAIGHT")][1:]
        lo, hi = AXES[axis].range_deg
        if axis == "a":  # a limited axis stays inside its range, overruns included
            assert lo <= min(angles) and max(angles) <= hi
        else:  # a full circle: 2 deg past 0 and past 360, both ways
            assert min(angles) == pytest.approx(-2.0) and max(angles) == pytest.approx(362.0)
        assert "G91" in text and text.count("G90") >= 2  # incremental turns, absolute after
        assert "WRAPPED_ROTARY" in text if dialect == "linuxcnc" else "ROLL-OVER" in text


def _replay_siemens(text, axis):
    """SINUMERIK: G91 increments, G4 F.. in a block of its own, the start absolute."""
    pos, dwells, mode = None, [], "G90"
    for line in text.splitlines():
        line = line.split(";")[0].strip()
        if not line:
            continue
        if line.startswith("G4 "):
            assert re.fullmatch(r"G4 F\d+(\.\d+)?", line), line
            dwells.append(pos)
            continue
        mode = "G91" if line == "G91" else "G90" if line.startswith("G90") else mode
        m = re.search(rf"{axis}=DC\((-?[\d.]+)\)|{axis}=(-?[\d.]+)|\b{axis}(-?[\d.]+)", line)
        if m:
            v = float(next(g for g in m.groups() if g is not None))
            pos = v if mode == "G90" else pos + v
    return dwells


def _replay_heidenhain(text, axis):
    """Klartext: numbered blocks, L C+.. absolute, L IC.. incremental, cycle 9 dwell."""
    pos, dwells = None, []
    lines = text.splitlines()
    for i, line in enumerate(lines):
        n, _, block = line.partition(" ")
        assert int(n) == i
        if block.startswith("CYCL DEF 9.1 DWELL"):
            assert lines[i - 1].split(" ", 1)[1] == "CYCL DEF 9.0 DWELL TIME"
            dwells.append(pos)
        m = re.fullmatch(rf"L (I?){axis}([+-][\d.]+) R0 F\d+", block)
        if m:
            pos = float(m.group(2)) + (pos if m.group(1) else 0.0)
    assert lines[0].endswith(f"BEGIN PGM {lines[0].split()[-2]} MM")
    assert lines[-1].split(" ", 1)[1].startswith("END PGM")
    return dwells


@pytest.mark.parametrize("axis", ["c", "a"])
def test_siemens_and_heidenhain_rotary_programs_dwell_at_the_targets(tmp_path, axis):
    for dialect, replay in (("siemens", _replay_siemens), ("heidenhain", _replay_heidenhain)):
        m, text, _ = _programs(tmp_path, axis, dialect)
        dwells = replay(text, axis.upper())
        np.testing.assert_allclose(dwells, m.columns["target_deg"], rtol=0, atol=0.5e-3)
        assert ("DC(" in text) == (axis == "c" and dialect == "siemens")
        assert "M126" in text if dialect == "heidenhain" else "MD30455" in text


def test_a_short_limited_range_shortens_the_overrun_with_a_warning(tmp_path):
    s = plan_session(TRAVEL, tests=["rotary:b"], steps=3, runs=1,
                     rotary={"axes": [RotaryAxis("b", (0.0, 90.0), False)],
                             "targets_deg": [0.5, 30.2, 61.7, 89.5]})
    _, warnings = write_programs(s, "linuxcnc", tmp_path / "p", ProgramOptions())
    assert warnings and "overrun shortened by the range of axis B" in warnings[0]


@NO_RS274
@pytest.mark.parametrize("axis", ["c", "a"])
def test_the_operator_stop_stands_at_the_first_readings_approach_point(tmp_path, axis):
    """Session 21: the stop stood at the first target (reached from wherever the axis was);
    a capture reading a control without program state took it for the first dwell, or
    refused it as reached from the wrong side. Now the axis turns on past the first target
    by the overrun before the stop, and the first reading is approached from its side."""
    for dialect in ("linuxcnc", "fanuc"):
        m, text, _ = _programs(tmp_path, axis, dialect)
        k = 3 + "abc".index(axis)
        pos = None
        for name, v in run_rs274(text, strip_fanuc=dialect == "fanuc", axes=6):
            if name.startswith("STRAIGHT"):
                pos = v
            elif name == "PROGRAM_STOP":
                break
        t0 = float(m.columns["target_deg"][0])
        sign = 1.0 if m.columns["direction"][0] == "+" else -1.0
        assert pos[k] == pytest.approx(t0 - sign * 2.0, abs=1e-6), (dialect, pos[k], t0)
