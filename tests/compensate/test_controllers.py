"""Controller files read as the controllers read them (LinuxCNC, Fanuc backups) and the
safety rule that no format redefines machine coordinates."""

import re
import tomllib

import numpy as np
import pytest

from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.fanuc import PARAM_FILE, PITCH_FILE, read_fanuc
from volcal.compensate.formats import DEFAULT_SIGN, FORMATS, MANIFEST
from volcal.errors import VolcalInputError
from volcal.measure.virtual import random_machine

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 400.0]])


@pytest.fixture(scope="module")
def machine():
    return random_machine(TRAVEL, "XYFZ", 5, n_nodes=9)


def linuxcnc_load(text, file_type):
    """Independent model of LinuxCNC's loader (usrmotLoadComp, usrmotintf.cc): lines are
    read until the first that does not scan as three doubles; type 0 rows become
    trims ``nominal - actual``; at most 256 entries are kept (EMCMOT_COMP_SIZE)."""
    rows = []
    for line in text.splitlines():
        parts = line.split()
        try:
            nom, fwd, rev = (float(v) for v in parts[:3])
        except ValueError:
            break  # sscanf != 3: the loader stops here
        if len(parts) < 3:
            break
        if file_type == 0:
            fwd, rev = nom - fwd, nom - rev
        rows.append((nom, fwd, rev))
    return np.array(rows[:256])


def linuxcnc_trim(table, pos, forward=True):
    """Trim LinuxCNC adds at ``pos`` (linear between entries, end values held) [mm]."""
    return np.interp(pos, table[:, 0], table[:, 1] if forward else table[:, 2])


@pytest.mark.parametrize("file_type", [0, 1])
def test_linuxcnc_full_table_loads_and_cancels_the_error(tmp_path, machine, file_type):
    write_compensation(machine, "linuxcnc", tmp_path,
                       CompensationOptions(spacing=10.0, linuxcnc_type=file_type))
    readme = (tmp_path / "README.txt").read_text()
    for k, ax in enumerate("XYZ"):
        text = (tmp_path / f"{ax}.comp").read_text()
        table = linuxcnc_load(text, file_type)
        lines = text.splitlines()
        assert len(table) == len(lines)  # every line loads: no header, no comment
        assert np.all(np.diff(table[:, 0]) > 0)
        assert f"[JOINT_{k}]\nCOMP_FILE = {ax}.comp\nCOMP_FILE_TYPE = {file_type}" in readme
        # commanded c -> actual c + trim + error(c + trim) ~ c + trim + error(c)
        c = np.linspace(*TRAVEL[k], 997)
        err = machine.component(k, c)[:, k]
        left = err + 1000.0 * linuxcnc_trim(table, c)
        # residual = interpolation error of the 10 mm table + 0.5 nm rounding
        curv = np.max(np.abs(np.diff(machine.component(k, np.arange(*TRAVEL[k], 1.0))[:, k],
                                     2)))
        assert np.max(np.abs(left)) <= curv * 10.0 ** 2 / 8 + 0.002
        assert np.max(np.abs(err)) > 10 * np.max(np.abs(left))  # the table does work
        np.testing.assert_array_equal(table[:, 1], table[:, 2])  # no bidirectional data


def test_linuxcnc_limits(tmp_path, machine):
    with pytest.raises(VolcalInputError, match="256"):
        write_compensation(machine, "linuxcnc", tmp_path / "a", CompensationOptions(spacing=2.0))
    with pytest.raises(VolcalInputError, match="0 or 1"):
        write_compensation(machine, "linuxcnc", tmp_path / "b",
                           CompensationOptions(linuxcnc_type=2))


def test_linuxcnc_bidirectional(tmp_path, machine):
    rev = (lambda p: 3.0 + 0 * p, lambda p: -2.0 + 0.01 * p, None)
    write_compensation(machine, "linuxcnc", tmp_path,
                       CompensationOptions(spacing=20.0, reversal_um=rev))
    t = linuxcnc_load((tmp_path / "X.comp").read_text(), 1)
    np.testing.assert_allclose(1000 * (t[:, 2] - t[:, 1]), -3.0, atol=0.002)
    t = linuxcnc_load((tmp_path / "Y.comp").read_text(), 1)
    np.testing.assert_allclose(1000 * (t[:, 2] - t[:, 1]), -(-2.0 + 0.01 * t[:, 0]), atol=0.002)
    assert tomllib.loads((tmp_path / MANIFEST).read_text())["bidirectional"] is True


