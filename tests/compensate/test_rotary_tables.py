"""Rotary compensation tables against a hand-worked data set and their controllers' readers.

The data set: a full-circle C axis, targets 0, 90, 180, 270 and 360 deg, two bidirectional
runs, deviations [urad]:

=======  ====  ====  ====  ====  ====
target      0    90   180   270   360
up r1       0    10    20    10     2
up r2       0    12    22    12     4
down r1     4    14    24    14     6
down r2     6    16    26    16     8
=======  ====  ====  ====  ====  ====

Means up 0, 11, 21, 11, 3; down 5, 15, 25, 15, 7. 0 and 360 deg are one position: up
(0 + 3) / 2 = 1.5, down (5 + 7) / 2 = 6. Periodic interpolation: up at 315 deg halfway
between 11 (270) and 1.5 (360 = 0): 6.25; down at 45 deg: (6 + 15) / 2 = 10.5.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from volcal.compensate.rotary import RotaryOptions, rotary_removed_urad, rotary_tables
from volcal.compensate.rotary.profile import DEG_PER_URAD, rotary_profile

T = [0.0, 90.0, 180.0, 270.0, 360.0]
UP = [[0, 10, 20, 10, 2], [0, 12, 22, 12, 4]]
DOWN = [[4, 14, 24, 14, 6], [6, 16, 26, 16, 8]]


def hand_measurement(modulo: bool = True):
    t, run, d, dev = [], [], [], []
    for r in range(2):
        t += T + T[::-1]
        run += [r + 1] * 10
        d += ["+"] * 5 + ["-"] * 5
        dev += UP[r] + DOWN[r][::-1]
    return SimpleNamespace(
        id="rot-c", kind="rotary", file=None, rows=None, deviation=np.array(dev, float),
        columns={"target_deg": np.array(t), "run": np.array(run), "direction": np.array(d)},
        meta={"axis": "c", "modulo": modulo, "range_deg": [0.0, 360.0]})


def write(files: dict, folder):
    folder.mkdir(exist_ok=True)
    for k, v in files.items():
        (folder / k).write_text(v)
    return folder


def test_profile_means_closure_and_periodic_interpolation():
    p = rotary_profile(hand_measurement())
    np.testing.assert_array_equal(p.targets_deg, [0, 90, 180, 270])
    np.testing.assert_allclose(p.up_urad, [1.5, 11, 21, 11])
    np.testing.assert_allclose(p.down_urad, [6, 15, 25, 15])
    assert p.bidirectional and p.modulo
    assert p.error_urad(315.0, "+") == pytest.approx(6.25)
    assert p.error_urad(45.0, "-") == pytest.approx(10.5)
    assert p.error_urad(45.0 + 720.0, "-") == pytest.approx(10.5)  # any turn
    assert p.error_urad(-45.0, "+") == pytest.approx(6.25)
    assert p.error_urad(360.0, "+") == pytest.approx(1.5)
    # a limited axis keeps 360 as its own target and holds the end values
    q = rotary_profile(hand_measurement(modulo=False))
    np.testing.assert_allclose(q.up_urad, [0, 11, 21, 11, 3])
    assert q.error_urad(400.0, "+") == pytest.approx(3.0)


def test_linuxcnc_rotary_file_by_hand(tmp_path):
    p = rotary_profile(hand_measurement())
    files, entries, skipped = rotary_tables([p], "linuxcnc", RotaryOptions())
    assert skipped == [] and entries[0]["sign"] == "correction"
    lines = files["C.comp"].splitlines()
    nom = [float(x.split()[0]) for x in lines]
    assert nom == [-360.0 + 90 * k for k in range(13)]  # -360 .. 720, one turn either side
    row = dict(zip(nom, lines, strict=True))
    k = DEG_PER_URAD
    assert row[90.0] == f"90.000000 {-11 * k:.9f} {-15 * k:.9f}"
    assert row[-270.0] == row[90.0].replace("90.000000", "-270.000000")
    assert row[720.0] == f"720.000000 {-1.5 * k:.9f} {-6 * k:.9f}"  # = 0 deg
    notes = files["ROTARY_NOTES.TXT"]
    assert "COMP_FILE = C.comp" in notes and "COMP_FILE_TYPE = 1" in notes
    folder = write(files, tmp_path / "l")
    got = rotary_removed_urad(folder, "linuxcnc", entries[0], [45.0, 315.0], ["-", "+"])
    half_digit = 0.5e-9 / DEG_PER_URAD  # values written with 9 decimals of deg [urad]
    np.testing.assert_allclose(got, [10.5, 6.25], atol=2 * half_digit)
    # type 0: the actual angles
    files0, _, _ = rotary_tables([p], "linuxcnc", RotaryOptions(linuxcnc_type=0))
    row0 = {float(x.split()[0]): x for x in files0["C.comp"].splitlines()}
    assert row0[90.0] == f"90.000000 {90 + 11 * k:.9f} {90 + 15 * k:.9f}"


def test_heidenhain_rotary_table_read_by_pylsv2(tmp_path):
    pytest.importorskip("pyLSV2")
    from pyLSV2.table_reader import NCTable

    p = rotary_profile(hand_measurement())
    files, entries, _ = rotary_tables([p], "heidenhain", RotaryOptions())
    folder = write(files, tmp_path / "h")
    t = NCTable.parse_table(folder / "C.COM")
    assert t.name == "C" and t.is_metric
    assert t.column_names == ["NR", "AXISPOS", "C", "BACKLASH"]
    pos = [float(r["AXISPOS"]) for r in t.rows]
    assert pos == [0.0, 90.0, 180.0, 270.0, 360.0]
    assert [int(r["NR"]) for r in t.rows] == list(range(5))
    up = np.array([float(r["C"]) for r in t.rows]) / DEG_PER_URAD  # the error [urad]
    down = np.array([float(r["BACKLASH"]) for r in t.rows]) / DEG_PER_URAD
    np.testing.assert_allclose(up, [1.5, 11, 21, 11, 1.5], atol=0.01)  # 6 decimals of deg
    np.testing.assert_allclose(down, [6, 15, 25, 15, 6], atol=0.01)
    cma = NCTable.parse_table(folder / "VOLCAL_ROTARY.CMA")
    assert cma.rows[0]["ACTIVE"] == "*" and cma.rows[0]["C"] == "C.COM"
    got = rotary_removed_urad(folder, "heidenhain", entries[0], [45.0, 315.0], ["-", "+"])
    np.testing.assert_allclose(got, [10.5, 6.25], atol=0.01)


def test_siemens_rotary_lec_modulo_and_direction_tables(tmp_path):
    p = rotary_profile(hand_measurement())
    files, entries, _ = rotary_tables([p], "siemens", RotaryOptions(spacing_deg=90.0))
    lec = files["SIEMENS_LEC_ROTARY_EEC_INI.SPF"]
    k = DEG_PER_URAD
    mean = [3.75, 13, 23, 13, 3.75]  # the mean of both directions, 0 = 360 [urad]
    for n, v in enumerate(mean):
        assert f"$AA_ENC_COMP[0,{n},AX4]={v * k:.7f}" in lec
    for line in ("$AA_ENC_COMP_STEP[0,AX4]=90.000000", "$AA_ENC_COMP_MIN[0,AX4]=0.000000",
                 "$AA_ENC_COMP_MAX[0,AX4]=360.000000", "$AA_ENC_COMP_IS_MODULO[0,AX4]=1"):
        assert line in lec
    cec = files["SIEMENS_CEC_ROTARY_CEC_INI.SPF"]
    assert "$AN_CEC_DIRECTION[6]=1" in cec and "$AN_CEC_DIRECTION[7]=-1" in cec
    assert "$AN_CEC_INPUT_AXIS[6]=(AX4)" in cec and "$AN_CEC_OUTPUT_AXIS[7]=(AX4)" in cec
    assert f"$AN_CEC[6,1]={-2 * k:.7f}" in cec  # 11 - 13 at 90 deg, moving positive
    assert f"$AN_CEC[7,1]={2 * k:.7f}" in cec
    folder = write(files, tmp_path / "s")
    got = rotary_removed_urad(folder, "siemens", entries[0], [45.0, 90.0, 315.0],
                              ["-", "+", "+"])
    np.testing.assert_allclose(got, [10.5, 11.0, 6.25], atol=1e-7 / DEG_PER_URAD)  # 7 decimals


def test_fanuc_rotation_axis_pitch_table_by_hand(tmp_path):
    p = rotary_profile(hand_measurement())
    files, entries, _ = rotary_tables([p], "fanuc", RotaryOptions(
        spacing_deg=90.0, fanuc_unit_deg=0.0001, fanuc_reference_number=60))
    par = files["FANUC_ROTARY_PARAM_C.TXT"].splitlines()
    for line in ("N03620Q1A4P60", "N03621Q1A4P60", "N03622Q1A4P64", "N03623Q1A4P1",
                 "N03624Q1A4P90.000", "N03625Q1A4P360.000"):
        assert line in par
    # correction relative to 0 deg: -(mean - 3.75) = 0, -9.25, -19.25, -9.25, 0 urad,
    # in 0.0001 deg: 0, -5.30, -11.03, -5.30, 0 -> cumulative 0, -5, -11, -5, 0
    pitch = files["FANUC_ROTARY_PITCH_C.TXT"].splitlines()
    assert pitch[1:-1] == ["N10060Q0P5", "N10061Q0P-5", "N10062Q0P-6", "N10063Q0P6",
                           "N10064Q0P5"]
    incs = [int(x.split("P")[1]) for x in pitch[2:-1]]
    assert sum(incs) == 0  # one revolution sums to zero (B-63980EN/01, rotation axis)
    folder = write(files, tmp_path / "f")
    got = rotary_removed_urad(folder, "fanuc", entries[0], [0.0, 90.0, 100.0, 180.0],
                              ["+"] * 4)
    unit = 0.0001 / DEG_PER_URAD
    np.testing.assert_allclose(got, np.array([0, 5, 5, 11]) * unit, atol=1e-9)
    # a limited axis has no rotation-axis table
    q = rotary_profile(hand_measurement(modulo=False))
    f2, e2, skipped = rotary_tables([q], "fanuc", RotaryOptions(spacing_deg=90.0))
    assert e2 == [] and "full-circle" in skipped[0]


def test_fanuc_rejects_a_spacing_that_does_not_divide_the_turn():
    from volcal.errors import ParameterError

    p = rotary_profile(hand_measurement())
    with pytest.raises(ParameterError, match="divide"):
        rotary_tables([p], "fanuc", RotaryOptions(spacing_deg=7.0))


def test_isg_rotary_leadscrew_list_by_hand(tmp_path):
    """The SSFK list of TF5200 (kw.ssfk.*): 0.0001 deg, bilateral, modulo, the error.

    Values by hand (urad x 0.57296 = 0.0001 deg, rounded): up 1.5, 11, 21, 11, 1.5 ->
    1, 6, 12, 6, 1; down 6, 15, 25, 15, 6 -> 3, 9, 14, 9, 3.
    """
    from volcal.compensate.rotary.isg import read_isg_rotary

    p = rotary_profile(hand_measurement())
    files, entries, _ = rotary_tables([p], "isg", RotaryOptions())
    assert sorted(files) == ["ROTARY_NOTES.TXT", "rotary_isg_C.lis"]
    lines = [x for x in files["rotary_isg_C.lis"].splitlines() if not x.startswith("#")]
    kv = dict(x.split() for x in lines)
    assert {k: kv[k] for k in ("kw.ssfk.unit", "kw.ssfk.interval", "kw.ssfk.kw_nr_max",
                               "kw.ssfk.bilateral", "kw.ssfk.modulo", "kopf.log_achs_name")} \
        == {"kw.ssfk.unit": "1", "kw.ssfk.interval": "0", "kw.ssfk.kw_nr_max": "5",
            "kw.ssfk.bilateral": "1", "kw.ssfk.modulo": "1", "kopf.log_achs_name": "C"}
    assert [kv[f"kw.ssfk.table[{i}].setpoint"] for i in range(5)] == [
        "0", "900000", "1800000", "2700000", "3600000"]
    assert [kv[f"kw.ssfk.table[{i}].pos"] for i in range(5)] == ["1", "6", "12", "6", "1"]
    assert [kv[f"kw.ssfk.table[{i}].neg"] for i in range(5)] == ["3", "9", "14", "9", "3"]
    folder = write(files, tmp_path / "i")
    pts, up, down, modulo = read_isg_rotary(folder / "rotary_isg_C.lis")
    assert modulo and pts[-1] == pytest.approx(360.0) and up[1] == pytest.approx(6e-4)
    # linear between points, per direction, periodic: 45 deg down (3 + 9) / 2 = 6 units,
    # 315 deg up (6 + 1) / 2 = 3.5 units, 405 deg = 45 deg
    got = rotary_removed_urad(folder, "isg", entries[0], [45.0, 315.0, 405.0],
                              ["-", "+", "-"])
    np.testing.assert_allclose(got, np.array([6.0, 3.5, 6.0]) * 1e-4 / DEG_PER_URAD,
                               rtol=1e-12)
    # the correction sign negates every value
    files2, _, _ = rotary_tables([p], "isg", RotaryOptions(sign="correction"))
    assert "kw.ssfk.table[2].pos -12" in files2["rotary_isg_C.lis"]


def test_formats_without_rotary_tables_say_so():
    p = rotary_profile(hand_measurement())
    files, entries, skipped = rotary_tables([p], "csv", RotaryOptions())
    assert files == {} and entries == [] and "no rotary tables" in skipped[0]


@pytest.mark.parametrize("fmt, manual", [
    ("linuxcnc", "usrmotintf.cc"), ("heidenhain", "6.10.3 Nonlinear axis error compensation"),
    ("siemens", "K3 4.4 Interpolatory compensation"), ("fanuc", "B-63980EN/01"),
    ("isg", "P-COMP-00017")])
def test_the_notes_name_the_manual_the_tables_follow(fmt, manual):
    """Session 21: the rotary notes said the sign, limits and activation but not the
    manual the tables follow (the linear formats' README says it)."""
    files, _, _ = rotary_tables([rotary_profile(hand_measurement())], fmt, RotaryOptions())
    source = [ln for ln in files["ROTARY_NOTES.TXT"].splitlines() if ln.startswith("Source: ")]
    assert len(source) == 1 and manual in source[0], files["ROTARY_NOTES.TXT"]


def test_deg_per_urad():
    assert DEG_PER_URAD == pytest.approx(180 / math.pi / 1e6)


def test_compensate_session_writes_rotary_tables_and_prints_A(tmp_path, monkeypatch, capsys):
    """``volcal compensate --session``: the rotary table beside the linear ones, in the
    manifest, and ISO 230-2 A before and after per rotary test."""
    from volcal.compensate.manifest import read_manifest
    from volcal.session.format import read_session
    from volcal.standards.iso230_2_rotary import evaluate_rotary
    from volcal_cli_helpers import run_volcal

    s = tmp_path / "s"
    assert run_volcal(monkeypatch, capsys, "plan", "--tests", "linear:x,rotary:c", "--runs",
                      "3", "-o", str(s))[0] == 0
    assert run_volcal(monkeypatch, capsys, "simulate", str(s), "--seed", "4")[0] == 0
    out_dir = tmp_path / "comp"
    code, out, err = run_volcal(monkeypatch, capsys, "compensate", str(s / "truth" /
                                "machine.csv"), "--format", "heidenhain", "-o", str(out_dir),
                                "--session", str(s))
    assert code == 0, err
    assert "rotary tests: ISO 230-2 A before and after these tables" in out
    man = read_manifest(out_dir)
    assert "C.COM" in man["files"] and "VOLCAL_ROTARY.CMA" in man["files"]
    assert man["rotary"][0]["id"] == "rotary-c" and man["rotary"][0]["sign"] == "error"
    m = next(x for x in read_session(s).measurements if x.kind == "rotary")
    ok = np.isfinite(m.deviation)
    before = evaluate_rotary(m.columns["target_deg"][ok], m.columns["run"][ok],
                             m.columns["direction"][ok], m.deviation[ok]).iso.A
    row = next(line for line in out.splitlines() if "rotary-c" in line)
    cells = [c.strip() for c in row.strip("│┃ ").split("│")]
    assert cells[:2] == ["rotary-c", "C"]
    assert float(cells[2]) == pytest.approx(before, abs=0.005)
    assert float(cells[3]) < 0.3 * float(cells[2])
    # the display in arcsec (1 arcsec = 4.8481368 urad)
    code, out2, err = run_volcal(monkeypatch, capsys, "compensate", str(s / "truth" /
                                 "machine.csv"), "--format", "heidenhain", "-o",
                                 str(tmp_path / "comp2"), "--session", str(s), "--units",
                                 "arcsec")
    assert code == 0, err
    assert "A before [arcsec]" in out2
    row2 = next(line for line in out2.splitlines() if "rotary-c" in line)
    cells2 = [c.strip() for c in row2.strip("│┃ ").split("│")]
    assert float(cells2[2]) == pytest.approx(before / 4.8481368, abs=0.005)


def test_fanuc_rotary_points_must_not_reuse_the_linear_ones(tmp_path, monkeypatch, capsys):
    from volcal_cli_helpers import run_volcal

    s = tmp_path / "s"
    assert run_volcal(monkeypatch, capsys, "plan", "--tests", "linear:x,rotary:c", "--runs",
                      "2", "--travel", "0:400,0:300,0:200", "-o", str(s))[0] == 0
    assert run_volcal(monkeypatch, capsys, "simulate", str(s), "--seed", "4")[0] == 0
    args = ["compensate", str(s / "truth" / "machine.csv"), "--format", "fanuc",
            "--session", str(s)]
    # 2 mm: the linear points (both directions of X) run past 900, where the rotary table
    # starts
    code, out, err = run_volcal(monkeypatch, capsys, *args, "-o", str(tmp_path / "a"),
                                "--spacing", "2")
    assert code != 0 and "Traceback" not in err
    assert "Fanuc pitch error compensation: point 900 in FANUC_PITCH.TXT and " \
        "FANUC_ROTARY_PITCH_C.TXT" in err
    assert not (tmp_path / "a").exists()
    code, out, err = run_volcal(monkeypatch, capsys, *args, "-o", str(tmp_path / "b"))
    assert code == 0, err
    assert (tmp_path / "b" / "FANUC_ROTARY_PITCH_C.TXT").is_file()


def test_fanuc_two_full_circle_axes_share_the_table_below_its_end(tmp_path):
    """Two full-circle axes at the default 5 deg: 73 points each from 900 ran past point
    1023 and the command refused them (naming an option it does not have). The tables now
    end at point 1023: 878..950 and 951..1023, each read back as written."""
    p = rotary_profile(hand_measurement())
    q = replace(rotary_profile(hand_measurement()), id="rot-a", axis="a")
    files, entries, _ = rotary_tables([p, q], "fanuc", RotaryOptions())
    par = [files[f"FANUC_ROTARY_PARAM_{s}.TXT"].splitlines() for s in ("C", "A")]
    assert "N03620Q1A4P878" in par[0] and "N03622Q1A4P950" in par[0]
    assert "N03620Q1A5P951" in par[1] and "N03622Q1A5P1023" in par[1]
    pts = [int(line[2:6]) for name in ("C", "A")
           for line in files[f"FANUC_ROTARY_PITCH_{name}.TXT"].splitlines()
           if line.startswith("N1")]
    assert pts == list(range(878, 1024))
    assert "take points 878..1023 of the shared table of 1024" in files["ROTARY_NOTES.TXT"]
    folder = write(files, tmp_path / "f")
    a = np.arange(0.0, 360.0, 5.0)
    for e in entries:  # each table removes the hand data's mean error at its points
        got = rotary_removed_urad(folder, "fanuc", e, a, ["+"] * a.size)
        assert np.all(np.abs(got) < 25.0) and np.ptp(got) > 15.0
    # one axis keeps the default start
    one, _, _ = rotary_tables([p], "fanuc", RotaryOptions())
    assert "N03620Q1A4P900" in one["FANUC_ROTARY_PARAM_C.TXT"].splitlines()


@pytest.mark.parametrize(("spacing", "message"), [
    ("0.25", "do not fit the table of 1024 points shared by all axes; use a larger "
             "--rotary-spacing"),
    ("7", "--rotary-spacing 7: parameter 3624 must divide 360 deg"),
    ("-5", "--rotary-spacing -5.0: expected a finite number > 0 [deg]")])
def test_compensate_rotary_spacing_option(tmp_path, monkeypatch, capsys, spacing, message):
    """``--rotary-spacing`` sets the rotary tables' points; its refusals name it (they
    named ``--rotary-spacing`` before the command had it)."""
    from volcal_cli_helpers import run_volcal

    s = tmp_path / "s"
    assert run_volcal(monkeypatch, capsys, "plan", "--tests", "rotary:c", "-o", str(s))[0] == 0
    assert run_volcal(monkeypatch, capsys, "simulate", str(s), "--seed", "4")[0] == 0
    args = ["compensate", "--format", "fanuc", "--session", str(s)]
    code, out, err = run_volcal(monkeypatch, capsys, *args, "-o", str(tmp_path / "a"),
                                "--rotary-spacing", spacing)
    assert code == 2 and "Traceback" not in err and message in err, err
    assert not (tmp_path / "a").exists()
    code, out, err = run_volcal(monkeypatch, capsys, *args, "-o", str(tmp_path / "b"),
                                "--rotary-spacing", "10")
    assert code == 0, err
    assert "N03624Q1A4P10.000" in (tmp_path / "b" / "FANUC_ROTARY_PARAM_C.TXT").read_text()
