"""The header block of a laser export -> [calibration] and the measurement's environment
(issue 20, Deliver 7), and what ``volcal import`` says it read."""

from __future__ import annotations

import tomllib

import pytest
from typer.testing import CliRunner

from volcal.cli import app
from volcal.errors import VolcalInputError
from volcal.importer.header import parse_header_date
from volcal.importer.laser_csv import import_csv, parse_mapping, read_laser_csv
from volcal.session.format import read_session

TRAVEL = [[0, 400], [0, 300], [0, 200]]
TABLE = ("Target (mm);Run;Dir;Error (um)\n" + "".join(
    f"{t};1;{d};{e}\n" for t, d, e in [(0, "fwd", "0,0"), (100, "fwd", "1,2"),
                                       (200, "fwd", "2,5"), (200, "bwd", "3,1"),
                                       (100, "bwd", "1,9"), (0, "bwd", "0,4")]))
HEADER = ("Renishaw LaserXL export\n"
          "Date:;20.11.2026\n"
          "Operator:;A. Technician\n"
          "Air temperature:;20,4;°C\n"
          "Air pressure:;1013,2;hPa\n"
          "Humidity:;45;%\n"
          "Material temperature:;68,9;°F\n")
MAP = "target=Target,run=Run,direction=Dir,deviation=Error"


def _cli(*args):
    r = CliRunner().invoke(app, [str(a) for a in args], env={"COLUMNS": "200"})
    r.returncode = r.exit_code
    return r


