import tomllib

import numpy as np
import pytest

from program.replay import EVENTS, REPLAY, RS274, WORK_OFFSET_INCH, run_rs274
from volcal.errors import VolcalInputError
from volcal.plan.geometry import linear_test, step_diagonal_test
from volcal.plan.planner import plan_session
from volcal.program import ProgramOptions, build_steps, write_programs
from volcal.program.dialects import DIALECTS
from volcal.session.format import Measurement, Session, read_session, write_session
from volcal_cli_helpers import volcal_process

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def _inner_session() -> Session:
    """Linear targets 10 mm inside the travel (room for the overrun) and a step diagonal."""
    inner = TRAVEL + np.array([10.0, -10.0])
    g = linear_test("Y", inner, 8, [100.0, 0.0, 250.0], runs=3, bidirectional=True)
    lin = Measurement("lin-y", "linear", "retroreflector", g.positions, None, g.beam_direction,
                      np.array([0.0, 0.0, 120.0]), columns={"run": g.run, "direction": g.direction},
                      meta={"axis": "Y", "notes": "Abbe offset 120 mm"})
    sd = step_diagonal_test("ppp", TRAVEL, 5, "yzx")
    step = Measurement("step", "step_diagonal", "flat_mirror", sd.positions, None,
                       sd.beam_direction, meta={"axis_order": "yzx"})
    return Session("VMC", "XYFZ", TRAVEL, [lin, step])


NO_RS274 = pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is missing: `make "
                              "linuxcnc-deps` installs Debian's linuxcnc-uspace")


def _need(dialect):
    if dialect == "linuxcnc" and RS274 is None:
        pytest.skip("LinuxCNC's rs274 is missing: `make linuxcnc-deps` installs linuxcnc-uspace")


@pytest.mark.parametrize("dialect", DIALECTS)
def test_replayed_dwells_are_the_planned_poses_in_order(tmp_path, dialect):
    _need(dialect)
    s = plan_session(TRAVEL, "XYFZ", 4, ["step-diagonal", "diagonal", "linear"], 2)
    write_session(s, tmp_path / "s")
    s = read_session(tmp_path / "s", require_deviation=False)
    folder, _ = write_programs(s, dialect, tmp_path / "p", ProgramOptions(dwell_s=2.5))
    index = tomllib.loads((folder / "volcal-programs.toml").read_text())
    assert [p["measurement"] for p in index["programs"]] == [m.id for m in s.measurements]
    for entry, m in zip(index["programs"], s.measurements, strict=True):
        dwell, secs, _ = REPLAY[dialect]((folder / entry["file"]).read_text())
        assert dwell.shape == m.positions.shape
        # 800/4, 600/4, 500/4 are whole millimetres: exact poses
        np.testing.assert_array_equal(dwell, m.positions)
        np.testing.assert_array_equal(secs, 2.5)


@pytest.mark.parametrize("dialect", DIALECTS)
def test_iso230_2_approach_and_overrun(tmp_path, dialect):
    _need(dialect)
    s = _inner_session()
    folder, warnings = write_programs(s, dialect, tmp_path / "p", ProgramOptions(overrun_mm=4.0))
    assert warnings == []
    files = sorted(folder.glob("*" + {"fanuc": ".nc", "siemens": ".MPF", "heidenhain": ".H",
                                      "linuxcnc": ".ngc"}[dialect]))
    text = next(f for f in files if f.stem.upper() == "LIN_Y").read_text()
    dwell, _, moves = REPLAY[dialect](text)
    lin = s.measurements[0]
    np.testing.assert_array_equal(dwell, lin.positions)
    # the safe start: retract, X Y, Z down to the approach point; the readings follow it
    np.testing.assert_array_equal(moves[1][:2], (lin.positions[0] - [0.0, 4.0, 0.0])[:2])
    moves = moves[2:]
    # every dwell pose is reached moving in its ISO 230-2 direction along Y
    k, last = 1, -1
    for i, p in enumerate(lin.positions):
        j = next(t for t in range(last + 1, len(moves)) if np.array_equal(moves[t], p))
        assert j >= 1
        before = moves[j - 1]
        sign = 1.0 if lin.direction[i] == "+" else -1.0
        assert sign * (p[k] - before[k]) > 0, f"reading {i} approached from the wrong side"
        np.testing.assert_array_equal(np.delete(before, k), np.delete(p, k))
        last = j
    # the start pose is the approach 4 mm below the first target, then the target itself
    np.testing.assert_array_equal(moves[0], lin.positions[0] - [0.0, 4.0, 0.0])
    np.testing.assert_array_equal(moves[1], lin.positions[0])
    # 3 runs: one approach, an overrun at each top (3) and at the bottom between runs (2)
    extra = len(moves) - lin.n
    assert extra == 1 + 3 + 2


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is not installed "
                    "(make linuxcnc-deps)")
