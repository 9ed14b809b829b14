
import numpy as np
import pytest

from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.fanuc import PARAM_FILE, PITCH_FILE, read_fanuc
from volcal.errors import VolcalInputError
from volcal.measure.virtual import random_machine
from volcal.model.errorfunctions import MachineErrors
from volcal.session.errortable import write_error_table
from volcal_cli_helpers import volcal_process


def _linear_machine(exx_end_um=12.0):
    """X travel 0..100 mm with EXX rising linearly to ``exx_end_um``; all else zero."""
    vx = np.zeros((2, 6))
    vx[1, 0] = exx_end_um
    return MachineErrors("XYFZ", [[0, 100], [0, 50], [0, 50]], [vx, np.zeros((2, 6)),
                                                                 np.zeros((2, 6))])


def test_fanuc_hand_computed(tmp_path):
    # spacing 25 mm, correction: -3 um per interval, reference at X=0 -> point 0 is the
    # section (-25, 0], points 1..4 hold -3 each; Y and Z (0..50 mm) follow as 5..7, 8..10
    write_compensation(_linear_machine(), "fanuc", tmp_path,
                       CompensationOptions("correction", spacing=25.0))
    pitch = (tmp_path / PITCH_FILE).read_text().split()
    assert pitch[:6] == ["%", "N10000Q0P0", "N10001Q0P-3", "N10002Q0P-3", "N10003Q0P-3",
                         "N10004Q0P-3"]
    assert pitch[-1] == "%" and len(pitch) == 2 + 5 + 3 + 3
    par = (tmp_path / PARAM_FILE).read_text().split()
    assert "N03620Q1A1P0A2P5A3P8" in par
    assert "N03621Q1A1P0A2P5A3P8" in par
    assert "N03622Q1A1P4A2P7A3P10" in par
    assert "N03624Q1A1P25.000A2P25.000A3P25.000" in par  # 30i: a length [mm], decimal point
    assert not any(line.startswith("N01240") for line in par)
    t = read_fanuc(tmp_path, "correction")[0]
    np.testing.assert_array_equal(t.positions, [-25, 0, 25, 50, 75, 100])
    np.testing.assert_array_equal(t.values, [0, 0, -3, -6, -9, -12])


def test_fanuc_older_series_syntax(tmp_path):
    write_compensation(_linear_machine(), "fanuc", tmp_path,
                       CompensationOptions("correction", spacing=25.0, fanuc_series="16i"))
    par = (tmp_path / PARAM_FILE).read_text().split()
    assert "N3620A1P0A2P5A3P8" in par and "N3624A1P25000A2P25000A3P25000" in par
    assert (tmp_path / PITCH_FILE).read_text().split()[1] == "N10000P0"
    t = read_fanuc(tmp_path, "correction")[0]
    np.testing.assert_array_equal(t.values, [0, 0, -3, -6, -9, -12])


def test_fanuc_reference_at_the_end_of_travel(tmp_path):
    # reference at X=100: sections 0..3 end at 25, 50, 75, 100 (reference = point 3)
    write_compensation(_linear_machine(), "fanuc", tmp_path,
                       CompensationOptions("error", spacing=25.0, reference_mm=(100, 0, 0)))
    par = (tmp_path / PARAM_FILE).read_text().split()
    assert "N03620Q1A1P3A2P4A3P7" in par and "N03621Q1A1P0A2P4A3P7" in par
    assert "N03622Q1A1P3A2P6A3P9" in par
    assert (tmp_path / PITCH_FILE).read_text().split()[1:5] == [
        "N10000Q0P3", "N10001Q0P3", "N10002Q0P3", "N10003Q0P3"]
    assert not any(line.startswith(("N01240", "N1240")) for line in par)
    notes = (tmp_path / "FANUC_NOTES.TXT").read_text()
    assert "X: reference position 100 mm" in notes and "1240" in notes
    t = read_fanuc(tmp_path, "error", reference_mm=(100, 0, 0))[0]
    np.testing.assert_array_equal(t.positions, [0, 25, 50, 75, 100])
    np.testing.assert_array_equal(t.values, [-12, -9, -6, -3, 0])


