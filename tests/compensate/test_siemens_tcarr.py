"""Siemens swivel data record ($TC_CARR) of an identified trunnion: the control's model maps
the machine's probed positions onto one sphere centre; a wrong sign does not."""

from __future__ import annotations

import re

import numpy as np
import pytest

from volcal.compensate.siemens_tcarr import (
    tcarr_export,
    tcarr_mpf,
    tcarr_to_workpiece,
    tcarr_values,
)
from volcal.errors import VolcalInputError
from volcal.measure.fiveaxis_virtual import nominal_machine, pose_grid, random_location
from volcal.measure.spheres import SphereReadings, probe_centres, simulate_blocks
from volcal.model.fiveaxis import location_parameter_names
from volcal_cli_helpers import volcal_process


def _parse(text: str, n: int = 1) -> dict[int, float | str]:
    out: dict[int, float | str] = {}
    for m in re.finditer(rf'^\$TC_CARR(\d+)\[{n}\]=(.+)$', text, re.M):
        v = m.group(2)
        out[int(m.group(1))] = v.strip('"') if v.startswith('"') else float(v)
    return out


def _machine(code):
    second = code[1]
    return nominal_machine(code, {"C": [200.0, 150.0, 10.0], second: [200.0, 150.0, -110.0]})


@pytest.mark.parametrize("code", ["CAFXYZ", "CBFXYZ"])
def test_record_of_a_machine_with_tilts_and_zeros_is_volcals_model(code):
    """Every location error (positions, tilts, zeros of both axes): the record's model, read
    back from the part program, puts the machine's tool point on one workpiece point at any
    pose; reversing the vectors (the table's sign) or dropping a tilt does not."""
    rng = np.random.default_rng(7)
    nominal = _machine(code)
    names = location_parameter_names(code)
    loc = random_location(code, rng)
    m = nominal.with_location([loc[n] for n in names])
    ang = pose_grid(code)
    w = np.array([350.0, 150.0, 50.0])
    q = probe_centres(m, ang, w)  # machine X Y Z that put the tool point on w
    first, second = code[1], "C"
    axes, vals = tcarr_values(m)
    assert axes == (first, second) and vals[23] == "P"
    exp = tcarr_export(m, [SphereReadings("p", "probe", ang, q, "S1", w, np.zeros(3))],
                       {"S1": w}, nominal)
    back = _parse(tcarr_mpf(exp))
    got = tcarr_to_workpiece(back, q, ang[first], ang[second])
    assert np.abs(got - w).max() < 1e-6  # mm: 1 nm
    assert exp.residual_um.max() < 1e-3 and exp.scatter_before_um.max() > 500.0
    flipped = dict(back)
    for i in range(7, 13):
        flipped[i] = -float(back[i])
    assert np.abs(tcarr_to_workpiece(flipped, q, ang[first], ang[second]) - w).max() > 1.0
    untilted = dict(back)
    untilted[10], untilted[11], untilted[12] = 0.0, 0.0, -1.0
    dev = np.abs(tcarr_to_workpiece(untilted, q, ang[first], ang[second]) - w).max()
    assert dev > 1e-3  # the C tilt of up to 200 urad matters at 150 mm off the axis


def test_identified_record_closes_within_the_noise():
    """A simulated probing (1 um noise) of a machine off by mm with tilts, identified: the
    record maps the true machine's noise-free positions onto one centre within 2 um, where
    the configured record scattered by millimetres."""
    from volcal.identify.location import identify_location
    from volcal.steps.locate import Located

    rng = np.random.default_rng(30)
    code = "CAFXYZ"
    nominal = _machine(code)
    names = location_parameter_names(code)
    truth = random_location(code, rng)
    truth = {n: (0.0 if n in ("EC0C", "EA0A") else v) for n, v in truth.items()}  # redundant
    true_m = nominal.with_location([truth[n] for n in names])
    ang = pose_grid(code)
    n = ang["C"].size
    design = [SphereReadings("p", "probe", ang, np.zeros((n, 3)), "S1",
                             np.array([350.0, 150.0, 50.0]), np.zeros(3))]
    sphere = {"S1": [350.4, 149.7, 50.2]}
    data = simulate_blocks(true_m, design, sphere, rng)
    exp = Located(identify_location(nominal, data), code, ("p",), (), tuple(data)).siemens_tcarr(3)
    text = tcarr_mpf(exp)
    assert "$TC_CARR23[3]=\"P\"" in text
    for phrase in ("source: SINUMERIK", "sign:", "activate:", "limits:", "not held:",
                   "predicted dispersion"):
        assert phrase in text, phrase
    q = simulate_blocks(true_m, design, sphere, rng, noise_scale=0.0)[0].values
    got = tcarr_to_workpiece(_parse(text, 3), q, ang["A"], ang["C"])
    spread = np.linalg.norm(got - got.mean(axis=0), axis=1) * 1e3
    assert spread.max() < 2.0 and exp.scatter_before_um.max() > 500.0


def test_refusals():
    with pytest.raises(VolcalInputError, match="trunnion"):
        tcarr_values(nominal_machine("FXYZCA", {"C": [0, 0, 0], "A": [0, 0, 0]}))
    m = _machine("CAFXYZ")
    with pytest.raises(VolcalInputError, match="record number"):
        tcarr_export(m, [], {}, m, carrier=0)


def test_locate_writes_the_record(tmp_path):
    s = tmp_path / "s"
    assert volcal_process("plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ",
                          "--tests", "probe_sphere:cb", "-o", str(s)).returncode == 0
    assert volcal_process("simulate", str(s), "--seed", "3").returncode == 0
    out = tmp_path / "carrier.mpf"
    p = volcal_process("locate", str(s), "--model", str(s / "truth" / "machine.csv"),
                       "--siemens-tcarr", str(out), "--tool-carrier", "2")
    assert p.returncode == 0, p.stdout + p.stderr
    vals = _parse(out.read_text(), 2)
    assert vals[23] == "P" and abs(float(vals[12]) + 1.0) < 1e-6  # C table reversed: -Z
    assert abs(float(vals[8]) + 1.0) < 1e-6  # B cradle: -Y
    assert out.read_text().rstrip().endswith("M30")
