"""What written tables correct: the error left, checked against numbers worked by hand.

Model: only EXX(x) = a x^2 (a = 1e-4 um/mm^2) on an 800 x 600 x 500 mm machine, or only
the squareness EC0Y. The work zone is evaluated at 11 points per axis (x = 0, 80, ..., 800).
Linear interpolation of a x^2 between table points x0 < x < x1 is off by a (x - x0)(x1 - x)
(the chord lies above the parabola): at 25 mm spacing the largest over x = 80 k is
a * 10 * 15 = 0.015 um (x = 160, 240, 560, 640); at 50 mm it is a * 30 * 20 = 0.06 um
(x = 80, 320, 480, 720). Rounding to 0.001 um adds at most 0.0005 um.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from volcal.compensate.formats import CompensationOptions, write_compensation
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import volumetric_error
from volcal.plan.geometry import linear_test
from volcal.report.carried import table_set_from_manifest
from volcal.report.pipeline import compensation_summary
from volcal.report.sections import ReportInputs, compensation_section
from volcal.session.format import Measurement, Session
from volcal.standards.tolerance import Tolerance, Verdict, parse_tolerance
from volcal_cli_helpers import volcal_process

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
A = 1e-4  # um/mm^2


def _exx_model(reversal_x=0.0):
    x = np.linspace(0.0, 800.0, 801)  # 1 mm nodes: the model's chord error is a/4 = 2.5e-5 um
    vx = np.zeros((x.size, 6))
    vx[:, 0] = A * x**2
    return MachineErrors("XYFZ", [x, TRAVEL[1], TRAVEL[2]], [vx, np.zeros((2, 6)),
                                                               np.zeros((2, 6))],
                         reversal=[reversal_x, 0.0, 0.0], name="exx")


def _result(errors):
    """Stand-in for an identification result: exact model, zero uncertainty."""
    return SimpleNamespace(errors=errors, predict=lambda q: (volumetric_error(errors, q),
                                                             np.zeros((len(q), 3))))


def _summary(errors, fmt, tmp_path, spacing, sign="error", **kw):
    folder = tmp_path / fmt
    write_compensation(errors, fmt, folder, CompensationOptions(sign, spacing), "m.json")
    return compensation_summary(_result(errors), TRAVEL, folder=folder, n=11, **kw)


def test_pitch_table_removes_exx_up_to_the_chord_error(tmp_path):
    c = _summary(_exx_model(), "csv", tmp_path, 25.0)
    assert c.model_max_um == pytest.approx(A * 800**2)  # 64 um at x = 800
    assert c.left_max_um == pytest.approx(0.015, abs=0.0006)
    # the manifest states what the tables carry and how the control interpolates them
    assert c.tables.carries == ("EXX", "EYY", "EZZ") and c.tables.assumed == ()


def test_grid_spacing_50_leaves_the_50_mm_chord_error(tmp_path):
    c = _summary(_exx_model(), "grid", tmp_path, 50.0)
    assert c.tables.grid
    assert c.left_max_um == pytest.approx(0.06, abs=0.0006)


def test_fanuc_step_rule_and_1_um_resolution(tmp_path):
    """Fanuc (manifest interpolation = "step"): the value of the last point passed is
    held, values in whole um: at x the table gives round(a x0^2), x0 = the point at or
    below x (20 mm spacing)."""
    c = _summary(_exx_model(), "fanuc", tmp_path, 20.0, sign="correction")
    assert c.tables.interpolation == "step" and c.tables.resolution_um == 1.0
    x = np.linspace(0, 800, 11)
    hand = np.abs(A * x**2 - np.round(A * (20.0 * np.floor(x / 20.0)) ** 2))
    assert c.left_max_um == pytest.approx(hand.max(), abs=1e-6)


def _ec0y_model():
    e = MachineErrors.zero("XYFZ", TRAVEL, "sq")
    e.squareness = np.array([10.0, 0.0, 0.0])  # EC0Y = 10 urad: e_x = -0.01 um/mm * y
    return e


def test_squareness_stays_with_pitch_tables_and_goes_with_siemens_cec(tmp_path):
    e = _ec0y_model()
    pitch = _summary(e, "csv", tmp_path, 25.0)
    assert pitch.model_max_um == pytest.approx(6.0)  # 10 urad over 600 mm
    assert pitch.left_max_um == pytest.approx(6.0)  # pitch tables cannot carry it
    cec = _summary(e, "siemens", tmp_path, 25.0)
    assert "EC0Y" in cec.tables.carries and cec.tables.squareness_folded
    assert cec.left_max_um <= 0.0005 + 1e-12  # linear: only the rounding is left


def test_manifest_keys_win_over_the_format_and_are_validated(tmp_path):
    t = table_set_from_manifest({"controller_format": "linuxcnc", "carries": ["exx"],
                                 "spacing_mm": 10, "resolution_um": 0.5,
                                 "bidirectional": True})
    assert t.carries == ("EXX",) and t.spacing_mm == 10 and t.resolution_um == 0.5
    assert t.bidirectional and t.assumed == ("interpolation",)
    with pytest.raises(VolcalInputError, match="EQQ"):
        table_set_from_manifest({"controller_format": "csv", "carries": ["EQQ"]})
    with pytest.raises(VolcalInputError, match="spacing_mm"):
        table_set_from_manifest({"controller_format": "csv", "spacing_mm": -1})
    with pytest.raises(VolcalInputError, match="cannot tell"):
        table_set_from_manifest({"controller_format": "okuma"})


def test_section_without_tables_claims_no_before_after(tmp_path):
    e = _exx_model()
    c = compensation_summary(_result(e), TRAVEL, n=5)
    sec = compensation_section(ReportInputs(Session("m", "XYFZ", TRAVEL, []), compensation=c))
    text = " ".join(sec.paragraphs)
    assert "nothing is said about the error after compensation" in text
    assert all("after" not in " ".join(t.columns) for t in sec.tables)
    assert c.left_max_um is None and c.truth_residual_max_um is None


def test_section_names_what_the_tables_carry(tmp_path):
    c = _summary(_ec0y_model(), "heidenhain", tmp_path, 25.0)
    sec = compensation_section(ReportInputs(Session("m", "XYFZ", TRAVEL, []), compensation=c))
    text = " ".join(sec.paragraphs)
    assert "per-axis pitch only: EXX, EYY, EZZ" in text and "0.1 µm" in text
    assert sec.tables[0].columns[-1] == "after these tables [µm]"
    assert sec.tables[0].rows[0][1:] == ["6.00", "6.00"]


def _linear_session(reversal):
    """Linear X test, 2 runs, no noise: deviation = a x^2 + B/2 (up) or - B/2 (down)."""
    g = linear_test("X", TRAVEL, 8, [0.0, 0.0, 0.0], runs=2, bidirectional=True,
                    targets_mm=np.array([5.0, 103.0, 207.0, 298.0, 401.0, 512.0, 597.0,
                                         703.0, 795.0]))
    x = g.positions[:, 0]
    dev = A * x**2 + np.where(g.direction == "+", 0.5, -0.5) * reversal
    m = Measurement("lx", "linear", "retroreflector", g.positions, dev, g.beam_direction,
                    columns={"run": g.run, "direction": g.direction}, meta={"axis": "X"})
    return Session("exx", "XYFZ", TRAVEL, [m]), x  # the machine of _exx_model


def test_iso230_2_verdict_before_and_after_by_hand(tmp_path):
    b = 2.0
    s, _ = _linear_session(b)
    e = _exx_model(reversal_x=b)
    tol = parse_tolerance("X=5,V=1")
    c = _summary(e, "csv", tmp_path, 25.0, tolerance=tol, session=s)
    vol, ax = c.verdicts
    # before: A = the spread of a x^2 + B/2 over the targets (no scatter):
    # a (795^2 - 5^2) + B = 63.2 + 2 = 65.2 um
    assert ax.before_um == pytest.approx(A * (795**2 - 5**2) + b)
    assert ax.before == "fail" and vol.before == "fail" and vol.before_um == pytest.approx(64)
    # after a unidirectional pitch table (25 mm, linear): chord errors at the targets plus B
    t = np.array([5.0, 103.0, 207.0, 298.0, 401.0, 512.0, 597.0, 703.0, 795.0])
    x0 = 25.0 * np.floor(t / 25.0)
    chord = -A * (t - x0) * (x0 + 25.0 - t)
    assert ax.after_um == pytest.approx(chord.max() - chord.min() + b, abs=0.002)
    assert ax.after == "pass" and vol.after == "pass"


def test_bidirectional_tables_take_the_reversal_off_too(tmp_path):
    """LinuxCNC tables written with the measured reversal B (forward = EXX + B/2, reverse =
    EXX - B/2), read back from X.comp: each approach gets its own column, so only the
    chord error of the 25 mm table is left in A (the tables used to be modelled, not
    read; the hand-written manifest of this test named an X.comp that did not exist)."""
    from volcal.compensate.bidirectional import DirectionalErrors

    b = 2.0
    s, _ = _linear_session(b)
    e = _exx_model(reversal_x=b)
    t = np.array([5.0, 103.0, 207.0, 298.0, 401.0, 512.0, 597.0, 703.0, 795.0])
    rev = DirectionalErrors([t, None, None], [np.full(t.size, b), None, None], "lx")
    folder = tmp_path / "lcnc"
    write_compensation(e, "linuxcnc", folder,
                       CompensationOptions(None, 25.0, directional=rev), "m.json")
    c = compensation_summary(_result(e), TRAVEL, folder=folder, n=11,
                             tolerance=Tolerance(None, {"X": 1.0}), session=s)
    assert c.written.reverse is not None and c.tables.bidirectional
    x0 = 25.0 * np.floor(t / 25.0)
    chord = -A * (t - x0) * (x0 + 25.0 - t)
    assert c.verdicts[0].after_um == pytest.approx(chord.max() - chord.min(), abs=0.002)
    # the same tables without the reverse column leave the reversal B in A
    one = tmp_path / "one"
    write_compensation(e, "linuxcnc", one, CompensationOptions(None, 25.0), "m.json")
    c1 = compensation_summary(_result(e), TRAVEL, folder=one, n=11,
                              tolerance=Tolerance(None, {"X": 1.0}), session=s)
    assert c1.verdicts[0].after_um == pytest.approx(chord.max() - chord.min() + b, abs=0.002)


@pytest.mark.parametrize("text,vol,axes", [("15", 15.0, {}),
                                           ("x=10, Y=10,Z=8", None,
                                            {"X": 10.0, "Y": 10.0, "Z": 8.0}),
                                           ("Z=3,V=7.5", 7.5, {"Z": 3.0})])
def test_parse_tolerance(text, vol, axes):
    t = parse_tolerance(text)
    assert t.volumetric_um == vol and t.axis_um == axes


@pytest.mark.parametrize("text", ["", "-1", "nan", "X=1,X=2", "W=3", "X=", "X=0"])
def test_parse_tolerance_refuses(text):
    with pytest.raises(VolcalInputError, match="tolerance-um"):
        parse_tolerance(text)


def test_verdict_words():
    assert Verdict("q", 5.0, 5.0, 5.01).before == "pass"
    assert Verdict("q", 5.0, 5.0, 5.01).after == "fail"
    assert Verdict("q", 5.0, None).after == "-"


def _cli(*args):
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-c", "from volcal.cli import main; main()", *args],
                          capture_output=True, text=True)


def test_evaluate_session_verdict_cli(tmp_path):
    """`volcal evaluate session --tolerance-um` with the model and its pitch tables: the
    same hand-worked A before (65.2 um) and after (chord spread + B) as above."""
    import json

    from volcal.session.errortable import write_error_table
    from volcal.session.format import write_session

    b = 2.0
    s, _ = _linear_session(b)
    write_session(s, tmp_path / "s")
    e = _exx_model(reversal_x=b)
    write_error_table(e, tmp_path / "m.csv")
    write_compensation(e, "csv", tmp_path / "c", CompensationOptions("error", 25.0), "m.csv")
    # the verdicts in-process (volcal_process: main(), its streams and exit code); the
    # refusals below are real processes
    r = volcal_process("evaluate", "session", tmp_path / "s", "--json", "--tolerance-um",
                       "X=5,V=1", "--model", tmp_path / "m.csv", "--compensation",
                       tmp_path / "c")
    assert r.returncode == 0, r.stderr
    vol, ax = json.loads(r.stdout)["verdict"]
    assert ax["before_um"] == pytest.approx(A * (795**2 - 5**2) + b, abs=1e-6)
    assert (ax["before"], ax["after"], vol["before"], vol["after"]) == ("fail", "pass",
                                                                        "fail", "pass")
    r = volcal_process("evaluate", "session", tmp_path / "s", "--tolerance-um", "X=70")
    assert r.returncode == 0 and "pass" in r.stdout and "--compensation" in r.stdout
    # a volumetric tolerance needs the model; tables need the model they came from
    r = _cli("evaluate", "session", str(tmp_path / "s"), "--tolerance-um", "5")
    assert r.returncode == 2 and "--model" in r.stderr and "Traceback" not in r.stderr
    r = _cli("evaluate", "session", str(tmp_path / "s"), "--tolerance-um", "X=5",
             "--compensation", str(tmp_path / "c"))
    assert r.returncode == 2 and "--model" in r.stderr
    r = _cli("evaluate", "session", str(tmp_path / "s"), "--tolerance-um", "X=five")
    assert r.returncode == 2 and "tolerance-um" in r.stderr