def test_fanuc_increment_limit(tmp_path):
    with pytest.raises(VolcalInputError, match=r"increment of -10 x 1 um, beyond \+-7"):
        write_compensation(_linear_machine(40.0), "fanuc", tmp_path / "o",
                           CompensationOptions("correction", spacing=25.0))
    assert not (tmp_path / "o").exists()
    write_compensation(_linear_machine(40.0), "fanuc", tmp_path / "o",
                       CompensationOptions("correction", spacing=25.0, magnification=2))


@pytest.mark.parametrize("fmt,opts,msg", [
    ("fanuc", dict(spacing=0.1), "exceed the table of 1024"),
    ("fanuc", dict(spacing=2.5, unit_um=1.0, reference_mm=(200.0, 0, 0)), "outside the travel"),
    ("fanuc", dict(spacing=0.0005), "whole number of detection units"),
    ("siemens", dict(spacing=0.01), "limit of 5000"),
    ("siemens", dict(spacing=1.0, max_points=50), "use --spacing 2.041 mm"),
    ("heidenhain", dict(spacing=0.25, max_points=256), "limit of 256"),
    ("linuxcnc", dict(spacing=0.25), "limit of 256"),
    ("heidenhain", dict(spacing=0.00005), "4 decimals"),
    ("grid", dict(spacing=0.5), "3-D grid would have"),
    ("isg", dict(spacing=-1.0), "positive distance"),
    ("okuma", dict(), "unknown format"),
])
def test_limits_are_clear_errors(tmp_path, fmt, opts, msg):
    m = random_machine([[0, 100], [0, 100], [0, 100]], "FXYZ", 1)
    with pytest.raises(VolcalInputError, match=msg):
        write_compensation(m, fmt, tmp_path / "o", CompensationOptions("error", **opts))
    assert not (tmp_path / "o").exists()


def test_sign_must_be_explicit_and_valid(tmp_path):
    with pytest.raises(VolcalInputError, match="'error' or 'correction'"):
        write_compensation(_linear_machine(), "csv", tmp_path / "o", CompensationOptions("comp"))


def test_foreign_folder_is_kept(tmp_path):
    (tmp_path / "notes.txt").write_text("keep")
    with pytest.raises(VolcalInputError, match="not a volcal compensation folder"):
        write_compensation(_linear_machine(), "csv", tmp_path, CompensationOptions("error"))
    assert (tmp_path / "notes.txt").read_text() == "keep"


def _cli(*args):
    """``volcal *args`` in-process (VOLCAL_TEST_SUBPROCESS=1: in a process of its own)."""
    return volcal_process(*args)


def test_cli_from_error_table(tmp_path):
    m = random_machine([[0, 800], [0, 600], [0, 500]], "XYFZ", 4)
    csv = write_error_table(m, tmp_path / "VMC.csv")
    r = _cli("compensate", str(csv), "--format", "siemens", "--sign", "error", "-o",
             str(tmp_path / "out"), "--spacing", "10")
    assert r.returncode == 0, r.stderr
    from volcal.compensate.siemens import LEC_FILE, read_lec
    t = read_lec(tmp_path / "out" / LEC_FILE, "error")[0]
    assert t.positions.size == 81
    np.testing.assert_allclose(t.values, m.component(0, t.positions)[:, 0], atol=0.0006)
    # no --sign: the controller's own convention (Fanuc: correction), said in the output
    r = _cli("compensate", str(csv), "--format", "fanuc", "-o", str(tmp_path / "f"))
    assert r.returncode == 0, r.stderr
    assert "correction, the controller's convention" in r.stdout.replace("\n", " ")
    t = read_fanuc(tmp_path / "f", "correction")[0]
    exx = m.component(0, t.positions)[:, 0]
    assert np.max(np.abs(t.values - -(exx - exx[1]))) <= 0.5 + 1e-9  # -error, zero at ref
    # an override is printed with what it overrides: a caution, on standard error
    r = _cli("compensate", str(csv), "--format", "fanuc", "--sign", "error", "-o",
             str(tmp_path / "f2"))
    assert r.returncode == 0 and "overrides the fanuc convention 'correction'" in r.stderr
    bad = tmp_path / "MODEL.json"
    bad.write_text("{not json")
    r = _cli("compensate", str(bad), "--format", "csv", "--sign", "error", "-o",
             str(tmp_path / "g"))
    assert r.returncode == 2 and "Traceback" not in r.stderr and "MODEL.json" in r.stderr
    assert not (tmp_path / "g").exists()