def test_direct_optics_reverse_with_the_overrun_in_rs274(tmp_path):
    """Session 20: a direct optic's program dwelt twice at each reversal without a move
    (its runs have directions, its kind is not ISO 230-2 bidirectional). LinuxCNC's
    interpreter runs it now: every dwell at its planned pose, reached from its side."""
    s = plan_session(TRAVEL, "XYFZ", 3, ["direct:x"], 2)
    write_session(s, tmp_path / "s")
    s = read_session(tmp_path / "s", require_deviation=False)
    folder, _ = write_programs(s, "linuxcnc", tmp_path / "p", ProgramOptions(dwell_s=1.0))
    m = s.get("str-xy")
    dwell, _, moves = REPLAY["linuxcnc"]((folder / "str_xy.ngc").read_text())
    np.testing.assert_array_equal(dwell, m.positions)
    moves = moves[2:]  # after the safe start
    last = -1
    for i, p in enumerate(m.positions):
        j = next(t for t in range(last + 1, len(moves)) if np.array_equal(moves[t], p))
        sign = 1.0 if m.direction[i] == "+" else -1.0
        assert j >= 1 and sign * (p[0] - moves[j - 1][0]) > 0, f"reading {i} from the wrong side"
        last = j


def test_hand_computed_fanuc_block(tmp_path):
    m = Measurement("t", "diagonal", "retroreflector", [[0, 0, 0], [266.6666667, 12.5, -0.0004]],
                    None, [1, 0, 0])
    built = build_steps(m, np.array([[0, 800], [-1, 600], [-1, 500]]), ProgramOptions())
    s = Session("m", "XYFZ", [[0, 800], [-1, 600], [-1, 500]], [m])
    folder, warnings = write_programs(s, "fanuc", tmp_path / "p")
    text = (folder / "t.nc").read_text()
    assert "G01 X266.667 Y12.500 Z0.000 F2000." in text
    # the first pose is the start positioning (X Y, then Z), never a 3-axis move
    assert "G53 G00 Z0.000\nG01 X0.000 Y0.000 F2000.\nG01 Z0.000\n" in text
    assert "G01 X0.000 Y0.000 Z0.000" not in text
    assert text.count("G04 P4000") == 2
    assert any("rounded to 0.001 mm" in w for w in warnings)
    assert [st.reading for st in built.steps if st.kind == "dwell"] == [0, 1]


def test_pose_outside_travel_names_file_and_row(tmp_path):
    m = Measurement("t", "diagonal", "retroreflector", [[0, 0, 0], [10, 700, 0]], None, [0, 1, 0])
    s = Session("m", "XYFZ", TRAVEL, [m])
    with pytest.raises(VolcalInputError) as e:
        write_programs(s, "siemens", tmp_path / "p")
    assert e.value.row == 3 and e.value.column == "y_mm" and e.value.file == "t.csv"
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize("opts", [dict(feed=0.0), dict(feed=20000.0), dict(dwell_s=-1.0),
                                  dict(dwell_s=float("nan")), dict(overrun_mm=-1.0)])
