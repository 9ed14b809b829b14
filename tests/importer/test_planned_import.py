"""Diagonal and step-diagonal readings imported into a planned session.

Round trip: ``volcal plan`` + ``volcal simulate`` give the truth; its readings are
exported by hand into vendor-like CSV files (other column names and order, mm instead
of um, decimal comma, a preamble, one row per step for the step diagonals), imported
with ``volcal import --measurement`` into a fresh copy of the plan, and compared with the
simulated readings.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from typer.testing import CliRunner

from volcal.cli import app
from volcal.errors import VolcalInputError
from volcal.importer import parse_mapping
from volcal.importer.planned import import_planned, planned_targets
from volcal.session.format import read_session

runner = CliRunner()


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """``P``: a plan (3 steps, 2 runs); ``S``: the same, simulated."""
    d = tmp_path_factory.mktemp("plan")
    r = runner.invoke(app, ["plan", "--travel", "0:400,0:300,0:200", "--steps", "3",
                            "--runs", "2", "-o", str(d / "P")])
    assert r.exit_code == 0, r.output
    shutil.copytree(d / "P", d / "S")
    r = runner.invoke(app, ["simulate", str(d / "S"), "--seed", "3"])
    assert r.exit_code == 0, r.output
    return d


def _fresh(planned, tmp_path):
    shutil.copytree(planned / "P", tmp_path / "P", dirs_exist_ok=True)
    return tmp_path / "P"


def _import(csv_text, mapping, session, mid, tmp_path, *extra):
    f = tmp_path / f"{mid}.csv"
    f.write_text(csv_text, encoding="utf-8")
    r = runner.invoke(app, ["import", str(f), "--map", mapping, "--session", str(session),
                            "--measurement", mid, *extra])
    return r, f


def _truth(planned, mid):
    return read_session(planned / "S").get(mid)


def test_diagonal_export_in_mm_with_decimal_comma(planned, tmp_path):
    s = _fresh(planned, tmp_path)
    m = _truth(planned, "diag-npp")
    dist = planned_targets(m)
    # vendor order: point, deviation [mm], distance [mm] rounded to 4 decimals
    lines = ["Diagonal test;npp;", "Operator;A. N. Other;", "Point;Dev. (mm);Distance (mm)"]
    lines += [f"{i + 1};{d / 1000:.9f};{t:.4f}".replace(".", ",")
              for i, (d, t) in enumerate(zip(m.deviation, dist, strict=True))]
    r, _ = _import("\n".join(lines) + "\n", "target=distance,deviation=dev.", s, "diag-npp",
                   tmp_path)
    assert r.exit_code == 0, r.output
    got = read_session(s, require_deviation=False).get("diag-npp")
    np.testing.assert_allclose(got.deviation, m.deviation, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(got.positions, m.positions)
    assert "run" not in got.columns  # a diagonal has none in the plan: none invented
    assert "deviation column 'Dev. (mm)': mm (detected from the header)" in r.output


def test_diagonal_export_of_absolute_readings(planned, tmp_path):
    # reading [um] along the beam from the start; deviation = reading - planned distance
    s = _fresh(planned, tmp_path)
    m = _truth(planned, "diag-ppn")
    dist = planned_targets(m)
    lines = ["Laser (um),Target (mm)"]
    lines += [f"{t * 1000 + d:.6f},{t:.3f}" for d, t in zip(m.deviation, dist, strict=True)]
    r, _ = _import("\n".join(lines) + "\n", "target=Target,reading=Laser", s, "diag-ppn",
                   tmp_path)
    assert r.exit_code == 0, r.output
    got = read_session(s, require_deviation=False).get("diag-ppn")
    # the readings are written with 1e-6 um resolution; the deviation is taken against the
    # plan's targets, not the file's rounded ones (which would err by up to 0.5 um)
    np.testing.assert_allclose(got.deviation, m.deviation, rtol=0, atol=2e-6)


@pytest.mark.parametrize("with_start", [True, False])
def test_step_diagonal_one_row_per_step(planned, tmp_path, with_start):
    s = _fresh(planned, tmp_path)
    m = _truth(planned, "step-pnp")
    dist = planned_targets(m)
    order = read_session(planned / "S").get("step-pnp").meta["axis_order"]
    assert order == "xyz"
    # columns in another order than the moves, in um; position of each step's corner
    lines = ["Z move (um),Step,Position (mm),X move (um),Y move (um)"]
    if with_start:
        lines.append(f",0,0,{m.deviation[0]:.6f},")
    for k in range(3):
        dx, dy, dz = m.deviation[1 + 3 * k: 4 + 3 * k]
        lines.append(f"{dz:.6f},{k + 1},{dist[3 + 3 * k]:.4f},{dx:.6f},{dy:.6f}")
    r, _ = _import("\n".join(lines) + "\n",
                   "target=Position,deviation=X move|Y move|Z move", s, "step-pnp", tmp_path)
    assert r.exit_code == 0, r.output
    got = read_session(s, require_deviation=False).get("step-pnp")
    np.testing.assert_allclose(got.deviation, m.deviation, rtol=0, atol=1e-9)
    assert ("no start row: the reading at the start is taken as 0" in r.output) != with_start


def test_step_diagonal_one_row_per_step_of_absolute_readings(planned, tmp_path):
    # readings [mm] along the beam after each move, counted from a laser datum 12.5 mm
    # away; targets in machine-like coordinates with the same offset
    s = _fresh(planned, tmp_path)
    m = _truth(planned, "step-npp")
    proj = planned_targets(m) + 12.5
    r_mm = proj + m.deviation / 1000.0
    lines = ["Step;Corner (mm);L1 (mm);L2 (mm);L3 (mm)", f"0;{proj[0]:.4f};{r_mm[0]:.12f};;"]
    for k in range(3):
        a, b, c = r_mm[1 + 3 * k: 4 + 3 * k]
        lines.append(f"{k + 1};{proj[3 + 3 * k]:.4f};{a:.12f};{b:.12f};{c:.12f}")
    text = "\n".join(lines).replace(".", ",") + "\n"
    r, _ = _import(text, "target=Corner,reading=L1|L2|L3", s, "step-npp", tmp_path)
    assert r.exit_code == 0, r.output
    got = read_session(s, require_deviation=False).get("step-npp")
    # 12 decimals of mm = 1e-9 um resolution of the export
    np.testing.assert_allclose(got.deviation, m.deviation, rtol=0, atol=2e-9)
    assert "targets counted from 12.5 mm: offset removed" in " ".join(r.output.split())


def test_step_diagonal_one_row_per_reading(planned, tmp_path):
    s = _fresh(planned, tmp_path)
    m = _truth(planned, "step-ppp")
    dist = planned_targets(m)
    lines = ["Err [nm];Pos [mm]"]
    lines += [f"{d * 1000:.3f};{t:.5f}" for d, t in zip(m.deviation, dist, strict=True)]
    r, _ = _import("\n".join(lines) + "\n", "target=Pos,deviation=Err", s, "step-ppp", tmp_path)
    assert r.exit_code == 0, r.output
    got = read_session(s, require_deviation=False).get("step-ppp")
    np.testing.assert_allclose(got.deviation, m.deviation, rtol=0, atol=1e-9)


def test_linear_wide_table_into_the_plan(planned, tmp_path):
    # a certificate of linear-x1 (2 runs, separate directions) fills the planned test
    s = _fresh(planned, tmp_path)
    m = _truth(planned, "linear-x1")
    x = m.positions[:, 0]
    tg = sorted(set(x.tolist()))
    cell = {(int(r), str(d), float(t)): v for r, d, t, v in
            zip(m.run, m.direction, x, m.deviation, strict=True)}
    lines = ["Target (mm),Run 1 + (um),Run 1 - (um),Run 2 + (um),Run 2 - (um)"]
    lines += [f"{t:g}," + ",".join(f"{cell[r, d, t]:.6f}" for r in (1, 2) for d in "+-")
              for t in tg]
    r, _ = _import("\n".join(lines) + "\n", "target=Target,deviation=Run*", s, "linear-x1",
                   tmp_path)
    assert r.exit_code == 0, r.output
    got = read_session(s, require_deviation=False).get("linear-x1")
    np.testing.assert_allclose(got.deviation, m.deviation, rtol=0, atol=1e-9)
    assert list(got.run) == list(m.run) and list(got.direction) == list(m.direction)


def _diag_export(m, extra_row=False, shift=None):
    dist = planned_targets(m)
    lines = ["Pos (mm),Dev (um)"]
    for i, (d, t) in enumerate(zip(m.deviation, dist, strict=True)):
        lines.append(f"{t + (shift if shift and i == 2 else 0):.4f},{d:.6f}")
    if extra_row:  # a reading beyond the planned end
        lines.append(f"{dist[-1] + 50:.4f},1.5")
    return "\n".join(lines) + "\n"


def _error(tmp_path, planned, text, mapping, mid, replace=False):
    s = _fresh(planned, tmp_path)
    f = tmp_path / "x.csv"
    f.write_text(text)
    before = (s / f"{mid}.csv").read_text()
    with pytest.raises(VolcalInputError) as e:
        import_planned(f, parse_mapping(mapping), s, mid, replace=replace)
    assert (s / f"{mid}.csv").read_text() == before  # nothing written
    return e.value, f


def test_wrong_row_count(planned, tmp_path):
    m = _truth(planned, "diag-ppp")
    e, f = _error(tmp_path, planned, _diag_export(m, extra_row=True), "target=Pos,deviation=Dev",
                  "diag-ppp")
    assert e.message == ("5 readings in the file, but 'diag-ppp' is planned with 4: one reading "
                         "per planned pose, in the planned order")
    assert (e.file, e.row, e.column) == (str(f), 6, None)


def test_target_off_the_plan(planned, tmp_path):
    m = _truth(planned, "diag-ppp")
    e, f = _error(tmp_path, planned, _diag_export(m, shift=0.5), "target=Pos,deviation=Dev",
                  "diag-ppp")
    t = planned_targets(m)[2]
    assert e.message == (f"target {round(t + 0.5, 4):g} mm does not match the plan of "
                         f"'diag-ppp': reading 3 is planned at {t:.6g} mm along the beam "
                         "(tolerance 0.01 mm); is this the right file, --measurement and "
                         "--units?")
    assert (e.file, e.row, e.column) == (str(f), 4, "Pos")


def test_step_table_with_wrong_rows_and_columns(planned, tmp_path):
    text = "P,a,b,c\n0,0,,\n10,1,2,3\n"
    e, f = _error(tmp_path, planned, text, "target=P,deviation=a|b|c", "step-ppp")
    assert e.message == ("2 rows in the per-step table, but 'step-ppp' is planned with 3 steps: "
                         "expected 4 rows (the start and one per step) or 3")
    e, f = _error(tmp_path, planned, text, "target=P,deviation=a|b", "step-ppp")
    assert e.message == ("--map names 2 move column(s) but each step of 'step-ppp' moves 3 "
                         "axes (in the order xyz)")


def test_unknown_measurement_and_measured_readings(planned, tmp_path):
    m = _truth(planned, "diag-ppp")
    s = _fresh(planned, tmp_path)
    f = tmp_path / "ok.csv"
    f.write_text(_diag_export(m))
    r = import_planned(f, parse_mapping("target=Pos,deviation=Dev"), s, "diag-ppp")
    np.testing.assert_allclose(r.measurement.deviation, m.deviation, atol=1e-9)
    with pytest.raises(VolcalInputError) as e2:
        import_planned(f, parse_mapping("target=Pos,deviation=Dev"), s, "diag-ppp")
    assert e2.value.message == ("measurement 'diag-ppp' has readings; give --replace to replace "
                                "them (the old ones are kept in backup/)")
    r = import_planned(f, parse_mapping("target=Pos,deviation=Dev"), s, "diag-ppp",
                       replace=True)
    assert any("kept in" in n for n in r.notes)
    assert list((s / "backup").iterdir())
    with pytest.raises(VolcalInputError) as e3:
        import_planned(f, parse_mapping("target=Pos,deviation=Dev"), s, "diag-xyz")
    assert e3.value.message.startswith("--measurement 'diag-xyz': no such measurement in the "
                                       "session (ids: step-ppp, ")
