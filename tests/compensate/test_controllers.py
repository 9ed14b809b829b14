"""Compensation files read by independent readers and by each controller's own rule.

* HEIDENHAIN tables are read with pyLSV2's fixed-width table reader (it takes each column
  from where its header name starts): nobody on this team wrote it.
* LinuxCNC comp files are loaded and applied by LinuxCNC itself, in simulation
  (tests/compensate/test_linuxcnc_control.py).
* ISG CSV files are parsed by a parser written here from the published syntax (Beckhoff
  TF5280 "ISG CSV format") and checked on the documentation's own example first.
* Fanuc: the reader accepts lines of real 30i-class backups.
* The property: model -> table -> the controller's interpolation -> what is left equals the
  model error minus the table, within the table's resolution, for every format and sign.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.bidirectional import DirectionalErrors
from volcal.compensate.fanuc import (
    COORDINATE_PARAMETERS,
    PARAM_FILE,
    PITCH_FILE,
    parse_fanuc_parameters,
    read_fanuc,
)
from volcal.compensate.formats import FORMATS
from volcal.compensate.generic import read_generic
from volcal.compensate.heidenhain import read_heidenhain
from volcal.compensate.siemens import CEC_FILE, LEC_FILE, read_cec, read_lec
from volcal.compensate.volumetric import ISG_FILE
from volcal.measure.virtual import random_machine

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 400.0]])
AXES = "XYZ"


def _machine(seed: int):
    # nodes every 100, 75, 50 mm: on the 25 mm table grid, so linear interpolation of the
    # table reproduces the model exactly up to the rounding of the values
    return random_machine(TRAVEL, "XYFZ", seed, n_nodes=9)


# --- LinuxCNC ------------------------------------------------------------------------
# LinuxCNC itself loads and applies volcal's comp files (types 0 and 1, bidirectional) in
# tests/compensate/test_linuxcnc_control.py; it replaced the transcription of
# usrmotLoadComp that stood here.


def test_linuxcnc_too_many_entries_is_an_error(tmp_path):
    from volcal.errors import VolcalInputError

    with pytest.raises(VolcalInputError, match="limit of 256"):
        write_compensation(_machine(1), "linuxcnc", tmp_path / "o",
                           CompensationOptions(spacing=2.0))
    assert not (tmp_path / "o").exists()


# --- HEIDENHAIN: pyLSV2 ----------------------------------------------------------------

def test_heidenhain_tables_read_by_pylsv2(tmp_path):
    pytest.importorskip("pyLSV2")
    from pyLSV2.table_reader import NCTable

    m = _machine(5)
    rev = DirectionalErrors([None, np.array([0.0, 600.0]), None],
                            [None, np.array([-6.0, 2.0]), None], "lin-y")
    write_compensation(m, "heidenhain", tmp_path, CompensationOptions(spacing=25.0,
                                                                      directional=rev))
    for k, a in enumerate(AXES):
        t = NCTable.parse_table(tmp_path / f"{a}.COM")
        assert t.name == a and t.is_metric
        if not rev.has(k):  # no measured reversal: no BACKLASH column
            assert t.column_names == ["NR", "AXISPOS", a]
            pos = np.array([float(r["AXISPOS"]) for r in t.rows])
            val = np.array([float(r[a]) for r in t.rows]) * 1000
            np.testing.assert_allclose(val, m.component(k, pos)[:, k], atol=0.05 + 1e-9)
            continue
        assert t.column_names == ["NR", "AXISPOS", a, "BACKLASH"]
        rows = t.rows
        assert [int(r["NR"]) for r in rows] == list(range(len(rows)))
        pos = np.array([float(r["AXISPOS"]) for r in rows])
        val = np.array([float(r[a]) for r in rows]) * 1000
        back = np.array([float(r["BACKLASH"]) for r in rows]) * 1000
        err = m.component(k, pos)[:, k]
        half = rev.half_reversal(k, pos)
        np.testing.assert_allclose(val, err + half, atol=0.05 + 0.05 + 1e-9)  # default: error
        np.testing.assert_allclose(back, err - half, atol=0.05 + 0.05 + 1e-9)
    cma = NCTable.parse_table(tmp_path / "VOLCAL.CMA")
    assert cma.rows[0]["ACTIVE"] == "*" and cma.rows[0]["X"] == "X.COM"


# --- ISG / Beckhoff --------------------------------------------------------------------

DOC_EXAMPLE = """\
// The header contains the argument "X" and component errors.
X      EXX    EYX    EZX    EAX    EBX    ECX
0.0    0.02   0.01   0.07   0.00   0.0042 0.003
10.0   0.00   -0.1   0.01   0.00   0.0011 0.002
#
// The header only contains position errors.
Y0A    Z0A    X0B
0.1    0.2    0.11
"""
"""Beckhoff TF5280 documentation, "ISG CSV format" (its two examples, joined by the
documented file break '#')."""


def isg_parse(text):
    """The published rules: '//' comments, '#' file break, header then whitespace rows."""
    blocks, head = [], None
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("//"):
            continue
        if s.startswith("#"):
            head = None
            continue
        if head is None:
            head = s.split()
            blocks.append({h: [] for h in head})
            continue
        vals = [float(v) for v in s.split()]
        assert len(vals) == len(head)
        for h, v in zip(head, vals, strict=True):
            blocks[-1][h].append(v)
    return blocks


def test_isg_parser_reads_the_documentation_example():
    b = isg_parse(DOC_EXAMPLE)
    assert list(b[0]) == ["X", "EXX", "EYX", "EZX", "EAX", "EBX", "ECX"]
    assert b[0]["EYX"] == [0.01, -0.1] and b[1]["X0B"] == [0.11]


@pytest.mark.parametrize("sign", ["error", "correction"])
def test_isg_file_in_mm_and_rad_as_documented(tmp_path, sign):
    m = _machine(7)
    write_compensation(m, "isg", tmp_path, CompensationOptions(sign, spacing=25.0))
    text = (tmp_path / ISG_FILE).read_text()
    assert "," not in text.replace("//", "").split("\n", 8)[-1]  # whitespace, not commas
    blocks = isg_parse(text)
    s = 1.0 if sign == "error" else -1.0
    sq = next(b for b in blocks if "C0Y" in b)
    assert list(sq) == ["C0Y", "B0Z", "A0Z"]
    # resolution 0.001 urad = 1e-9 rad and 0.001 um = 1e-6 mm: half of it allowed
    np.testing.assert_allclose([sq[n][0] for n in sq], s * m.squareness * 1e-6, rtol=0,
                               atol=5e-10 + 1e-15)
    for k, a in enumerate(AXES):
        b = next(b for b in blocks if a in b and f"EX{a}" in b)
        pos = np.array(b[a])
        comp = m.component(k, pos)
        for j, c in enumerate(("EX", "EY", "EZ")):  # mm
            np.testing.assert_allclose(np.array(b[c + a]), s * comp[:, j] * 1e-3, rtol=0,
                                       atol=5e-7 + 1e-12)
        for j, c in enumerate(("EA", "EB", "EC")):  # rad
            np.testing.assert_allclose(np.array(b[c + a]), s * comp[:, 3 + j] * 1e-6, rtol=0,
                                       atol=5e-10 + 1e-15)


# --- Fanuc: real backup lines ------------------------------------------------------------

REAL_BACKUP = """\
%
N00000Q1P00001010
N01240Q1A1P0.0A2P0.0A3P0.0
N03620Q1A1P40A2P140A3P240
N03621Q1A1P0A2P100A3P200
N03622Q1A1P80A2P180A3P280
N03623Q1A1P1A2P1A3P1
N03624Q1A1P40.0A2P40.0A3P40.0
%
"""
"""Lines in the layout of a 30i-class parameter backup (the 1240 line as quoted from a
real backup in issue 9; 3620 as in public Fanuc pitch-data tools)."""


def test_fanuc_reader_accepts_real_backup_lines():
    p = parse_fanuc_parameters(REAL_BACKUP)
    assert p[1240] == {1: 0.0, 2: 0.0, 3: 0.0}
    assert p[3620] == {1: 40, 2: 140, 3: 240} and p[3624][2] == 40.0
    assert p[0] == {0: 1010.0}


# --- no format redefines the machine's coordinates ------------------------------------

@pytest.mark.parametrize("fmt", sorted(FORMATS))
def test_no_format_writes_coordinate_parameters(tmp_path, fmt):
    write_compensation(_machine(2), fmt, tmp_path, CompensationOptions(spacing=50.0,
                                                                       max_increment=100))
    for f in tmp_path.iterdir():
        text = f.read_text()
        if fmt == "fanuc" and f.name in (PARAM_FILE, PITCH_FILE):
            nums = {int(n) for n in re.findall(r"^N0*(\d+)Q1", text, re.M)}
            assert not nums & set(COORDINATE_PARAMETERS), nums
            assert nums <= {3605, 3620, 3621, 3622, 3623, 3624, 3626, 3627} or not nums
        # Siemens machine data for reference points / limits, LinuxCNC HOME or limits
        assert not re.search(r"\$MA_REFP|\$MA_POS_LIMIT|^HOME\s*=|^MIN_LIMIT|^MAX_LIMIT", text,
                             re.M)


# --- the property: what the controller leaves ------------------------------------------

def _tables(fmt, folder, sign):
    if fmt == "fanuc":
        return read_fanuc(folder, sign), "points"
    if fmt == "siemens":
        return read_lec(folder / LEC_FILE, sign) + read_cec(folder / CEC_FILE, sign), "linear"
    if fmt == "heidenhain":
        return read_heidenhain(folder, sign), "linear"
    if fmt == "linuxcnc":
        from volcal.compensate.linuxcnc import read_linuxcnc
        return read_linuxcnc(folder, sign), "linear"
    if fmt == "csv":
        return read_generic(folder / "pitch.csv"), "linear"
    raise AssertionError(fmt)


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), fmt=st.sampled_from(
    ["fanuc", "siemens", "heidenhain", "linuxcnc", "csv"]),
    sign=st.sampled_from(["error", "correction"]))
def test_controller_leaves_model_minus_table(tmp_path_factory, seed, fmt, sign):
    from volcal.compensate.tables import cross_values

    m = _machine(seed)
    out = tmp_path_factory.mktemp("c")
    write_compensation(m, fmt, out, CompensationOptions(sign, spacing=25.0,
                                                        max_increment=1000))
    tables, rule = _tables(fmt, out, sign)
    s = 1.0 if sign == "error" else -1.0
    for t in tables:
        k, o = t.input_axis, t.output_axis
        x = t.positions if rule == "points" else np.concatenate(
            [t.positions, 0.5 * (t.positions[1:] + t.positions[:-1])])
        x = x[(x >= TRAVEL[k, 0]) & (x <= TRAVEL[k, 1])]
        table_err = s * np.interp(x, t.positions, t.values)  # the table as an error [um]
        model = (m.component(k, x)[:, k] if k == o else cross_values(m, k, o, x))
        if fmt == "fanuc":  # zero at the reference (start of travel): a constant offset
            model = model - m.component(k, [TRAVEL[k, 0]])[0, k]
        left = model - table_err
        assert np.max(np.abs(left)) <= t.resolution_um / 2 + 1e-6, (fmt, k, o)
