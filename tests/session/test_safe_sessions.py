"""Partial sessions, missed captures, self-validating types, travel/geometry checks,
plausibility warnings: each case with the exact message a user reads."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest

from conftest import TRAVEL, machine
from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import KINDS, TARGETS, Measurement, Session, read_session, write_session
from volcal.session.plausibility import plausibility_warnings


@pytest.fixture(scope="module")
def measured(tmp_path_factory) -> Path:
    s = plan_session(TRAVEL, "XYFZ", steps=3, runs=2)
    simulate_session(s, machine("XYFZ", seed=4), SimulationOptions(seed=1))
    return write_session(s, tmp_path_factory.mktemp("m") / "S")


@pytest.fixture
def S(measured, tmp_path) -> Path:
    d = tmp_path / "S"
    shutil.copytree(measured, d)
    return d


def _rows(p: Path) -> list[list[str]]:
    return list(csv.reader(p.open()))


def _write(p: Path, rows: list[list[str]]) -> None:
    with p.open("w") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)


def set_cell(p: Path, row: int, col: str, value: str) -> None:
    r = _rows(p)
    r[row - 1][r[0].index(col)] = value
    _write(p, r)


def clear(p: Path) -> None:
    r = _rows(p)
    j = r[0].index("deviation_um")
    for x in r[1:]:
        x[j] = ""
    _write(p, r)


def _msg(exc: pytest.ExceptionInfo) -> tuple[str, int | None, str | None, str]:
    e = exc.value
    return Path(e.file).name if e.file else "", e.row, e.column, e.message


# --------------------------------------------------------------------------- partial sessions

def test_partial_session_works_on_the_measured_subset(S):
    clear(S / "diag-ppp.csv")
    clear(S / "linear-z3.csv")
    s = read_session(S)
    assert [m.id for m in s.unmeasured] == ["diag-ppp", "linear-z3"]
    assert {m.id for m in s.measurements} & {"diag-ppp", "linear-z3"} == set()
    assert len(s.measurements) == 15
    assert s.notes[0] == "no readings yet: diag-ppp, linear-z3 (working on the 15 measured)"
    # read without readings required: every measurement, nothing set aside
    full = read_session(S, require_deviation=False)
    assert len(full.measurements) == 17 and full.unmeasured == [] and full.notes == []


def test_no_readings_yet(tmp_path):
    write_session(plan_session(TRAVEL, steps=2, tests=("linear",), runs=2), tmp_path / "P")
    with pytest.raises(VolcalInputError) as exc:
        read_session(tmp_path / "P")
    assert _msg(exc) == ("session.toml", None, "deviation_um",
                         "no readings yet: the deviation_um column of all 9 measurements is "
                         "empty (measure them, `volcal import` or `volcal simulate` first)")


def test_some_rows_empty_is_an_error_naming_the_row(S):
    set_cell(S / "diag-npp.csv", 4, "deviation_um", "")
    with pytest.raises(VolcalInputError) as exc:
        read_session(S)
    assert _msg(exc) == ("diag-npp.csv", 4, "deviation_um",
                         "missing deviation: write the reading, or 'missed' for a missed "
                         "capture (docs/formats.md)")


@pytest.mark.parametrize("how", ["marker", "status"])
def test_missed_capture_is_skipped_with_a_note(S, how):
    before = read_session(S).get("step-ppp")
    if how == "marker":
        set_cell(S / "step-ppp.csv", 5, "deviation_um", "Missed")
    else:
        r = _rows(S / "step-ppp.csv")
        r[0].append("status")
        for i, x in enumerate(r[1:]):
            x.append("missed" if i + 2 == 5 else ("ok" if i % 2 else ""))
        _write(S / "step-ppp.csv", r)
    s = read_session(S)
    m = s.get("step-ppp")
    assert m.n == before.n - 1
    keep = np.arange(before.n) != 3
    np.testing.assert_array_equal(m.positions, before.positions[keep])
    np.testing.assert_array_equal(m.deviation, before.deviation[keep])
    assert m.rows.tolist() == [r for r in range(2, before.n + 2) if r != 5]
    assert s.notes == [f"{S / 'step-ppp.csv'}: missed capture skipped (row 5)"]
    # read as planned (simulate): the row stays, NaN, and is written back as 'missed'
    p = read_session(S, require_deviation=False).get("step-ppp")
    assert p.n == before.n and np.isnan(p.deviation[3])
    assert "missed" in p.to_csv().splitlines()[4].split(",")


def test_first_row_cannot_be_missed(S):
    set_cell(S / "diag-pnp.csv", 2, "deviation_um", "missed")
    with pytest.raises(VolcalInputError) as exc:
        read_session(S)
    file, row, column, message = _msg(exc)
    assert (file, row, column) == ("diag-pnp.csv", 2, "deviation_um")
    assert message.startswith("the first row is the reference of the readings (deviation 0 "
                              "by definition): it cannot be a missed capture; capture the "
                              "measurement again (volcal capture SESSION --measurement ID "
                              "--again")


def test_all_rows_missed_is_not_measured(S):
    r = _rows(S / "diag-ppn.csv")
    for x in r[1:]:
        x[3] = "missed"
    _write(S / "diag-ppn.csv", r)
    assert read_session(S).unmeasured_ids == ["diag-ppn"]


# --------------------------------------------------------------------------- absurd values

@pytest.mark.parametrize("col,value,words", [
    ("deviation_um", "1e308", "absurd value 1e308: |value| > 10000 um"),
    ("deviation_um", "-10000.5", "absurd value -10000.5: |value| > 10000 um"),
    ("x_mm", "1e308", "absurd value 1e308: |value| > 1e+06 mm"),
    ("deviation_um", "inf", "not a finite number: 'inf'"),
])
def test_absurd_values(S, col, value, words):
    set_cell(S / "diag-npp.csv", 3, col, value)
    with pytest.raises(VolcalInputError) as exc:
        read_session(S)
    assert _msg(exc) == ("diag-npp.csv", 3, col, words)


def test_pose_outside_travel(S):
    set_cell(S / "step-ppp.csv", 4, "x_mm", "99999")
    with pytest.raises(VolcalInputError) as exc:
        read_session(S)
    assert _msg(exc) == ("step-ppp.csv", 4, "x_mm",
                         "x = 99999 mm is outside the travel 0..800 mm of session.toml "
                         "(margin 16 mm)")


def test_overrun_within_the_margin_is_accepted(S):
    # 10 mm before the start of X: inside the margin max(2 mm, 2 % of 800 mm) = 16 mm
    set_cell(S / "linear-x1.csv", 2, "x_mm", "-10")
    assert read_session(S).get("linear-x1").positions[0, 0] == -10


@pytest.mark.parametrize("file,row,col,value,message", [
    ("linear-y2.csv", 4, "z_mm", "7", "pose not on the line of this linear test (from row 2 "
     "along [0, 1, 0]): z = 7 mm, expected 0 mm"),
    # beam (-800, 600, 500)/1118.03; row 3 = (533.33, 200, 166.67) with y -> 150: the foot of
    # the perpendicular on the diagonal has y = ((-266.67, 150, 166.67) . n) n_y = 185.6
    ("diag-npp.csv", 3, "y_mm", "150", "pose not on the diagonal of this test (from row 2 "
     "along [-0.7155, 0.5367, 0.4472]): y = 150 mm, expected 185.6 mm"),
    ("step-pnp.csv", 6, "x_mm", "300", "step-diagonal pose does not follow its stepping "
     "pattern (single-axis moves in the order xyz, equal increments): x = 300 mm, expected "
     "533.333 mm"),
])
def test_geometry(S, file, row, col, value, message):
    set_cell(S / file, row, col, value)
    with pytest.raises(VolcalInputError) as exc:
        read_session(S)
    assert _msg(exc) == (file, row, col, message)


def test_step_diagonal_row_count(S):
    r = _rows(S / "step-ppn.csv")
    _write(S / "step-ppn.csv", r[:-1])
    with pytest.raises(VolcalInputError) as exc:
        read_session(S)
    assert _msg(exc) == ("step-ppn.csv", 10, None, "a step diagonal with axis order xyz has "
                         "1 + 3N rows (one reading after each single-axis move); found 9")


# --------------------------------------------------------------------------- types

def _m(**kw):
    args = dict(id="m", kind="linear", target="retroreflector", positions=[[0, 0, 0], [1, 0, 0]],
                deviation=None, beam_direction=[1, 0, 0])
    args.update(kw)
    return Measurement(**args)


@pytest.mark.parametrize("kw,message", [
    ({"target": "flat-mirror"}, "measurement 'm': unknown target 'flat-mirror': expected one of "
     "flat_mirror, retroreflector, retroreflector_mirror, cat_eye, straightness_optics, "
     "angular_optics, level, roll_optics, rotary_calibrator, index_table, touch_probe, "
     "r_test_nest"),
    ({"kind": "circle"}, "measurement 'm': unknown kind 'circle': expected one of linear, "
     "diagonal, step_diagonal, multilateration, straightness, angular, rotary, "
     "probe_sphere, r_test"),
    ({"id": ""}, "measurement id must be a non-empty string, got ''"),
    ({"positions": [[0, 0], [1, 0]]}, "measurement 'm': positions [mm]: expected shape (n, 3), "
     "got (2, 2)"),
    ({"positions": [[0, 0, 0], [np.nan, 0, 0]]}, "measurement 'm': positions [mm]: values must "
     "be finite"),
    ({"beam_direction": [0, 0, 0]}, "measurement 'm': beam_direction must not be the zero "
     "vector"),
    ({"beam_direction": [1, 0]}, "measurement 'm': beam_direction: expected shape (3,), got "
     "(2,)"),
    ({"tool_offset": [0, np.inf, 0]}, "measurement 'm': tool_offset [mm]: values must be "
     "finite"),
    ({"deviation": [0.0]}, "measurement 'm': deviation [um] has shape (1,), expected (2,) like "
     "the positions"),
])
def test_measurement_validates_itself(kw, message):
    with pytest.raises(VolcalInputError) as exc:
        _m(**kw)
    assert exc.value.message == message


def test_valid_values_are_one_table_each():
    for k in KINDS:
        for t in TARGETS:
            assert _m(kind=k, target=t).kind == k


def test_unknown_target_in_file(S):
    p = S / "session.toml"
    p.write_text(p.read_text().replace('target = "flat_mirror"', 'target = "flat-mirror"', 1))
    with pytest.raises(VolcalInputError) as exc:
        read_session(S)
    assert _msg(exc) == ("session.toml", None, "measurements[0].target",
                         "unknown target 'flat-mirror': expected one of flat_mirror, "
                         "retroreflector, retroreflector_mirror, cat_eye, straightness_optics, "
                         "angular_optics, level, roll_optics, rotary_calibrator, "
                         "index_table, touch_probe, r_test_nest")


@pytest.mark.parametrize("kw,message", [
    ({"chain": "XYZ"}, None),
    ({"travel": [[0, 1], [0, 1]]}, "travel [mm]: expected shape (3, 2), got (2, 2)"),
    ({"travel": [[0, 1], [2, 1], [0, 1]]}, "travel [mm]: every axis needs max > min"),
    ({"measurements": [_m(), _m()]}, "duplicate measurement id 'm'"),
])
def test_session_validates_itself(kw, message):
    args = dict(name="M", chain="XYFZ", travel=TRAVEL)
    args.update(kw)
    with pytest.raises(VolcalInputError) as exc:
        Session(**args)
    if message is not None:
        assert exc.value.message == message


# --------------------------------------------------------------------------- plausibility

def _sim(seed=0, chain="XYFZ", tests=("step-diagonal", "diagonal", "linear"), errors=None,
         **opts):
    s = plan_session(TRAVEL, chain, steps=5, tests=tests, runs=2)
    simulate_session(s, errors or machine(chain, seed), SimulationOptions(seed=seed, **opts))
    return s


def test_mm_entered_as_um_is_flagged():
    s = _sim()
    s.get("linear-y2").deviation *= 1000.0
    w = plausibility_warnings(s)
    assert len(w) == 1 and w[0].startswith("linear-y2: deviations ~")
    assert "larger than the session's other linear tests" in w[0]
    assert w[0].endswith("mm entered as um in linear-y2.csv?")


def test_wrong_sign_of_a_whole_test_is_flagged():
    m = machine("XYFZ", seed=2)
    # EXX dominates the X lines (the check is for tests whose positioning error dominates
    # their Abbe differences; docs/formats.md)
    m.values[0][:, 0] = np.linspace(0.0, 60.0, m.nodes[0].size)
    s = _sim(errors=m, tests=("linear",))
    s.get("linear-x2").deviation *= -1.0
    assert plausibility_warnings(s) == [
        "linear-x2: readings of the opposite sign to the other X lines (linear-x1, linear-x3): "
        "a whole test with the wrong sign in linear-x2.csv?"]


def test_reversed_csv_is_flagged():
    s = _sim()
    d = s.get("diag-npp")
    d.positions = d.positions[::-1].copy()
    d.deviation = d.deviation[::-1].copy()
    w = plausibility_warnings(s)
    assert w[0] == ("diag-npp: the poses move against the beam direction of session.toml: "
                    "rows of diag-npp.csv in reverse order?")
    lin = _sim()
    m = lin.get("linear-z1")
    m.columns["direction"] = m.columns["direction"][::-1].copy()
    assert plausibility_warnings(lin) == [
        "linear-z1: positions descend in the '+' rows (or ascend in the '-' rows) of "
        "linear-z1.csv: rows in reverse order?"]


def test_reversed_deviations_are_flagged():
    s = _sim()
    d = s.get("diag-ppn")
    d.deviation = d.deviation[::-1].copy()
    w = plausibility_warnings(s)
    assert len(w) == 1 and w[0].startswith("diag-ppn: the first reading is ")
    assert w[0].endswith("um, not ~0 (readings count from the first row): deviations of "
                         "diag-ppn.csv in reverse order?")


@pytest.mark.parametrize("seed", range(40))
def test_clean_simulations_raise_no_warning(seed):
    """No false alarm on clean sessions of every kind, chain, size, noise (many seeds)."""
    rng = np.random.default_rng(seed)
    travel = np.array([[0, rng.uniform(100, 2000)], [0, rng.uniform(100, 1500)],
                       [0, rng.uniform(100, 1000)]])
    chain = ("XYFZ", "FXYZ", "YFXZ", "XFYZ", "ZFXY", "XYZF")[seed % 6]
    s = plan_session(travel, chain, steps=int(rng.integers(2, 12)),
                     tests=("step-diagonal", "diagonal", "linear", "face-diagonal",
                            "face-step-diagonal"),
                     runs=int(rng.integers(2, 6)), iso_spacing=bool(seed % 2),
                     step_orders=("xyz", "zyx") if seed % 3 == 0 else ("xyz",))
    noise = float(rng.choice([0.0, 0.1, 0.5, 2.0]))
    simulate_session(s, random_machine(s.travel, chain, seed),
                     SimulationOptions(noise_um=noise,
                                       drift_um_per_h=float(rng.choice([0.0, 1.0])),
                                       seed=seed))
    # what `volcal simulate` records: a noise-free simulation is declared as such, and only
    # then is the absolute repeatability floor (20 nm, no interferometer in air) waived
    s.provenance = {"readings": "simulated", "noise_um": noise}
    assert plausibility_warnings(s) == []
