"""Compensation tables know their machine and their model; the "after" is read from them.

* the manifest records the machine identity (volcal.session.identity) and the model digest;
* ``report --compensation`` / ``evaluate session --compensation`` refuse another machine's
  tables (the demo's VMC-800 grid on the FXYZ 1200 x 800 x 600 gantry) unless --force,
  warn about another model of the same machine and about an old manifest;
* the "after" is what the files hold: a table edited by hand changes it, and for every
  format the tables read back agree with the model they were written from to the
  table's resolution.
"""

from __future__ import annotations

import json
import sys
import tomllib

import numpy as np
import pytest

from compensate.gantry import GANTRY_TRAVEL, gantry_errors, write_gantry
from volcal.cli import main
from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.manifest import check_manifest, errors_digest, read_manifest
from volcal.compensate.readback import read_written_tables
from volcal.demo import DEMO_TRAVEL
from volcal.errors import VolcalInputError
from volcal.measure.virtual import random_machine
from volcal.session.errortable import write_error_table
from volcal.session.format import read_session
from volcal.session.identity import MachineIdentity


def _run(monkeypatch, capsys, *args):
    monkeypatch.setattr(sys, "argv", ["volcal", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return code, out.out, " ".join(out.err.split())


@pytest.fixture(scope="module")
def gantry(tmp_path_factory):
    return write_gantry(tmp_path_factory.mktemp("gantry"))


@pytest.fixture(scope="module")
def vmc_grid(tmp_path_factory):
    """What `volcal demo` writes: the VMC-800's 3-D error grid at 50 mm (seed 7)."""
    folder = tmp_path_factory.mktemp("demo") / "compensation"
    vm = random_machine(DEMO_TRAVEL, "XYFZ", 7, name="VMC-800")
    write_compensation(vm, "grid", folder, CompensationOptions("error", 50.0), "model.json")
    return folder


FOREIGN = ("{m}, column 'machine': the compensation tables in {c} were written for another "
           "machine, VMC-800 (chain XYFZ, travel 800 x 600 x 500 mm), not for this "
           "session's FXYZ-1200 (chain FXYZ, travel 1200 x 800 x 600 mm): name 'VMC-800' "
           "is not 'FXYZ-1200'; chain XYFZ is not FXYZ; travel [[0.0, 800.0], [0.0, 600.0], "
           "[0.0, 500.0]] mm is not [[0.0, 1200.0], [0.0, 800.0], [0.0, 600.0]] mm; write "
           "tables for this machine with `volcal compensate MODEL --session SESSION`, or "
           "give --force to use them anyway")


def test_manifest_records_machine_and_model(gantry, tmp_path, monkeypatch, capsys):
    session, model = gantry
    code, _, err = _run(monkeypatch, capsys, "compensate", str(model), "--format", "csv",
                        "-o", str(tmp_path / "c"), "--session", str(session))
    assert code == 0, err
    man = tomllib.loads((tmp_path / "c" / "volcal-compensation.toml").read_text())
    assert man["format"] == "volcal-compensation/2"
    assert man["machine"] == {"name": "FXYZ-1200", "chain": "FXYZ",
                              "travel_mm": GANTRY_TRAVEL.tolist()}
    assert man["machine"] == MachineIdentity.of(read_session(session)).to_dict()
    from volcal.session.errortable import read_error_table

    assert man["model"] == "model.csv" and man["model_sha256"] == errors_digest(
        read_error_table(model))
    assert len(man["model_sha256"]) == 64


def test_demo_grid_on_the_gantry_is_refused(gantry, vmc_grid, tmp_path, monkeypatch, capsys):
    session, model = gantry
    expected = FOREIGN.format(m=vmc_grid / "volcal-compensation.toml", c=vmc_grid)
    code, _, err = _run(monkeypatch, capsys, "report", str(session), "--compensation",
                        str(vmc_grid), "-o", str(tmp_path / "r"))
    assert code == 2 and err == f"error: {expected}"
    assert not (tmp_path / "r").exists()  # refused before identifying or writing anything
    code, _, err = _run(monkeypatch, capsys, "evaluate", "session", str(session),
                        "--tolerance-um", "Y=10", "--model", str(model), "--compensation",
                        str(vmc_grid))
    assert code == 2 and err == f"error: {expected}"
    # --force: used, with the same words as a warning
    code, out, err = _run(monkeypatch, capsys, "evaluate", "session", str(session),
                          "--tolerance-um", "Y=10", "--model", str(model), "--compensation",
                          str(vmc_grid), "--force", "--json")
    assert code == 0, err
    assert "warning --force: the compensation tables in" in err and "VMC-800" in err
    assert json.loads(out)["verdict"][0]["after_um"] is not None


def test_serial_numbers_decide(gantry, tmp_path, monkeypatch, capsys):
    """Same name, chain and travel but another serial: another machine."""
    session, model = gantry
    s2, _ = write_gantry(tmp_path / "other", serial="G-2")
    s1, _ = write_gantry(tmp_path / "one", serial="G-1")
    code, _, err = _run(monkeypatch, capsys, "compensate", str(model), "--format", "csv",
                        "-o", str(tmp_path / "c"), "--session", str(s1))
    assert code == 0, err
    man = read_manifest(tmp_path / "c")
    assert man["machine"]["serial"] == "G-1" and man["machine"]["make"] == "Gantry Works"
    code, _, err = _run(monkeypatch, capsys, "evaluate", "session", str(s2), "--tolerance-um",
                        "Y=10", "--model", str(model), "--compensation", str(tmp_path / "c"))
    assert code == 2
    assert "were written for another machine, FXYZ-1200 (Gantry Works, serial G-1) (chain " \
           "FXYZ, travel 1200 x 800 x 600 mm), not for this session's FXYZ-1200 (Gantry " \
           "Works, serial G-2)" in err and "serial 'G-1' is not 'G-2'" in err
    # the session without identity keys: name, chain and travel agree -> accepted
    code, _, err = _run(monkeypatch, capsys, "evaluate", "session", str(session),
                        "--tolerance-um", "Y=10", "--model", str(model), "--compensation",
                        str(tmp_path / "c"))
    assert code == 0, err


def test_other_model_of_the_same_machine_and_old_manifest_warn(gantry, tmp_path,
                                                               monkeypatch, capsys):
    session, model = gantry
    other = tmp_path / "other.csv"
    write_error_table(gantry_errors(0.012), other)  # another model of the gantry
    c = tmp_path / "c"
    code, _, err = _run(monkeypatch, capsys, "compensate", str(other), "--format", "csv",
                        "-o", str(c), "--session", str(session))
    assert code == 0, err
    d_other = read_manifest(c)["model_sha256"]
    from volcal.session.errortable import read_error_table

    d_model = errors_digest(read_error_table(model))
    assert d_other != d_model
    code, out, err = _run(monkeypatch, capsys, "evaluate", "session", str(session),
                          "--tolerance-um", "Y=10", "--model", str(model), "--compensation",
                          str(c), "--json")
    assert code == 0, err
    assert (f"warning the compensation tables in {c} were written from another model of "
            f"this machine: other.csv (sha256 {d_other[:12]}), not {model} (sha256 "
            f"{d_model[:12]}); the 'after' is what those tables do") in err
    # an old manifest (volcal-compensation/1: the machine's name only) -> a warning
    text = (c / "volcal-compensation.toml").read_text()
    head = text.split("[machine]")[0].replace('format = "volcal-compensation/2"',
                                               'format = "volcal-compensation/1"')
    (c / "volcal-compensation.toml").write_text('machine = "FXYZ-1200"\n' + head)
    code, out, err = _run(monkeypatch, capsys, "evaluate", "session", str(session),
                          "--tolerance-um", "Y=10", "--model", str(model), "--compensation",
                          str(c), "--json")
    assert code == 0, err
    assert (f"warning the compensation tables in {c} record no machine identity (an older "
            "manifest, machine 'FXYZ-1200'): volcal cannot check that they were written "
            "for FXYZ-1200") in err


def test_hand_edited_table_changes_the_after(gantry, tmp_path, monkeypatch, capsys):
    """The Y rows of pitch.csv set to 0 by hand: the tables no longer correct Y, so the
    per-axis 'after' equals the 'before' (it used to be resampled from the model)."""
    session, model = gantry
    c = tmp_path / "c"
    assert _run(monkeypatch, capsys, "compensate", str(model), "--format", "csv", "-o", str(c),
                "--session", str(session))[0] == 0

    def verdict():
        code, out, err = _run(monkeypatch, capsys, "evaluate", "session", str(session),
                              "--tolerance-um", "Y=5", "--model", str(model),
                              "--compensation", str(c), "--json")
        assert code == 0, err
        return json.loads(out)["verdict"][0]

    v = verdict()
    assert v["before_um"] > 7.5 and v["before"] == "fail"  # the worst Y line: y1 or y2
    assert v["after_um"] > 7.5  # y3 after the table (the Abbe line, see test_line_check)
    lines = (c / "pitch.csv").read_text().splitlines()
    edited = [ln if not ln.startswith("Y,") else ",".join(ln.split(",")[:3] + ["0.000"])
              for ln in lines]
    (c / "pitch.csv").write_text("\n".join(edited) + "\n")
    v2 = verdict()
    assert v2["after_um"] == pytest.approx(v2["before_um"], abs=1e-9)
    assert v2["after_um"] != pytest.approx(v["after_um"], abs=0.05)


def test_check_manifest_python(gantry):
    session, _ = gantry
    s = read_session(session)
    me = MachineIdentity.of(s)
    man = {"machine": me.to_dict(), "model_sha256": "a" * 64, "model": "m.json"}
    assert check_manifest(man, "c", me, "a" * 64) == []
    w = check_manifest(man, "c", me, "b" * 64, model_label="x.json")
    assert len(w) == 1 and "m.json (sha256 aaaaaaaaaaaa), not x.json (sha256 bbbbbbbbbbbb)" in w[0]
    bad = dict(man, machine={"name": "FXYZ-1200"})
    with pytest.raises(VolcalInputError, match=r"\[machine\]: not a machine identity"):
        check_manifest(bad, "c", me)


@pytest.mark.parametrize("fmt", ["fanuc", "siemens", "heidenhain", "linuxcnc", "csv", "isg",
                                 "grid"])
def test_tables_read_back_remove_the_model_error(tmp_path, fmt):
    """For every format: what the tables read back remove, at points between the table
    points, is the model's error as the controller's rule samples it (the grid and ISG:
    the whole volumetric error; the pitch formats: the positioning component;
    Siemens: with the straightness and squareness), within the values' rounding."""
    from volcal.model.kinematics import volumetric_error
    from volcal.report.carried import applied_correction, table_set_from_manifest

    travel = np.array([[0.0, 600.0], [0.0, 400.0], [0.0, 300.0]])
    e = random_machine(travel, "XYFZ", 11, name="m")
    write_compensation(e, fmt, tmp_path, CompensationOptions(None, 25.0, max_increment=1000))
    man = read_manifest(tmp_path)
    w = read_written_tables(tmp_path)
    rng = np.random.default_rng(0)
    q = rng.uniform(travel[:, 0], travel[:, 1], size=(200, 3))
    # an independent path: the carried components resampled from the model
    # (volcal.report.carried, what the 'after' used to be)
    ref = applied_correction(e, table_set_from_manifest(man, tmp_path), q)
    res = float(man["resolution_um"])
    tol = {"fanuc": res + 1e-6, "heidenhain": res / 2 * 1.01, "isg": 0.01,
           "grid": res / 2 + 1e-6}.get(fmt, res / 2 * 1.01 + 1e-9)
    assert np.max(np.abs(w.correction(q) - ref)) <= tol, fmt
    if fmt == "grid":  # and the grid removes nearly all of the volumetric error
        left = volumetric_error(e, q) - w.correction(q)
        assert np.max(np.linalg.norm(left, axis=1)) < 0.1 * np.max(
            np.linalg.norm(volumetric_error(e, q), axis=1))


@pytest.mark.parametrize("fmt", ["fanuc", "heidenhain", "linuxcnc"])
def test_bidirectional_tables_read_back_per_direction(tmp_path, fmt):
    """Forward table = EXX + B/2, reverse = EXX - B/2 (B = 3 um measured on X): read back
    from the files (Fanuc 3626/3627, Heidenhain BACKLASH, LinuxCNC's third column), the
    '+' and '-' corrections differ by B; without a direction their mean is EXX."""
    from volcal.compensate.bidirectional import DirectionalErrors

    travel = np.array([[0.0, 600.0], [0.0, 400.0], [0.0, 300.0]])
    e = random_machine(travel, "XYFZ", 5, name="m")
    t = np.linspace(0.0, 600.0, 7)
    rev = DirectionalErrors([t, None, None], [np.full(7, 3.0), None, None], "lx")
    write_compensation(e, fmt, tmp_path, CompensationOptions(None, 25.0, max_increment=1000,
                                                             directional=rev))
    w = read_written_tables(tmp_path)
    assert w.reverse is not None
    q = np.column_stack([np.linspace(3.0, 597.0, 50), np.full(50, 100.0), np.full(50, 50.0)])
    up = w.correction(q, direction=np.full(50, "+"))
    down = w.correction(q, direction=np.full(50, "-"))
    res = 1.0 if fmt == "fanuc" else (0.1 if fmt == "heidenhain" else 0.001)
    np.testing.assert_allclose(up[:, 0] - down[:, 0], 3.0, atol=res + 1e-9)
    np.testing.assert_allclose(up[:, 1:], down[:, 1:], atol=1e-12)
    mixed = w.correction(q, direction=np.array(["+", "-"] * 25))
    np.testing.assert_array_equal(mixed[0::2], up[0::2])
    np.testing.assert_array_equal(mixed[1::2], down[1::2])


def test_model_digest_survives_the_model_file(tmp_path, monkeypatch, capsys):
    """A model identified in memory and read back from its file: the same digest (the
    report identifies anew when no --model is given). Tables written from the model file
    without --session record the machine of the session the model was identified from."""
    from volcal.flow import Calibration
    from volcal.identify.modelfile import load_model_errors

    cal = Calibration.plan([[0, 400], [0, 300], [0, 200]], "XYFZ", 4, ("diagonal", "linear"),
                           2, name="M")
    cal.simulate(seed=1)
    r = cal.identify()
    r.to_json(tmp_path / "m.json")
    assert errors_digest(r.errors) == errors_digest(load_model_errors(tmp_path / "m.json"))
    code, _, err = _run(monkeypatch, capsys, "compensate", str(tmp_path / "m.json"),
                        "--format", "heidenhain", "-o", str(tmp_path / "c"))
    assert code == 0, err
    man = read_manifest(tmp_path / "c")
    assert man["machine"] == MachineIdentity.of(cal.session).to_dict()
    assert man["machine"]["travel_mm"] == [[0.0, 400.0], [0.0, 300.0], [0.0, 200.0]]
    assert man["model_sha256"] == errors_digest(r.errors)
    # identity keys the model file carries (a [machine] table) are recorded too
    doc = json.loads((tmp_path / "m.json").read_text())
    doc["machine"] = {"make": "Acme", "serial": "A-7"}
    (tmp_path / "m2.json").write_text(json.dumps(doc))
    code, _, err = _run(monkeypatch, capsys, "compensate", str(tmp_path / "m2.json"),
                        "--format", "csv", "-o", str(tmp_path / "c2"))
    assert code == 0, err
    assert read_manifest(tmp_path / "c2")["machine"] == {
        **MachineIdentity.of(cal.session).to_dict(), "make": "Acme", "serial": "A-7"}
    other = load_model_errors(tmp_path / "m.json")
    other.values[0][3, 0] += 1e-3  # 1 nm somewhere: another model
    assert errors_digest(other) != errors_digest(r.errors)


def test_report_pipeline_checks_and_shows_the_warnings(gantry, vmc_grid, tmp_path):
    """The report's pipeline (also the Python flow's) applies the same check and puts its
    warnings into the compensation section."""
    from types import SimpleNamespace

    from volcal.model.kinematics import volumetric_error
    from volcal.report.pipeline import compensation_summary
    from volcal.report.sections import ReportInputs, compensation_section

    session, model = gantry
    s = read_session(session)
    e = gantry_errors(0.012)  # another model of the gantry
    r = SimpleNamespace(errors=e, predict=lambda q: (volumetric_error(e, q),
                                                     np.zeros((len(q), 3))))
    with pytest.raises(VolcalInputError, match="written for another machine, VMC-800"):
        compensation_summary(r, s.travel, folder=vmc_grid, n=3, session=s)
    c = compensation_summary(r, s.travel, folder=vmc_grid, n=3, session=s, force=True)
    assert c.warnings[0].startswith("--force: the compensation tables in")
    c_dir = tmp_path / "c"
    write_compensation(gantry_errors(), "csv", c_dir, CompensationOptions(None, 20.0),
                       "model.csv", MachineIdentity.of(s))
    c = compensation_summary(r, s.travel, folder=c_dir, n=3, session=s, model_label="m2")
    assert len(c.warnings) == 1 and "another model of this machine: model.csv" in c.warnings[0]
    sec = compensation_section(ReportInputs(s, r, compensation=c))
    assert c.warnings[0] in sec.warnings
    # the 'after' is the tables' (EYY = 0.01 y), not the model's (0.012 y): left
    # e_y = 0.002 y - (y / 60) z 1e-3; over y, z in {0, 400, 800} x {0, 300, 600} the largest
    # is at y = 800, z = 600: 1.6 - 8 = -6.4 um (the model itself: 9.6 um at y = 800, z = 0)
    assert c.model_max_um == pytest.approx(9.6, abs=1e-6)
    assert c.left_max_um == pytest.approx(6.4, abs=0.001)


def test_error_table_of_another_machine_with_session_is_refused(gantry, tmp_path,
                                                                 monkeypatch, capsys):
    """--session labels the tables with the session's machine: an error table of another
    chain or travel is refused (--force writes them, with the reason as a warning)."""
    session, _ = gantry
    vm = random_machine(DEMO_TRAVEL, "XYFZ", 7, name="VMC-800")
    write_error_table(vm, tmp_path / "vmc.csv")
    args = ["compensate", str(tmp_path / "vmc.csv"), "--format", "csv", "--session",
            str(session)]
    code, _, err = _run(monkeypatch, capsys, *args, "-o", str(tmp_path / "c"))
    assert code == 2 and err == (
        f"error: {tmp_path / 'vmc.csv'}: the error table is not of this session's machine "
        "(chain XYFZ is not FXYZ; travel [[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]] mm is not "
        "[[0.0, 1200.0], [0.0, 800.0], [0.0, 600.0]] mm); the tables would be labelled "
        "FXYZ-1200; give --force to write them anyway")
    assert not (tmp_path / "c").exists()
    code, out, err = _run(monkeypatch, capsys, *args, "--force", "-o", str(tmp_path / "c"))
    assert code == 0, err
    assert "warning --force: the error table is not of this session's machine" in " ".join(
        err.split())  # on standard error
