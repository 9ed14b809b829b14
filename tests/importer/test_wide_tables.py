"""Wide per-run tables (one column per run, with or without separate direction columns)
import into exactly the session the equivalent long table gives.

The fixtures are written by hand in the layouts of calibration certificates and laser
exports: a target column and one deviation column per run (``Run 1 (um)``...), or per
run and direction (``Run 1 +``/``Run 1 -``, ``1 up``/``1 down``, ``R1 Fwd``/``R1 Rev``),
with ``,`` or ``;`` + decimal comma and a vendor preamble.
"""

from __future__ import annotations

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.importer import import_csv, parse_mapping, read_laser_csv
from volcal.importer.wide import parse_run_header
from volcal.session.format import read_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
TARGETS = [0.0, 97.25, 201.5, 305.0, 400.0]
STYLES = {  # how a header names run r in direction d
    "run-sign": lambda r, d: f"Run {r} {d} (um)",
    "up-down": lambda r, d: f"{r} {'up' if d == '+' else 'down'} [µm]",
    "fwd-rev": lambda r, d: f"R{r} {'Fwd' if d == '+' else 'Rev'} (µm)",
}


def _readings(runs: int, seed: int) -> dict[tuple[int, str, float], float]:
    """Deviation [um] of each (run, direction, target), 3 decimals as exports print them."""
    rng = np.random.default_rng(seed)
    return {(r, d, t): round(0.012 * t + (1.7 if d == "-" else 0.0) + rng.normal(0, 0.3), 3)
            for r in range(1, runs + 1) for d in "+-" for t in TARGETS}


def _long(readings, runs: int) -> str:
    """The equivalent long table, in capture order (ISO 230-2 standard test cycle)."""
    lines = ["Target (mm),Run,Dir,Error (um)"]
    for r in range(1, runs + 1):
        for d, ts in (("+", TARGETS), ("-", TARGETS[::-1])):
            lines += [f"{t:g},{r},{d},{readings[r, d, t]}" for t in ts]
    return "\n".join(lines) + "\n"


def _wide_directions(readings, runs: int, style) -> str:
    """Certificate layout: one row per target, a column per run and direction."""
    heads = [style(r, d) for r in range(1, runs + 1) for d in "+-"]
    lines = ["Target (mm)," + ",".join(heads)]
    for t in TARGETS:
        lines.append(f"{t:g}," + ",".join(f"{readings[r, d, t]}" for r in range(1, runs + 1)
                                          for d in "+-"))
    return "\n".join(lines) + "\n"


def _wide_capture(readings, runs: int) -> str:
    """Export layout: rows in the order of one bidirectional run, a column per run;
    European CSV (``;``, decimal comma) with a preamble."""
    lines = ["Linear measurement;;;;;", "Axis;X;;;;", "",
             "Position (mm);" + ";".join(f"Run {r} (um)" for r in range(1, runs + 1))]
    for d, ts in (("+", TARGETS), ("-", TARGETS[::-1])):
        for t in ts:
            lines.append(f"{t:g};".replace(".", ",")
                         + ";".join(f"{readings[r, d, t]}".replace(".", ",")
                                    for r in range(1, runs + 1)))
    return "\n".join(lines) + "\n"


def _import(tmp_path, text: str, mapping: str, name: str):
    f = tmp_path / f"{name}.csv"
    f.write_text(text, encoding="utf-8")
    r = import_csv(f, parse_mapping(mapping), "X", [0, 100, 50], tmp_path / name, name,
                   travel=TRAVEL)
    return read_session(tmp_path / name).get(name), r.notes


def _same(a, b) -> None:
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.deviation, b.deviation)
    assert list(a.run) == list(b.run)
    assert list(a.direction) == list(b.direction)


@pytest.mark.parametrize("runs", [2, 3, 4, 5])
def test_wide_tables_give_the_long_tables_session(tmp_path, runs):
    readings = _readings(runs, seed=runs)
    long, _ = _import(tmp_path, _long(readings, runs),
                      "target=Target,run=Run,direction=Dir,deviation=Error", "long")
    assert long.n == 2 * runs * len(TARGETS)
    for k, style in enumerate(STYLES.values()):
        pattern = {0: "Run*", 1: "? *", 2: "R*"}[k]
        wide, notes = _import(tmp_path, _wide_directions(readings, runs, style),
                              f"target=Target,deviation={pattern}", f"wide{k}")
        _same(wide, long)
        assert any(n.startswith(f"wide table: {2 * runs} run column(s)") for n in notes)
    capture, notes = _import(tmp_path, _wide_capture(readings, runs),
                             "target=Position,deviation=Run *", "capture")
    _same(capture, long)
    assert "header on line 4, delimiter ';'" in notes


def test_unidirectional_runs_and_readings_in_mm(tmp_path):
    # one pass per run (ISO 230-2 unidirectional), absolute readings in mm:
    # deviation = reading - target (0.0012 mm = 1.2 um)
    text = ("Target [mm],Laser 1 [mm],Laser 2 [mm]\n"
            "0,0.0000,0.0003\n100,100.0012,100.0010\n200,200.0025,200.0021\n")
    m, _ = _import(tmp_path, text, "target=Target,reading=Laser*", "uni")
    np.testing.assert_allclose(m.deviation, [0.0, 1.2, 2.5, 0.3, 1.0, 2.1], atol=1e-9)
    assert list(m.run) == [1, 1, 1, 2, 2, 2] and list(m.direction) == ["+"] * 6
    np.testing.assert_array_equal(m.positions[:, 0], [0, 100, 200] * 2)


