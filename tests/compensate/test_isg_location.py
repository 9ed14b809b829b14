"""ISG/Beckhoff location errors (``volcal locate --isg-kinematics``): the ISG CSV format.

The file is read by a parser of the published ISG CSV rules (``//`` comments, ``#`` file
breaks, a header of names, rows of numbers; TF5280 "ISG CSV format"), independent of the
writer; its values are checked against the hidden truth of a simulation (units mm and rad,
"Units of measure") and the dispersion it leaves is recomputed from what was read.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from volcal.compensate.isg_location import isg_location_csv, isg_location_export
from volcal.measure.spheres import probe_centres
from volcal.model.fiveaxis import FiveAxisMachine, exact_pose5
from volcal.model.rotary import RotaryAxis
from volcal.steps.locate import locate
from volcal_cli_helpers import volcal_process


def _parse(text):
    """The published rules only: list of blocks, each {name: [values]}."""
    blocks, head = [], None
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("//"):
            continue
        if line.startswith("#"):
            head = None
            continue
        parts = line.split()
        if head is None:
            head = parts
            blocks.append({h: [] for h in head})
            continue
        assert len(parts) == len(head)
        for h, x in zip(head, parts, strict=True):
            blocks[-1][h].append(float(x))
    return blocks


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("isg") / "s"
    for args in (["plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ", "--tests",
                  "probe_sphere", "-o", str(folder)], ["simulate", str(folder), "--seed", "7"]):
        p = volcal_process(*args)
        assert p.returncode == 0, p.stdout + p.stderr
    return folder


def test_cli_writes_the_isg_file(simulated, tmp_path):
    out = tmp_path / "location_isg.csv"
    p = volcal_process("locate", str(simulated), "--model",
                       str(simulated / "truth" / "machine.csv"), "--isg-kinematics", str(out))
    assert p.returncode == 0, p.stdout + p.stderr
    assert "ISG location errors" in p.stdout + p.stderr
    text = out.read_text()
    centres, errors = _parse(text)
    # the centres of rotation: the configured pivots [mm]
    r = locate(simulated, model=simulated / "truth" / "machine.csv")
    assert centres == {f"P{c}{a}": [float(r.result.machine.rotary[a].pivot_mm[k])]
                       for a in "CA" for k, c in enumerate("XYZ")}
    assert set(errors) == {"X0C", "Y0C", "A0C", "B0C", "C0C", "Y0A", "Z0A", "B0A", "C0A",
                           "A0A"}
    # mm and rad, against the truth; the redundant ones (EC0C, EA0A) written as 0
    truth = tomllib.loads((simulated / "truth" / "setup.toml").read_text())[
        "setup"]["probe_sphere"]["location"]
    assert errors["X0C"][0] == pytest.approx(truth["EX0C"] * 1e-3, abs=3e-3)
    assert errors["Y0A"][0] == pytest.approx(truth["EY0A"] * 1e-3, abs=3e-3)
    assert errors["B0C"][0] == pytest.approx(truth["EB0C"] * 1e-6, abs=3e-6)
    assert errors["C0C"] == [0.0] and errors["A0A"] == [0.0]
    assert "chain CAXYZ" in text and "workpiece_axes 4" in text  # C A X Y before F
    assert "not determined by the readings (written as 0): C0C, A0A" in text


def test_residual_recomputed_from_the_file(simulated):
    """The dispersion the file leaves, recomputed from the parsed file with its own
    transforms: the pivots moved by the written errors and turned by the written angles."""
    r = locate(simulated, model=simulated / "truth" / "machine.csv")
    exp = r.isg_location()
    centres, errors = _parse(isg_location_csv(exp))
    ident = r.result.machine
    assert exp.scatter_before_um.max() > 1000.0 and exp.residual_um.max() < 1e-3
    # the control's machine, built from the parsed values (mm, rad -> um, urad)
    rot = {}
    for letter in ("C", "A"):
        names = {"C": ("X0C", "Y0C", "A0C", "B0C", "C0C"),
                 "A": ("Y0A", "Z0A", "B0A", "C0A", "A0A")}[letter]
        loc = {"E" + n: errors[n][0] * (1e3 if n[0] in "XYZ" else 1e6) for n in names}
        pivot = [centres[f"P{c}{letter}"][0] for c in "XYZ"]
        rot[letter] = RotaryAxis(letter, pivot, loc)
    control = FiveAxisMachine(ident.chain_obj, rot, ident.linear)
    sph = {k.rpartition(":")[0]: None for k in r.result.nuisances if k.endswith(":sx")}
    s = {sid: np.array([r.result.nuisances[f"{sid}:s{a}"] for a in "xyz"]) for sid in sph}
    for b in r.blocks:
        q = probe_centres(ident, b.angles, s[b.sphere], b.tool_offset_mm)
        p, _ = exact_pose5(control, q, b.angles, b.tool_offset_mm)
        np.testing.assert_allclose(np.linalg.norm(p - p.mean(axis=0), axis=1) * 1e3,
                                   exp.residual_um, atol=1e-6)


def test_component_errors_block_and_bad_centre(simulated):
    from volcal.compensate.isg_location import read_isg_location
    from volcal.errors import VolcalInputError

    r = locate(simulated, model=simulated / "truth" / "machine.csv")
    ident = r.result.machine
    c = ident.rotary["C"]
    nodes = np.array([0.0, 90.0, 180.0, 270.0])
    vals = np.zeros((4, 6))
    vals[:, 5] = [0.0, 10.0, -5.0, 3.0]  # ECC [urad]
    vals[:, 0] = [0.0, 1.0, 2.0, 1.0]  # EXC [um]
    rot = dict(ident.rotary)
    rot["C"] = RotaryAxis("C", c.pivot_mm, c.location, nodes, vals, True)
    m = FiveAxisMachine(ident.chain_obj, rot, ident.linear)
    nominal = m.with_location(np.zeros(10))
    exp = isg_location_export(m, r.blocks, _spheres(r), nominal)
    blocks = _parse(isg_location_csv(exp))
    comp = blocks[2]
    assert list(comp) == ["C", "EXC", "EYC", "EZC", "EAC", "EBC", "ECC"]
    assert comp["C"] == [0.0, 90.0, 180.0, 270.0, 360.0]  # periodic: 360 = 0
    assert comp["ECC"] == pytest.approx([0.0, 1e-5, -5e-6, 3e-6, 0.0])
    assert comp["EXC"] == pytest.approx([0.0, 1e-3, 2e-3, 1e-3, 0.0])
    back = read_isg_location(isg_location_csv(exp), nominal)
    np.testing.assert_allclose(back.rotary["C"].values, vals, atol=1e-9)
    lines = isg_location_csv(exp).splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith("PXC"))
    vals_line = lines[i + 1].split()
    vals_line[0] = str(float(vals_line[0]) + 1.0)
    lines[i + 1] = " ".join(vals_line)
    with pytest.raises(VolcalInputError, match="PXC"):
        read_isg_location("\n".join(lines), nominal)


def _spheres(r):
    out = {}
    for k, v in r.result.nuisances.items():
        sid, _, ax = k.rpartition(":")
        if ax in ("sx", "sy", "sz"):
            out.setdefault(sid, [0.0, 0.0, 0.0])["xyz".index(ax[1])] = v
    return out


def test_head_head_chain_and_round_trip_of_the_values():
    """A fork head (volcal FXYZCA): ISG chain XYZCA ("a conventional CA machine",
    P-VOLC-00007), no workpiece axes; every value read back in um and urad."""
    from volcal.compensate.isg_location import IsgLocationExport, read_isg_location

    loc = {"EX0C": 812.5, "EY0C": -40.25, "EA0C": 120.0, "EB0C": -35.5, "EC0C": 17.0,
           "EY0A": 1500.0, "EZ0A": -2.0, "EB0A": 60.0, "EC0A": -199.0, "EA0A": 5.5}
    rot = {"C": RotaryAxis("C", [0.0, 0.0, 450.0], {k: v for k, v in loc.items()
                                                     if k.endswith("C")}),
           "A": RotaryAxis("A", [0.0, 0.0, 300.0], {k: v for k, v in loc.items()
                                                     if k.endswith("A")})}
    m = FiveAxisMachine("FXYZCA", rot)
    nominal = m.with_location(np.zeros(10))
    exp = IsgLocationExport("XYZCA", 0, {"PXC": 0.0, "PYC": 0.0, "PZC": 450.0, "PXA": 0.0,
                                         "PYA": 0.0, "PZA": 300.0},
                            {n[1:]: v * (1e-3 if n[1] in "XYZ" else 1e-6)
                             for n, v in loc.items()})
    text = isg_location_csv(exp)
    assert "chain XYZCA" in text and "workpiece_axes 0" in text
    _, errors = _parse(text)
    assert errors["C0A"] == [pytest.approx(-1.99e-4)] and errors["X0C"] == [0.8125]
    back = read_isg_location(text, nominal)
    for r in "CA":
        for n, v in back.rotary[r].location.items():
            assert v == pytest.approx(loc[n], abs=1e-6), n
    full = isg_location_export(m, [], {}, nominal)
    assert (full.chain, full.workpiece_axes) == ("XYZCA", 0)
    assert full.errors == {n[1:]: pytest.approx(v * (1e-3 if n[1] in "XYZ" else 1e-6))
                           for n, v in loc.items()}
