"""Model -> controller table -> re-read -> agreement within the table's resolution."""

import numpy as np
import pytest

from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.fanuc import read_fanuc
from volcal.compensate.generic import read_generic
from volcal.compensate.heidenhain import read_heidenhain
from volcal.compensate.siemens import CEC_FILE, LEC_FILE, read_cec, read_lec
from volcal.compensate.volumetric import GRID_FILE, ISG_FILE, read_grid, read_isg
from volcal.measure.virtual import random_machine
from volcal.model.kinematics import volumetric_error

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 400.0]])
SIGNS = ("error", "correction")


@pytest.fixture(scope="module")
def machine():
    return random_machine(TRAVEL, "XYFZ", 11, n_nodes=9)


def _on_axis(k, p):
    """Points along axis k with the other axes at the start of travel [mm]."""
    q = np.tile(TRAVEL[:, 0], (p.size, 1))
    q[:, k] = p
    return q


def _expected(machine, k, out, p, s):
    """Error of the output axis while axis k moves on its reference line: exact model."""
    return s * volumetric_error(machine, _on_axis(k, p))[:, out]


def _check(table, machine, s, shift=0.0):
    exp = _expected(machine, table.input_axis, table.output_axis, table.positions, s) - shift
    assert np.max(np.abs(table.values - exp)) <= table.resolution_um / 2 + 1e-9
    assert np.allclose(np.diff(table.positions), table.spacing)
    lo, hi = TRAVEL[table.input_axis]
    assert table.positions[0] <= lo + 1e-9 and table.positions[-1] >= hi - 1e-9


@pytest.mark.parametrize("sign", SIGNS)
def test_fanuc(tmp_path, machine, sign):
    s = 1.0 if sign == "error" else -1.0
    ref = (400.0, 600.0, 100.0)  # middle, end, inside: all three Fanuc layouts
    write_compensation(machine, "fanuc", tmp_path, CompensationOptions(
        sign, spacing=25.0, reference_mm=ref, magnification=3, unit_um=1.0))
    tables = read_fanuc(tmp_path, sign, unit_um=1.0, reference_mm=ref)
    for k, t in enumerate(tables):
        assert t.resolution_um == 3.0
        assert 0.0 in np.round(t.positions - ref[k], 9)
        e_ref = _expected(machine, k, k, np.array([ref[k]]), s)[0]
        _check(t, machine, s, shift=e_ref)


@pytest.mark.parametrize("sign", SIGNS)
def test_siemens_lec_and_cec(tmp_path, machine, sign):
    s = 1.0 if sign == "error" else -1.0
    write_compensation(machine, "siemens", tmp_path, CompensationOptions(sign, spacing=30.0))
    lec = read_lec(tmp_path / LEC_FILE, sign)
    assert [(t.input_axis, t.output_axis) for t in lec] == [(0, 0), (1, 1), (2, 2)]
    cec = read_cec(tmp_path / CEC_FILE, sign)
    assert sorted((t.input_axis, t.output_axis) for t in cec) == [
        (a, b) for a in range(3) for b in range(3) if a != b]
    for t in lec + cec:
        _check(t, machine, s)
    # 400 mm / 30 mm -> 15 points, the last beyond the end of travel (held constant)
    assert lec[2].positions.size == 15 and lec[2].positions[-1] == 420.0


@pytest.mark.parametrize("sign", SIGNS)
def test_heidenhain(tmp_path, machine, sign):
    s = 1.0 if sign == "error" else -1.0
    write_compensation(machine, "heidenhain", tmp_path, CompensationOptions(sign, spacing=12.5))
    tables = read_heidenhain(tmp_path, sign)
    assert [t.input_axis for t in tables] == [0, 1, 2]
    for t in tables:
        assert t.resolution_um == 0.1
        _check(t, machine, s)


@pytest.mark.parametrize("sign", SIGNS)
def test_generic_csv(tmp_path, machine, sign):
    s = 1.0 if sign == "error" else -1.0
    write_compensation(machine, "csv", tmp_path, CompensationOptions(sign, spacing=40.0))
    tables = read_generic(tmp_path / "pitch.csv")
    for t in tables:
        assert t.sign == sign
        _check(t, machine, s)


@pytest.mark.parametrize("sign", SIGNS)
def test_isg_blocks_rebuild_the_model(tmp_path, machine, sign):
    s = 1.0 if sign == "error" else -1.0
    write_compensation(machine, "isg", tmp_path, CompensationOptions(sign, spacing=25.0))
    back, got_sign = read_isg(tmp_path / ISG_FILE)
    assert got_sign == sign and back.chain_obj.code == "XYFZ"
    for k in range(3):
        np.testing.assert_allclose(back.values[k], s * machine.component(k, back.nodes[k]),
                                   atol=0.0005 + 1e-9)
    np.testing.assert_allclose(back.squareness, s * machine.squareness, atol=0.0005 + 1e-9)
    # the model's nodes (every 100, 75, 50 mm) lie on the 25 mm grid: the resampled model
    # is the model, so volumetric errors agree to the rounding (0.0005 um, 0.0005 urad x 1 m)
    q = np.random.default_rng(2).uniform(TRAVEL[:, 0], TRAVEL[:, 1], (500, 3))
    t = np.array([10.0, -20.0, 150.0])
    np.testing.assert_allclose(volumetric_error(back, q, t), s * volumetric_error(machine, q, t),
                               atol=0.004)


@pytest.mark.parametrize("sign", SIGNS)
def test_grid(tmp_path, machine, sign):
    s = 1.0 if sign == "error" else -1.0
    write_compensation(machine, "grid", tmp_path,
                       CompensationOptions(sign, spacing=100.0, tool_offset=(0.0, 0.0, 120.0)))
    pts, e, got_sign = read_grid(tmp_path / GRID_FILE)
    assert got_sign == sign
    assert pts.shape == (9 * 7 * 5, 3)
    np.testing.assert_allclose(e, s * volumetric_error(machine, pts, [0, 0, 120.0]),
                               atol=0.0005 + 1e-9)


@pytest.mark.parametrize("spoil, where", [
    (lambda lines, i: lines.__setitem__(i, " ".join(lines[i].split()[:4])), "expected 7"),
    (lambda lines, i: lines.__setitem__(i, lines[i].replace(lines[i].split()[1], "x", 1)),
     "not a number"),
])
def test_damaged_isg_file_is_a_clear_error(tmp_path, machine, spoil, where):
    from volcal.errors import VolcalInputError

    write_compensation(machine, "isg", tmp_path, CompensationOptions("error", spacing=25.0))
    path = tmp_path / ISG_FILE
    lines = path.read_text().splitlines()
    i = next(j for j, t in enumerate(lines) if t and t[0].isdigit() and len(t.split()) == 7)
    spoil(lines, i)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(VolcalInputError, match=f"{ISG_FILE}, row {i + 1}: {where}"):
        read_isg(path)