# parameters that (re)define machine coordinates / reference positions (FANUC 1240-1243
# reference positions, 1250, 1260, 1850 grid shift); any of them in any output is a defect
_FORBIDDEN = re.compile(r"^N0*(124[0-3]|1250|1260|1850)(Q1)?A", re.M)


@pytest.mark.parametrize("fmt", sorted(FORMATS))
def test_no_format_redefines_machine_coordinates(tmp_path, machine, fmt):
    files = write_compensation(machine, fmt, tmp_path, CompensationOptions(spacing=25.0))
    for name in files:
        text = (tmp_path / name).read_text()
        assert not _FORBIDDEN.search(text), (fmt, name)
        assert "$MA_REFP_SET_POS" not in text.upper().replace(" ", "")
    man = tomllib.loads((tmp_path / MANIFEST).read_text())
    assert man["sign"] == DEFAULT_SIGN[fmt] and man["sign_source"]
    assert man["spacing_mm"] == 25.0 and man["resolution_um"] > 0
    assert {"EXX", "EYY", "EZZ"} <= set(man["carries"])
    assert man["bidirectional"] is False


def test_fanuc_current_io_syntax(tmp_path, machine):
    write_compensation(machine, "fanuc", tmp_path, CompensationOptions(spacing=25.0))
    p = (tmp_path / PARAM_FILE).read_text().splitlines()
    assert p[0] == p[-1] == "%"
    assert p[1].startswith("N03620Q1A1P0A2P") and "N03624Q1A1P25.0A2P25.0A3P25.0" in p
    d = (tmp_path / PITCH_FILE).read_text().splitlines()
    assert all(re.fullmatch(r"N1\d{4}Q0P-?\d+", ln) for ln in d[1:-1])
    assert d[1].startswith("N10000Q0P")


def test_fanuc_reader_accepts_a_real_backup(tmp_path):
    # Lines in the syntax of a 30i-class parameter backup, as quoted in issue 9
    # ("N03620Q1A1P40A2P140", "N01240Q1A1P0.0A2P0.0A3P0.0", "N03624Q1A1P40.0",
    # "N10000Q0P0"); no public backup with pitch data was found in the search index.
    (tmp_path / PARAM_FILE).write_text(
        "%\nN00000Q0P00000010\nN01240Q1A1P0.0A2P0.0A3P0.0\nN01320Q1A1P1000.0A2P500.0A3P0.0\n"
        "N03620Q1A1P40A2P140A3P240\nN03621Q1A1P40A2P140A3P240\nN03622Q1A1P42A2P141A3P241\n"
        "N03623Q1A1P1A2P2A3P1\nN03624Q1A1P40.0A2P40.0A3P40.0\n%\n")
    (tmp_path / PITCH_FILE).write_text(
        "%\nN10040Q0P0\nN10041Q0P3\nN10042Q0P-2\nN10140Q0P0\nN10141Q0P-1\n"
        "N10240Q0P0\nN10241Q0P7\n%\n")
    x, y, z = read_fanuc(tmp_path, "correction", reference_mm=(0, 0, 0))
    np.testing.assert_allclose(x.positions, [-40, 0, 40, 80])
    np.testing.assert_allclose(x.values, [0, 0, 3, 1])  # incremental -> absolute
    np.testing.assert_allclose(y.values, [0, 0, -2])  # magnification 2
    np.testing.assert_allclose(z.values, [0, 0, 7])


def test_siemens_cec_syntax_and_activation(tmp_path, machine):
    from volcal.compensate.siemens import CEC_FILE, LEC_FILE

    write_compensation(machine, "siemens", tmp_path, CompensationOptions(spacing=50.0))
    cec = (tmp_path / CEC_FILE).read_text().splitlines()
    # K3 syntax: the axis name in parentheses
    assert "$AN_CEC_INPUT_AXIS[0]=(AX1)" in cec and "$AN_CEC_OUTPUT_AXIS[0]=(AX2)" in cec
    text = "\n".join(cec)
    for key in ("MD18342 $MN_MM_CEC_MAX_POINTS", "MD32710 $MA_CEC_ENABLE",
                "SD41300 $SN_CEC_TABLE_ENABLE"):
        assert key in text
    assert "sign = error" in (tmp_path / LEC_FILE).read_text()  # K3: the LEC wants the error