def test_unsafe_options_are_refused(tmp_path, opts):
    with pytest.raises(VolcalInputError):
        write_programs(_inner_session(), "fanuc", tmp_path / "p", ProgramOptions(**opts))
    assert not (tmp_path / "p").exists()


def test_does_not_replace_a_foreign_folder(tmp_path):
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "thesis.tex").write_text("precious")
    with pytest.raises(VolcalInputError):
        write_programs(_inner_session(), "fanuc", tmp_path / "p")
    assert (tmp_path / "p" / "thesis.tex").read_text() == "precious"
    # a previous program folder is replaced
    write_programs(_inner_session(), "fanuc", tmp_path / "q")
    write_programs(_inner_session(), "heidenhain", tmp_path / "q")
    assert sorted(f.suffix for f in (tmp_path / "q").iterdir()) == [".H", ".H", ".toml"]


def test_comments_name_test_and_optics(tmp_path):
    folder, _ = write_programs(_inner_session(), "siemens", tmp_path / "p")
    text = (folder / "LIN_Y.MPF").read_text()
    assert "; volcal measurement lin-y: linear test, 54 readings" in text
    assert "retroreflector on the tool at offset [0, 0, 120] mm" in text
    assert "notes: Abbe offset 120 mm" in text
    assert "; run 3" in text


def _cli(*args):
    """``volcal *args`` in-process (VOLCAL_TEST_SUBPROCESS=1: in a process of its own)."""
    return volcal_process(*args)


def test_cli_writes_programs_and_reports_bad_input(tmp_path):
    write_session(_inner_session(), tmp_path / "s")
    r = _cli("program", str(tmp_path / "s"), "--dialect", "heidenhain", "-o", str(tmp_path / "p"),
             "--dwell-s", "3", "--feed", "1500")
    assert r.returncode == 0, r.stderr
    dwell, secs, _ = REPLAY["heidenhain"]((tmp_path / "p" / "STEP.H").read_text())
    np.testing.assert_array_equal(dwell, _inner_session().measurements[1].positions)
    assert set(secs) == {3.0}
    assert " F1500" in (tmp_path / "p" / "STEP.H").read_text()
    r = _cli("program", str(tmp_path / "s"), "--dialect", "okuma", "-o", str(tmp_path / "x"))
    assert r.returncode == 2 and "Traceback" not in r.stderr and "okuma" in r.stderr


def _default_session(tmp_path):
    s = plan_session(TRAVEL, "XYFZ", 4, ["step-diagonal", "diagonal", "linear"], 2)
    write_session(s, tmp_path / "s")
    return read_session(tmp_path / "s", require_deviation=False)


@pytest.mark.parametrize("dialect", ["fanuc", "siemens", "heidenhain"])
def test_program_shape_retract_start_stop_readings_end(tmp_path, dialect):
    s = _default_session(tmp_path)
    folder, _ = write_programs(s, dialect, tmp_path / "p")
    for entry in tomllib.loads((folder / "volcal-programs.toml").read_text())["programs"]:
        _, _, moves = REPLAY[dialect]((folder / entry["file"]).read_text())
        ev = list(EVENTS)
        # one retract first, then X Y, then Z down, one operator stop before any reading
        assert ev[:4] == ["retract", "move", "move", "stop"], ev[:6]
        assert ev.count("stop") == 1 and ev.count("retract") == 1 and ev[-1] == "end"
        # X Y first (Z unknown: still at the retract height), then only Z changes
        assert np.isnan(moves[1][2]) or dialect == "fanuc"
        # no block moves to where the machine already stands
        full = moves[2:]
        assert not np.any(np.all(np.diff(full, axis=0) == 0.0, axis=1))


