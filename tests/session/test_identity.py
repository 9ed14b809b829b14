"""Identity and circumstances in session.toml: [machine] keys, [calibration], [[equipment]]."""

from __future__ import annotations

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session
from volcal.session.identity import (
    MachineIdentity,
    expired_equipment,
    parse_date,
    same_machine,
)

IDENT = """
[calibration]
date = 2026-11-23
operator = "A. Technician"
customer = "Shop Ltd"
laboratory = "volcal lab"

[[equipment]]
role = "laser"
make = "Renishaw"
model = "XL-80"
serial = "L123"
certificate = "C-17"
calibrated = 2025-10-01
due = 2026-10-01

[[equipment]]
role = "air sensor"
serial = 445
calibrated = "2026-06-01"
due = "2027-06-01"
"""


def _planned(tmp_path, extra: str = "", machine: str = ""):
    s = plan_session([[0, 800], [0, 600], [0, 500]], "XYFZ", steps=3, tests=("linear",))
    write_session(s, tmp_path / "S")
    p = tmp_path / "S" / "session.toml"
    text = p.read_text()
    text = text.replace("[machine]\n", "[machine]\n" + machine, 1) + extra
    p.write_text(text)
    return tmp_path / "S"


def test_identity_round_trip(tmp_path):
    folder = _planned(tmp_path, IDENT, 'make = "DMG"\nserial = "S-99"\ncontrol = "Fanuc 31i"\n')
    s = read_session(folder, require_deviation=False)
    assert s.identity.make == "DMG" and s.identity.serial == "S-99"
    assert s.calibration["date"] == "2026-11-23" and s.calibration["operator"] == "A. Technician"
    assert [e["role"] for e in s.equipment] == ["laser", "air sensor"]
    assert s.equipment[1]["serial"] == "445"  # a number typed without quotes is kept as text
    # the laser was due on 2026-10-01, before the measurement: expired; the sensor is not
    assert [e["serial"] for e in expired_equipment(s.equipment, s.calibration["date"])] == ["L123"]
    write_session(s, tmp_path / "T")
    t = read_session(tmp_path / "T", require_deviation=False)
    assert t.calibration == s.calibration and t.equipment == s.equipment
    assert t.identity == s.identity


@pytest.mark.parametrize("extra, where", [
    ('[calibration]\ndate = "23.11.2026"\n', "column 'calibration.date'"),
    ('[calibration]\noperator = 3.5\n', "column 'calibration.operator'"),
    ('[[equipment]]\nmake = "Renishaw"\n', "column 'equipment[1].role'"),
    ('[[equipment]]\nrole = "laser"\ncalibrated = 2026-01-01\ndue = 2025-01-01\n',
     "column 'equipment[1].due'"),
    ('calibration = 3\n', "column 'calibration'"),
])
def test_identity_bad_input(tmp_path, extra, where):
    folder = _planned(tmp_path, "")
    p = folder / "session.toml"
    text = p.read_text()
    if extra.startswith("calibration ="):
        head = 'format = "volcal-session/1"\n'
        text = text.replace(head, head + extra)
    else:
        text += "\n" + extra
    p.write_text(text)
    with pytest.raises(VolcalInputError) as exc:
        read_session(folder, require_deviation=False)
    assert where in str(exc.value) and "session.toml" in str(exc.value)


def test_same_machine_rules():
    t = ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0))
    a = MachineIdentity("VMC-800", "XYFZ", t, make="DMG", serial="1")
    assert same_machine(a, MachineIdentity("renamed", "XYFZ", t, serial="1")) == (True, "")
    ok, why = same_machine(a, MachineIdentity("VMC-800", "XYFZ", t, serial="2"))
    assert not ok and why == "serial '1' is not '2'"
    g = MachineIdentity("FXYZ-1200", "FXYZ", ((0, 1200), (0, 800), (0, 600)))
    ok, why = same_machine(MachineIdentity("VMC-800", "XYFZ", t), g)
    assert not ok and "name 'VMC-800' is not 'FXYZ-1200'" in why and "chain XYFZ is not FXYZ" in why
    assert MachineIdentity.from_dict(a.to_dict()) == a
    assert a.digest() == MachineIdentity.from_dict(a.to_dict()).digest()
    assert np.isclose(len(a.digest()), 16)
    assert parse_date("2026-11-23T09:30:00Z") == "2026-11-23T09:30:00+00:00"
