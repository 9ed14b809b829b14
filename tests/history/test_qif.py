"""QIF 3 FPSTestType export: mapping and signs, round trip, schema validation, CLI."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import history_fixtures as _fx
import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal_cli_helpers import volcal_process

# pytest fixtures shared by the history tests (see history_fixtures.py)
history_two = _fx.history_two

NS = {"q": "http://qifstandards.org/xsd/qif3"}
TRAVEL = [[0, 800], [0, 600], [0, 500]]
ROOT = Path(__file__).resolve().parents[2]
RUN = [sys.executable, "-c", "from volcal.cli import main; main()"]

# The mapping as docs/history.md ("QIF 3 export") states it, written out independently of
# volcal.history.qif: QIF element -> (axis, component) of MachineErrors.values.
DOC_TABLE = {
    "XLinearity": (0, 0), "YLinearity": (1, 1), "ZLinearity": (2, 2),
    "XAxisRoll": (0, 3), "XAxisPitch": (0, 4), "XAxisYaw": (0, 5),
    "YAxisRoll": (1, 4), "YAxisPitch": (1, 3), "YAxisYaw": (1, 5),
    "ZAxisRoll": (2, 5), "ZAxisPitch": (2, 3), "ZAxisYaw": (2, 4),
    "XAxisStraightnessY": (0, 1), "XAxisStraightnessZ": (0, 2),
    "YAxisStraightnessX": (1, 0), "YAxisStraightnessZ": (1, 2),
    "ZAxisStraightnessX": (2, 0), "ZAxisStraightnessY": (2, 1),
}


def _schema():
    """The QIF 3.0 schema set: $VOLCAL_QIF_XSD or shared/qif3 beside the repository."""
    from volcal.history.qif import find_xsd

    xsd = find_xsd([ROOT.parent / "shared" / "qif3", ROOT / "shared" / "qif3"])
    if xsd is None:
        pytest.skip("the QIF 3.0 XSD set is not on this machine (volcal does not ship it: "
                    "put it in shared/qif3/ beside the repository or name it in "
                    "VOLCAL_QIF_XSD; docs/history.md, 'QIF 3 export')")
    pytest.importorskip("lxml")
    return xsd


@pytest.fixture(scope="module")
def machine():
    from volcal.measure.virtual import random_machine

    m = random_machine(TRAVEL, "XYFZ", seed=11)
    m.squareness[:] = [12.5, -7.25, 3.0]   # EC0Y, EB0Z, EA0Z [urad]
    return m


def _fps(path: Path) -> ET.Element:
    return ET.parse(path).getroot().find(".//q:CartesianCMMFPSTest", NS)


def test_every_error_in_its_element(tmp_path, machine):
    from volcal.history.qif import write_qif

    p = write_qif(machine, tmp_path / "m.qif")
    fps = _fps(p)
    names = [e.tag.split("}")[1] for e in fps]
    assert names[:18] == list(DOC_TABLE) and len(names) == 21
    for tag, (k, c) in DOC_TABLE.items():
        e = fps.find(f"q:{tag}", NS)
        assert int(e.get("n")) == machine.nodes[k].size
        x = np.array(e.find("q:DomainValues", NS).text.split(), dtype=float)
        v = np.array(e.find("q:RangeValues", NS).text.split(), dtype=float)
        np.testing.assert_array_equal(x, machine.nodes[k])          # [mm]
        np.testing.assert_array_equal(v, machine.values[k][:, c])   # [um] or [urad]
        unit = e.find("q:RangeLinearUnit" if c < 3 else "q:RangeAngularUnit", NS).text
        assert unit == ("um" if c < 3 else "urad")
    # the units the functions name are defined in the file, with their SI factors
    other = ET.parse(p).getroot().find(".//q:OtherUnits", NS)
    factors = {u.find("q:UnitName", NS).text: float(u.find(".//q:Factor", NS).text)
               for u in other}
    assert factors == {"um": 1e-6, "urad": 1e-6}
    sq = {t: float(fps.find(f"q:{t}", NS).text) for t in
          ("XYSquareness", "XZSquareness", "YZSquareness")}
    assert sq == pytest.approx({"XYSquareness": 12.5e-6, "XZSquareness": 7.25e-6,
                                "YZSquareness": 3.0e-6}, rel=1e-12)


@pytest.mark.parametrize("name,axes", [("EC0Y", (0, 1)), ("EB0Z", (0, 2)), ("EA0Z", (1, 2))])
def test_squareness_sign_is_qif_angle(tmp_path, name, axes):
    """QIF: positive squareness = the angle between the two axes exceeds 90 deg.

    The angle is measured on volcal's exact kinematic model of a machine with only that
    squareness error (100 urad), not taken from the mapping table.
    """
    from volcal.history.qif import write_qif
    from volcal.measure.virtual import random_machine
    from volcal.model.kinematics import exact_pose
    from volcal.model.names import SQUARENESS_NAMES

    m = random_machine(TRAVEL, "XYFZ", seed=1).scaled(0.0)
    m.squareness[SQUARENESS_NAMES.index(name)] = 100.0
    a, b = axes
    qa, qb = np.zeros(3), np.zeros(3)
    qa[a], qb[b] = 400.0, 400.0
    pa, _ = exact_pose(m, [qa])
    pb, _ = exact_pose(m, [qb])
    angle = np.arccos(pa[0] @ pb[0] / np.linalg.norm(pa[0]) / np.linalg.norm(pb[0]))
    tag = {(0, 1): "XYSquareness", (0, 2): "XZSquareness", (1, 2): "YZSquareness"}[axes]
    value = float(_fps(write_qif(m, tmp_path / "s.qif")).find(f"q:{tag}", NS).text)
    assert value == pytest.approx(angle - np.pi / 2, rel=1e-6)   # [rad], sign included
    assert abs(value) == pytest.approx(100e-6, rel=1e-6)


def test_round_trip(tmp_path, machine):
    from volcal.history.qif import read_qif, write_qif

    back = read_qif(write_qif(machine, tmp_path / "m.qif"), "XYFZ")
    for k in range(3):
        np.testing.assert_array_equal(back.nodes[k], machine.nodes[k])
        np.testing.assert_array_equal(back.values[k], machine.values[k])
    np.testing.assert_allclose(back.squareness, machine.squareness, rtol=1e-12)


def test_read_refuses_bad_files(tmp_path, machine):
    from volcal.history.qif import read_qif, write_qif

    p = write_qif(machine, tmp_path / "m.qif")
    bad = tmp_path / "bad.qif"
    bad.write_text(p.read_text().replace("<RangeAngularUnit>urad<", "<RangeAngularUnit>deg<",
                                         1))
    with pytest.raises(VolcalInputError, match="XAxisRoll.*mm/urad"):
        read_qif(bad, "XYFZ")
    bad.write_text("<QIFDocument/>")
    with pytest.raises(VolcalInputError, match="no CartesianCMMFPSTest"):
        read_qif(bad, "XYFZ")


def test_read_names_the_element_of_bad_numbers(tmp_path, machine):
    """Text that is no number: a VolcalInputError naming the element (was a TypeError)."""
    import re

    from volcal.history.qif import read_qif, write_qif

    text = write_qif(machine, tmp_path / "m.qif").read_text()
    bad = tmp_path / "bad.qif"
    bad.write_text(re.sub(r"<DomainValues>[^<]*<", "<DomainValues>0 ten 20<", text, count=1))
    with pytest.raises(VolcalInputError, match="XLinearity: values that are not numbers") as e:
        read_qif(bad, "XYFZ")
    assert e.value.column == "XLinearity" and e.value.file == str(bad)
    bad.write_text(re.sub(r"<(\w+Squareness\w*)>[^<]*</\1>", "", text, count=1))
    with pytest.raises(VolcalInputError, match="Squareness.*None is not a number") as e:
        read_qif(bad, "XYFZ")
    assert "Squareness" in e.value.column


def test_validates_against_qif3_xsd(tmp_path, machine):
    from volcal.history.qif import QifMachine, load_schema, validate_qif, write_qif

    schema = load_schema(_schema())
    info = QifMachine(name="VMC 1", make="Hermle", model="C 42", serial="42-1187",
                      travel_mm=TRAVEL, location="hall 2", date="2026-01-10",
                      due="2027-01-10")
    p = write_qif(machine, tmp_path / "m.qif", info)
    assert validate_qif(p, schema) == []
    # the validator is real: an element out of the XSD's order and a missing attribute fail
    text = p.read_text()
    swapped = text.replace("<XAxisRoll ", "<XAxisRollX ").replace("</XAxisRoll>",
                                                                  "</XAxisRollX>")
    (tmp_path / "b1.qif").write_text(swapped)
    assert any("XAxisRollX" in e for e in validate_qif(tmp_path / "b1.qif", schema))
    (tmp_path / "b2.qif").write_text(text.replace('idMax="2"', ""))
    assert any("idMax" in e for e in validate_qif(tmp_path / "b2.qif", schema))


@pytest.fixture(scope="module")
def stored(history_two):
    """One stored calibration (SQLite) of a simulated machine: db, id, model, folder."""
    from volcal.identify.modelfile import load_model

    a = history_two["a"]
    # the model as stored (rounded as the file holds it)
    return history_two["db"], history_two["id"], load_model(a / "model.json"), a


def test_cli_export_record(stored, tmp_path):
    from volcal.history.qif import read_qif

    db, rid, model, _ = stored
    out = tmp_path / "c.qif"
    # in-process (volcal_process: main(), its streams and exit code; the refusal below
    # is a real process)
    r = volcal_process("history", "export-qif", rid, "-o", out, "--db", db)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == str(out)
    back = read_qif(out, "XYFZ")
    for k in range(3):
        np.testing.assert_array_equal(back.values[k], model.errors.values[k])
    np.testing.assert_allclose(back.squareness, model.errors.squareness, rtol=1e-12)
    dev = ET.parse(out).getroot().find(".//q:CartesianCMM", NS)
    assert dev.find("q:SerialNumber", NS).text == "42-1187"
    assert dev.find(".//q:CalibrationDate", NS).text == "2026-01-10T00:00:00Z"
    assert dev.find(".//q:ExpirationDate", NS).text == "2027-01-10T00:00:00Z"  # 365 days
    assert float(dev.find("q:Size/q:XAxisLength", NS).text) == 800.0
    # one record, one document: exported again, the file is the same byte for byte
    from typer.testing import CliRunner

    from volcal.cli import app

    again = tmp_path / "again.qif"
    res = CliRunner().invoke(app, ["history", "export-qif", rid, "-o", str(again), "--db", db])
    assert res.exit_code == 0 and again.read_bytes() == out.read_bytes()


def test_cli_bad_record_id(stored, tmp_path):
    from typer.testing import CliRunner

    from volcal.cli import app

    db, _, _, _ = stored
    out = tmp_path / "x.qif"
    r = subprocess.run([*RUN, "history", "export-qif", "C999999", "-o", str(out), "--db", db],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "C999999" in r.stderr and "Traceback" not in r.stderr
    assert not out.exists()
    res = CliRunner().invoke(app, ["history", "export-qif", "M000001", "-o", str(out),
                                   "--db", db])
    assert isinstance(res.exception, VolcalInputError)
    assert "machine record, not a calibration" in str(res.exception)


def test_cli_model_file_validated(stored, tmp_path):
    _, _, model, tmp = stored
    xsd = _schema()
    out = tmp_path / "m.qif"
    r = subprocess.run([*RUN, "history", "export-qif", "--model", str(tmp / "model.json"),
                        "-o", str(out), "--xsd", str(xsd)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "validates against" in r.stderr
