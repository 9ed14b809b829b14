"""The ``rotary`` kind: session keys and CSV, plan, simulation truth, readings helper.

The contract every kind passes runs on it in ``test_kind_contract.py`` (reader round
trip, refusals); here what is its own: the keys ``axis``, ``range_deg``, ``modulo``,
``mounting``, ``eccentricity_mm`` and ``[[machine.rotary_axes]]``, each refused naming the
file and the key; the CSV ``target_deg, run, direction, deviation_urad`` (or
``deviation_arcsec``) with ``missed``; the ISO 230-2 targets of ``volcal plan --tests
rotary:c``; the simulated readings against the hidden truth of the virtual axis.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.measure.rotary import ECCENTRICITY_URAD_PER_MM, RotaryAxisErrors, RotarySetup
from volcal.measure.simulate import SimulationOptions, simulate_session, truth_files
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session
from volcal.session.rotary import ARCSEC_URAD, RotaryAxis, rotary_readings
from volcal.standards.iso230_2_rotary import evaluate_rotary_measurement
from volcal_cli_helpers import run_volcal

TRAVEL = np.array([[0.0, 400.0], [0.0, 300.0], [0.0, 200.0]])


def planned(tmp_path, **rotary):
    s = plan_session(TRAVEL, tests=["rotary:c"], steps=6, runs=2, rotary=rotary)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=1), SimulationOptions(seed=3))
    write_session(s, tmp_path / "s")
    return tmp_path / "s"


@pytest.mark.parametrize("old,new,key,words", [
    ('axis = "c"', 'axis = "z"', "measurements[0].axis", "axis must be \"a\", \"b\" or \"c\""),
    ('axis = "c"', 'axes = "c"', "measurements[0].axis", "missing axis"),
    ('modulo = true\nmounting', 'modulo = "yes"\nmounting', "measurements[0].modulo",
     "expected true or false"),
    ('range_deg = [0.0, 360.0]\nmodulo = true\nmounting', 'range_deg = [0.0, 400.0]\nmodulo '
     '= true\nmounting', "measurements[0].range_deg", "spans at most 360 deg"),
    ('mounting = "on_axis"', 'mounting = "eccentric"', "measurements[0].mounting",
     "expected one of on_axis, off_axis"),
    ('mounting = "on_axis"', 'mounting = "off_axis"', "measurements[0].eccentricity_mm",
     "needs eccentricity_mm"),
    ('mounting = "on_axis"', 'mounting = "off_axis"\neccentricity_mm = -1',
     "measurements[0].eccentricity_mm", "between 0 and 100"),
    ('name = "c"\nrange_deg = [0.0, 360.0]\nmodulo = true',
     'name = "c"\nrange_deg = [0.0, 360.0]\nmodulo = true\nspeed = 3',
     "machine.rotary_axes[0].speed", "unknown key 'speed'"),
    ('name = "c"\nrange_deg = [0.0, 360.0]\nmodulo = true',
     'name = "c"\nrange_deg = [0.0, 180.0]\nmodulo = true', "measurements[0].range_deg",
     "leaves the range of axis c in [machine]"),
    ('name = "c"\nrange_deg = [0.0, 360.0]\nmodulo = true',
     'name = "c"\nrange_deg = [0.0, 360.0]\nmodulo = false', "measurements[0].modulo",
     "[machine] lists axis c with modulo = false"),
    ('name = "c"\nrange_deg = [0.0, 360.0]', 'name = "q"\nrange_deg = [0.0, 360.0]',
     "machine.rotary_axes[0].name", "axis must be"),
])
def test_a_bad_key_is_refused_naming_the_file_and_key(tmp_path, old, new, key, words):
    s = planned(tmp_path)
    toml = s / "session.toml"
    text = toml.read_text()
    assert old in text, old
    toml.write_text(text.replace(old, new, 1))
    with pytest.raises(VolcalInputError) as exc:
        read_session(s)
    assert (exc.value.file, exc.value.column) == (str(toml), key)
    assert words in exc.value.message


@pytest.mark.parametrize("row,column,value,words", [
    (3, "deviation_urad", "abc", "number"),
    (4, "target_deg", "400", "outside the axis' range_deg [0, 360]"),
    (2, "deviation_urad", "missed", "the first row is the reference"),
    (5, "direction", "up", ""),
])
def test_a_bad_cell_is_refused_naming_file_row_and_column(tmp_path, row, column, value, words):
    s = planned(tmp_path)
    csv = s / "rotary-c.csv"
    lines = [ln.split(",") for ln in csv.read_text().splitlines()]
    lines[row - 1][lines[0].index(column)] = value
    csv.write_text("\n".join(",".join(c) for c in lines) + "\n")
    with pytest.raises(VolcalInputError) as exc:
        read_session(s)
    assert (exc.value.file, exc.value.row, exc.value.column) == (str(csv), row, column)
    assert words in exc.value.message


def test_deviation_arcsec_and_missed_captures_are_read(tmp_path):
    s = planned(tmp_path)
    back = read_session(s).measurements[0]
    csv = s / "rotary-c.csv"
    lines = csv.read_text().splitlines()
    head = lines[0].split(",")
    k = head.index("deviation_urad")
    head[k] = "deviation_arcsec"
    rows = [head]
    for i, line in enumerate(lines[1:]):
        cells = line.split(",")
        cells[k] = "missed" if i == 6 else f"{float(cells[k]) / ARCSEC_URAD:.9f}"
        rows.append(cells)
    csv.write_text("\n".join(",".join(r) for r in rows) + "\n")
    s2 = read_session(s)
    m = s2.measurements[0]
    assert m.n == back.n - 1 and len(m.missed) == 1 and m.missed[0]["row"] == 8
    assert m.missed[0]["target_deg"] == back.columns["target_deg"][6]
    keep = np.delete(np.arange(back.n), 6)
    np.testing.assert_allclose(m.deviation, back.deviation[keep], atol=5e-8)
    assert any("missed capture skipped" in n for n in s2.notes)
    # the helper: per target, direction and run
    r = rotary_readings(m)
    assert r.targets_deg[0] == 0.0 and r.targets_deg[-1] == 360.0
    assert r.up.shape == (7, 2) and r.closure_pairs == [(0, 6)]
    t6 = back.columns["target_deg"][6]  # the missed one: run 1, '+', the last target
    assert np.isnan(r.up[list(r.targets_deg).index(t6), 0])
    j = int(np.flatnonzero((back.columns["run"] == 2) & (back.columns["direction"] == "-")
                           & (back.columns["target_deg"] == r.targets_deg[2]))[0])
    assert r.down[2, 1] == pytest.approx(back.deviation[j], abs=5e-8)


def test_plan_spreads_iso_targets_over_the_range(tmp_path, monkeypatch, capsys):
    code, out, err = run_volcal(monkeypatch, capsys, "plan", "-o", str(tmp_path / "p"),
                                "--tests", "rotary:c,rotary:a", "--rotary-axes",
                                "a:-120:30:limited")
    assert code == 0, err
    doc = tomllib.loads((tmp_path / "p" / "session.toml").read_text())
    axes = {a["name"]: a for a in doc["machine"]["rotary_axes"]}
    assert axes["a"] == {"name": "a", "range_deg": [-120.0, 30.0], "modulo": False}
    assert axes["c"] == {"name": "c", "range_deg": [0.0, 360.0], "modulo": True}
    s = read_session(tmp_path / "p", require_deviation=False)
    c, a = s.get("rotary-c"), s.get("rotary-a")
    for m in (c, a):  # 5 bidirectional runs by default, up then down each run
        assert sorted(set(m.columns["run"])) == [1, 2, 3, 4, 5]
        t = np.unique(m.columns["target_deg"])
        inner = t[1:-1]
        assert inner.size >= 8
        # not all multiples of a round angle: the periodic errors are sampled at many phases
        assert np.count_nonzero(np.abs(inner - np.round(inner)) > 1e-6) >= inner.size - 1
        assert np.ptp(np.diff(t)) > 0.2 * np.mean(np.diff(t))
    tc = np.unique(c.columns["target_deg"])
    assert tc[0] == 0.0 and tc[-1] == 360.0  # both ends of the full circle
    ta = np.unique(a.columns["target_deg"])
    assert ta[0] == pytest.approx(-118.0) and ta[-1] == pytest.approx(28.0)  # overrun room
    code, out, err = run_volcal(monkeypatch, capsys, "plan", "-o", str(tmp_path / "q"),
                                "--tests", "rotary:b", "--targets", "0,33.3,71,359.5")
    assert code == 0, err
    m = read_session(tmp_path / "q", require_deviation=False).measurements[0]
    assert list(np.unique(m.columns["target_deg"])) == [0.0, 33.3, 71.0, 359.5]
    code, out, err = run_volcal(monkeypatch, capsys, "plan", "-o", str(tmp_path / "r"),
                                "--tests", "rotary:a", "--rotary-axes", "a:-30:30",
                                "--targets", "-40,0,20")
    assert code == 2 and "--targets: the angles must lie in the range of axis A" in err


def test_simulation_reads_the_hidden_truth_of_the_virtual_axis(tmp_path):
    """Readings = the virtual axis' error (smooth + once + twice per revolution + reversal)
    + the eccentric mounting, counted from the first reading, + noise; the truth file
    holds the axis, and ISO 230-2 of the simulated readings finds its E."""
    axis = RotaryAxisErrors("c", (0.0, 360.0), True, (0.0, 40.0, -20.0), 12.0, 0.4, 5.0,
                            1.1, 6.0)
    machine = random_machine(TRAVEL, "XYFZ", seed=1)
    machine.rotary = {"c": axis}  # type: ignore[attr-defined]
    s = plan_session(TRAVEL, tests=["rotary:c"], steps=10, runs=5,
                     rotary={"mounting": "off_axis", "eccentricity_mm": 1.0})
    o = SimulationOptions(seed=7, noise_um=0.2)
    setups = simulate_session(s, machine, o)
    m = s.measurements[0]
    st = setups[m.id]
    assert isinstance(st, RotarySetup) and st.axis is axis and st.eccentricity_mm == 1.0
    t, d = m.columns["target_deg"], m.columns["direction"]
    th = np.radians(t)
    u = t / 360.0
    truth = (u * (1 - u) * (40.0 - 20.0 * u) + 12.0 * np.sin(th + 0.4)
             + 5.0 * np.sin(2 * th + 1.1) + np.where(d == "-", 6.0, 0.0)
             + ECCENTRICITY_URAD_PER_MM * np.sin(th + st.eccentricity_phase_rad))
    truth = truth - truth[0]
    resid = m.deviation - truth
    assert 0.1 < np.std(resid) < 0.3 and np.max(np.abs(resid)) < 1.2  # the noise only
    assert ECCENTRICITY_URAD_PER_MM == pytest.approx(0.5 * ARCSEC_URAD)
    doc = tomllib.loads(truth_files(machine, setups, o)["truth/setup.toml"])
    assert doc["setup"][m.id]["rotary_axis"]["once_urad"] == 12.0
    # ISO 230-2 of the readings: the reversal is the axis' (B mean = -6 urad) and E is the
    # range of the truth's means within the noise
    res = evaluate_rotary_measurement(m)
    assert res.iso.B_mean == pytest.approx(-6.0, abs=0.3)
    tu = np.unique(t)
    up = np.array([truth[(t == x) & (d == "+")].mean() for x in tu])
    dn = np.array([truth[(t == x) & (d == "-")].mean() for x in tu])
    assert res.iso.E == pytest.approx(np.ptp(np.concatenate([up, dn])), abs=0.5)
    assert res.closure_urad["up"] == pytest.approx(0.0, abs=0.5)


def test_the_rotary_kind_is_left_out_of_identify(tmp_path, monkeypatch, capsys):
    s = planned(tmp_path)
    code, out, err = run_volcal(monkeypatch, capsys, "identify", str(s), "-o",
                                str(tmp_path / "m.json"))
    assert code == 2 and "rotary tests are evaluated per axis" in err
    assert RotaryAxis("c").to_toml() == {"name": "c", "range_deg": [0.0, 360.0],
                                         "modulo": True}