def test_import_reads_the_header_block_and_says_what_it_read(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text(HEADER + TABLE, encoding="cp1252")  # a Windows export: ° in cp1252
    s = tmp_path / "S"
    r = _cli("import", f, "--map", MAP, "--axis", "X", "--id", "lx", "--session", s,
             "--travel", "0:400,0:300,0:200")
    assert r.returncode == 0, r.output
    said = [ln for ln in r.stdout.splitlines() if ln.startswith("header:")]
    assert said == [
        "header: line 2 'Date: 20.11.2026' -> calibration.date = 2026-11-20 (day.month.year)",
        "header: line 3 'Operator: A. Technician' -> calibration.operator = A. Technician",
        "header: line 4 'Air temperature: 20,4 °C' -> environment.air_temperature_c = 20.4",
        "header: line 5 'Air pressure: 1013,2 hPa' -> environment.air_pressure_pa = 101320 "
        "(hPa -> Pa)",
        "header: line 6 'Humidity: 45 %' -> environment.humidity_pct = 45",
        "header: line 7 'Material temperature: 68,9 °F' -> environment.material_temperature_c "
        "= 20.5 (degF -> degC)",
    ]
    doc = tomllib.loads((s / "session.toml").read_text())
    assert doc["calibration"] == {"date": "2026-11-20", "operator": "A. Technician"}
    ses = read_session(s)
    assert ses.calibration == {"date": "2026-11-20", "operator": "A. Technician"}
    # 68.9 degF = (68.9 - 32) * 5/9 degC = 20.5 degC; 1013.2 hPa = 101320 Pa
    assert ses.get("lx").meta["environment"] == {
        "air_temperature_c": 20.4, "air_pressure_pa": 101320.0, "humidity_pct": 45.0,
        "material_temperature_c": 20.5}
    assert ses.get("lx").deviation.tolist() == [0.0, 1.2, 2.5, 3.1, 1.9, 0.4]


def test_mapped_labels_and_a_mistyped_one(tmp_path):
    text = ("Prüfprotokoll\nDatum der Messung: 2026-11-19\nPrüfer: B. Meier\n"
            "T Luft [°C]: 19,8\nDruck [mbar]: 998\nFeuchte: 51 %RH\n" + TABLE)
    f = tmp_path / "x.csv"
    f.write_text(text)
    m = parse_mapping(MAP + ",date=Datum der Messung,operator=Prüfer,air_temperature_c=T Luft,"
                      "air_pressure_pa=Druck,humidity_pct=Feuchte")
    t = read_laser_csv(f, m)
    assert t.calibration == {"date": "2026-11-19", "operator": "B. Meier"}
    assert t.environment == {"air_temperature_c": 19.8, "air_pressure_pa": 99800.0,
                             "humidity_pct": 51.0}
    bad = parse_mapping(MAP + ",air_temperature_c=T Luftt")
    with pytest.raises(VolcalInputError) as e:
        read_laser_csv(f, bad)
    assert str(e.value) == (
        f"{f}, row 7, column 'T Luftt': --map air_temperature_c=T Luftt: no column 'T Luftt' in "
        "the table's header line and no such field in the header lines above it (closest: "
        "'T Luft [°C]'); header lines: lines 1-6")
    # a mistyped column of the table: the closest name is the column
    g = tmp_path / "y.csv"
    g.write_text("Pos,Err,AirT\n0,0,20.0\n100,1,20.2\n")
    with pytest.raises(VolcalInputError) as e:
        read_laser_csv(g, parse_mapping("target=Pos,deviation=Err,air_temperature_c=AirTT"))
    assert str(e.value) == (
        f"{g}, row 1, column 'AirTT': --map air_temperature_c=AirTT: no column 'AirTT' in the "
        "table's header line and no such field in the header lines above it (closest: 'AirT'); "
        "header lines: none")


def test_environment_columns_still_read_per_reading(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text("Air temperature: 20.1 C\nPos,Err,AirT\n0,0,20.0\n100,1,20.2\n200,2,20.3\n")
    t = read_laser_csv(f, parse_mapping("target=Pos,deviation=Err,air_temperature_c=AirT"))
    assert t.columns["air_temperature_c"].tolist() == [20.0, 20.2, 20.3]
    assert t.environment == {}  # the column wins; the header's value is not looked for
    assert t.header == []


def test_existing_calibration_date_is_kept_and_the_difference_said(tmp_path):
    s = tmp_path / "S"
    f = tmp_path / "a.csv"
    f.write_text(HEADER + TABLE)
    import_csv(f, parse_mapping(MAP), "X", [0, 0, 0], s, "lx1", travel=TRAVEL)
    g = tmp_path / "b.csv"
    g.write_text(HEADER.replace("20.11.2026", "21.11.2026") + TABLE)
    r = import_csv(g, parse_mapping(MAP), "X", [0, 50, 0], s, "lx2")
    assert r.header_notes == [
        "calibration.date: the session says '2026-11-20', this export's header '2026-11-21'; "
        "the session's is kept (the export's is recorded in the measurement's import table)"]
    ses = read_session(s)
    assert ses.calibration["date"] == "2026-11-20"
    assert ses.get("lx2").meta["import"]["date"] == "2026-11-21"


def test_unrecognised_header_and_ambiguous_date_are_said_not_dropped(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text("Export v2\nSerial: 123\n" + TABLE)
    t = read_laser_csv(f, parse_mapping(MAP))
    assert t.header == []
    assert t.header_notes == [
        "lines 1-2 above the table: no date, operator or environment recognised (name them "
        "with --map date=<label>,operator=<label>,air_temperature_c=<label>,...)"]
    f.write_text("Date: 05/11/2026\n" + TABLE)
    t = read_laser_csv(f, parse_mapping(MAP))
    assert t.header == [] and t.header_notes == [
        "line 1 'Date: 05/11/2026' not read as date ('05/11/2026' is ambiguous (day/month or "
        "month/day): write it as YYYY-MM-DD); map it with --map date=<label> or leave it"]
    with pytest.raises(VolcalInputError) as e:
        read_laser_csv(f, parse_mapping(MAP + ",date=Date"))
    assert e.value.row == 1 and e.value.column == "Date"
    assert "cannot read '05/11/2026'" in e.value.message


def test_absurd_header_value_is_refused_when_mapped(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text("Air temperature: 204 °C\n" + TABLE)
    with pytest.raises(VolcalInputError) as e:
        read_laser_csv(f, parse_mapping(MAP + ",air_temperature_c=Air temperature"))
    assert e.value.message == ("--map air_temperature_c=Air temperature: cannot read '204 °C': "
                               "204 is outside the possible range -40..100")


@pytest.mark.parametrize("text,iso", [
    ("2026-11-20", "2026-11-20"), ("2026-11-20T14:32:05Z", "2026-11-20"),
    ("2026/11/20 14:32", "2026-11-20"), ("20.11.2026", "2026-11-20"),
    ("20/11/2026", "2026-11-20"), ("11/20/2026", "2026-11-20"), ("20 Nov 2026", "2026-11-20"),
    ("Nov 20, 2026", "2026-11-20"), ("20-Nov-2026", "2026-11-20"), ("3.2.2026", "2026-02-03"),
    ("07/07/2026", "2026-07-07"),
])
def test_vendor_dates(text, iso):
    assert parse_header_date(text)[0] == iso


@pytest.mark.parametrize("text", ["05/11/2026", "31.02.2026", "n/a", "2026"])
def test_not_a_date(text):
    with pytest.raises(ValueError):
        parse_header_date(text)


def test_planned_import_takes_the_header(tmp_path):
    import numpy as np

    from volcal.importer.planned import import_planned, planned_targets

    s = tmp_path / "P"
    r = _cli("plan", "--travel", "0:400,0:300,0:200", "--steps", "3", "--tests", "diagonal",
             "-o", s)
    assert r.returncode == 0, r.output
    m = read_session(s, require_deviation=False).get("diag-ppp")
    f = tmp_path / "d.csv"
    f.write_text("Operator, C. Lee\nAir pressure, 101.2 kPa\nPos (mm),Dev (um)\n" + "".join(
        f"{t:.4f},{k * 0.5}\n" for k, t in enumerate(planned_targets(m))))
    res = import_planned(f, parse_mapping("target=Pos,deviation=Dev"), s, "diag-ppp")
    assert res.header == [
        "line 1 'Operator: C. Lee' -> calibration.operator = C. Lee",
        "line 2 'Air pressure: 101.2 kPa' -> environment.air_pressure_pa = 101200 (kPa -> Pa)"]
    ses = read_session(s)
    assert ses.calibration == {"operator": "C. Lee"}
    got = ses.get("diag-ppp")
    assert got.meta["environment"] == {"air_pressure_pa": 101200.0}
    np.testing.assert_array_equal(got.deviation, [0.0, 0.5, 1.0, 1.5])


@pytest.mark.parametrize("switch,referred", [("Off", False), ("On", True)])
def test_the_material_compensation_field_sets_referred_to_20c(tmp_path, switch, referred):
    """Issue 25: the export says whether its software referred the readings to 20 C."""
    f = tmp_path / "x.csv"
    f.write_text(HEADER + f"Material compensation:;{switch}\n"
                 "Expansion coefficient:;11,5;ppm/°C\n" + TABLE, encoding="utf-8")
    s = tmp_path / "S"
    r = _cli("import", f, "--map", MAP, "--axis", "X", "--id", "lx", "--session", s,
             "--travel", "0:400,0:300,0:200")
    assert r.returncode == 0, r.output
    said = [ln for ln in r.stdout.splitlines() if ln.startswith("header:")]
    assert f"header: line 8 'Material compensation: {switch}' -> referred_to_20c = " \
           f"{str(referred).lower()}" in " ".join(said)
    assert "header: line 9 'Expansion coefficient: 11,5 ppm/°C' -> " \
           "environment.expansion_ppm_per_k = 11.5" in said
    doc = tomllib.loads((s / "session.toml").read_text())
    (m,) = doc["measurements"]
    assert m["referred_to_20c"] is referred
    assert m["environment"]["expansion_ppm_per_k"] == 11.5
    got = read_session(s).get("lx")
    dev = [0.0, 1.2, 2.5, 3.1, 1.9, 0.4]
    if referred:  # taken as they are
        assert got.deviation == pytest.approx(dev, abs=1e-9)
    else:  # referred by volcal at 20.5 C (68.9 F), steel 11.5 ppm/K: L / (1 + alpha dt)
        c = [0.0, 100.0, 200.0, 200.0, 100.0, 0.0]
        want = [((ci + di * 1e-3) / (1 + 11.5e-6 * 0.5) - ci) * 1e3
                for ci, di in zip(c, dev, strict=True)]
        assert got.deviation == pytest.approx(want, abs=1e-9)
        assert got.meta["referral"]["material_temperature_c"] == pytest.approx(20.5)