@pytest.mark.parametrize("header,expect", [
    ("Run 1 (um)", (1, None)), ("Run 12 + [µm]", (12, "+")), ("Run 3 -", (3, "-")),
    ("2 up", (2, "+")), ("2 down", (2, "-")), ("R4 Fwd (um)", (4, "+")),
    ("R4 Rev (um)", (4, "-")), ("Run-1", (1, None)), ("Run1+", (1, "+")),
    ("Bidirectional run 5 backward", (5, "-")), ("Mean", (None, None))])
def test_run_and_direction_from_the_header(header, expect):
    assert parse_run_header(header) == expect


@pytest.mark.parametrize("text,mapping,msg,row,col", [
    # a run column with text
    ("Target (mm),Run 1 (um),Run 2 (um)\n0,0,0.1\n100,1.2,n/a\n", "target=Target,deviation=Run*",
     "not a number: 'n/a'", 3, "Run 2 (um)"),
    # mm in a um column: 12.5 mm pasted as 12500 um, beyond the 10 mm plausibility limit
    ("Target (mm),Run 1 (um),Run 2 (um)\n0,0,0\n100,1.2,12500\n", "target=Target,deviation=Run*",
     "deviation 12500 um of reading 4 is absurd (> 10000 um): wrong units (mm in a um column?), "
     "or a column that is not the laser's reading?", 3, "Run 2 (um)"),
    # the pattern matches nothing: an unknown column
    ("Target (mm),Pass 1 (um),Pass 2 (um)\n0,0,0\n100,1.2,1.1\n", "target=Target,deviation=Run*",
     "mapped column 'Run*' not in the header line, which holds the other mapped columns "
     "('Target'; header: 'Target (mm),Pass 1 (um),Pass 2 (um)')", 1, "Run*"),
    ("Target (mm),Run 1 (um),Run 2 (um)\n0,0,0\n100,1.2,1.1\n", "target=Pos,deviation=Run*",
     "mapped column 'Pos' not in the header line, which holds the other mapped columns "
     "('Run*'; header: 'Target (mm),Run 1 (um),Run 2 (um)')", 1, "Pos"),
    ("Target (mm),Run 1 (um),Run mean (um)\n0,0,0\n100,1.2,1.1\n",
     "target=Target,deviation=Run*",
     "column matches 'Run*' but names no run number (expected e.g. 'Run 1', 'Run 1 +', "
     "'1 up')", 1, "Run mean (um)"),
    ("Target (mm),Run 1 +,Run 1 -,Run 2\n0,0,0,0\n100,1,2,1\n", "target=Target,deviation=Run*",
     "some run columns name a direction (+/-, up/down, fwd/rev) and others do not: name it "
     "in every run column or in none", 1, "Run 2"),
    ("Target (mm),Run 1 +,Run 1 up\n0,0,0\n100,1,2\n", "target=Target,deviation=Run*",
     "run 1 direction + repeats column 'Run 1 +'", 1, "Run 1 up"),
    ("Target (mm),Run 1 (ft),Run 2 (ft)\n0,0,0\n100,1,2\n", "target=Target,deviation=Run*",
     "the header names the unit 'ft', which volcal does not read; convert to one of mm, um, "
     "nm, in, uin", 1, "Run 1 (ft)"),
])
def test_bad_wide_tables_name_file_row_and_column(tmp_path, text, mapping, msg, row, col):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(VolcalInputError) as e:
        import_csv(f, parse_mapping(mapping), "X", [0, 0, 0], tmp_path / "s", "m", travel=TRAVEL)
    assert e.value.message == msg
    assert (e.value.file, e.value.row, e.value.column) == (str(f), row, col)
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("mapping,msg", [
    ("target=T,deviation=Run*,run=R", "--map: run= does not fit a wide table (the pattern "
     "names one column per run; run and direction come from the column names)"),
    ("target=T,deviation=A|B,direction=D", "--map: direction= does not fit a per-step "
     "step-diagonal table"),
])
def test_mappings_that_do_not_fit_the_layout(mapping, msg):
    with pytest.raises(VolcalInputError) as e:
        parse_mapping(mapping)
    assert e.value.message == msg


def test_wide_table_through_read_laser_csv_keeps_rows_for_messages(tmp_path):
    f = tmp_path / "w.csv"
    f.write_text("T (mm),Run 1 +,Run 1 -\n0,0.0,1.0\n50,0.5,1.5\n")
    t = read_laser_csv(f, parse_mapping("target=T,deviation=Run*"))
    # + pass ascending, - pass descending: rows 2, 3 then 3, 2
    assert t.rows.tolist() == [2, 3, 3, 2]
    assert t.sources == ["Run 1 +", "Run 1 +", "Run 1 -", "Run 1 -"]
    np.testing.assert_array_equal(t.deviation_um, [0.0, 0.5, 1.5, 1.0])


def test_a_per_step_table_is_no_linear_measurement(tmp_path):
    f = tmp_path / "s.csv"
    f.write_text("P,a,b,c\n0,0,,\n10,1,2,3\n")
    with pytest.raises(VolcalInputError) as e:
        import_csv(f, parse_mapping("target=P,deviation=a|b|c"), "X", [0, 0, 0], tmp_path / "s",
                   "m", travel=TRAVEL)
    assert e.value.message == ("--map: a per-step table (deviation=A|B|C) is a step diagonal: "
                               "import it into its planned measurement with --measurement ID")
    assert not (tmp_path / "s").exists()


def test_unit_errors_behind_a_preamble_name_the_header_line(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("Laser export\nMachine;VMC\nTarget (ft);Run 1 (um);Run 2 (um)\n0;0;0\n1;2;3\n")
    with pytest.raises(VolcalInputError) as e:
        read_laser_csv(f, parse_mapping("target=Target,deviation=Run*"))
    assert (e.value.row, e.value.column) == (3, "Target")
    assert e.value.message.startswith("the header names the unit 'ft'")