@pytest.mark.parametrize("dialect", DIALECTS)
def test_no_repeated_motion_block_at_the_reversal(tmp_path, dialect):
    """Targets on the travel limits: the reversal has no room for an overrun, and the
    return reading is taken without writing the same move twice."""
    s = plan_session(TRAVEL, "XYFZ", 4, ["linear"], 2, iso_spacing=False, linear_margin_mm=0.0)
    folder, warnings = write_programs(s, dialect, tmp_path / "p")
    assert any("have no overrun" in w for w in warnings)
    for f in folder.iterdir():
        if f.suffix == ".toml":
            continue
        blocks = [ln.split(" ", 1)[1] if dialect == "heidenhain" else ln
                  for ln in f.read_text().splitlines()]
        motion = [b for b in blocks if b.startswith(("G01 ", "G1 ", "G53 ", "G0 ", "L "))]
        assert all(a != b for a, b in zip(motion, motion[1:], strict=False)), f.name


def _rs274_check(text, m, seconds, safe_z=0.0, fanuc=False):
    """LinuxCNC's interpreter: every dwell at the planned pose, in order, and the start."""
    cmds = run_rs274(text, strip_fanuc=fanuc)
    names = [c[0] for c in cmds]
    off_mm = np.array(WORK_OFFSET_INCH) * 25.4
    # the only rapid is the retract to the machine-coordinate safe Z (work z = safe - offset)
    trav = [c for c in cmds if c[0] == "STRAIGHT_TRAVERSE"]
    assert len(trav) == 1 and names.index("STRAIGHT_TRAVERSE") == 0
    assert trav[0][1][2] == pytest.approx(safe_z - off_mm[2], abs=1e-4)
    # then X Y at that height, then Z down
    xy, zdown = cmds[1][1], cmds[2][1]
    assert cmds[1][0] == cmds[2][0] == "STRAIGHT_FEED"
    assert xy[2] == pytest.approx(trav[0][1][2], abs=1e-4)
    assert zdown[:2] == xy[:2]
    # the operator stop comes before the first dwell, the program ends once
    assert names.index("PROGRAM_STOP") < names.index("DWELL")
    assert names.count("PROGRAM_STOP") == 1 and names[-1] == "PROGRAM_END"
    pos, dwells, secs = None, [], []
    for name, v in cmds:
        if name.startswith("STRAIGHT"):
            pos = v
        elif name == "DWELL":
            dwells.append(pos)
            secs.append(v[0])
    np.testing.assert_allclose(np.array(dwells), m.positions, rtol=0, atol=0.5e-4)
    np.testing.assert_allclose(secs, seconds)
    return names


@NO_RS274
def test_rs274_runs_the_linuxcnc_and_fanuc_programs_of_the_default_plan(tmp_path):
    """The default plan (ISO 230-2 targets at 0.001 mm, overrun room) through LinuxCNC's
    interpreter: dwell poses in order, LinuxCNC dwells in seconds; the Fanuc program runs
    unchanged (but for its O number) and dwells 1000x longer there (Fanuc's P is in ms),
    so only its poses are compared."""
    s = plan_session(TRAVEL, "XYFZ", 4, ["step-diagonal", "diagonal", "linear"], 2)
    write_session(s, tmp_path / "s")
    s = read_session(tmp_path / "s", require_deviation=False)
    opts = ProgramOptions(dwell_s=2.5, safe_z_mm=-12.5)
    for dialect in ("linuxcnc", "fanuc"):
        folder, _ = write_programs(s, dialect, tmp_path / dialect, opts)
        index = tomllib.loads((folder / "volcal-programs.toml").read_text())["programs"]
        for entry, m in zip(index, s.measurements, strict=True):
            text = (folder / entry["file"]).read_text()
            names = _rs274_check(text, m, 2.5 if dialect == "linuxcnc" else 2500.0, -12.5,
                                 fanuc=dialect == "fanuc")
            if dialect == "linuxcnc":
                assert names.index("MESSAGE") < names.index("PROGRAM_STOP")


@NO_RS274
def test_rs274_rejects_what_linuxcnc_rejects():
    """The runner is not a rubber stamp: an unknown word fails."""
    with pytest.raises(AssertionError, match="rs274 refused"):
        run_rs274("G21\nG1 X1 Q\nM2\n")
