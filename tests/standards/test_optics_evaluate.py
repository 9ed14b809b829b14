"""ISO 230-1 evaluation of direct optics: straightness, angular deviation, optical squares."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from volcal.measure.optics import OpticSetup, optic_exact, reference_columns
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import Session, write_session
from volcal.session.optics import annotate_references
from volcal.standards.optics import evaluate_optics

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def _hand_session():
    """One X line along Y: positions 0, 100, 200, 300 mm, readings 0, 2, 1, 3 um; one level."""
    s = plan_session(TRAVEL, "XYFZ", 3, ("direct",), runs=1, iso_spacing=False,
                     linear_margin_mm=0.0)
    m = next(m for m in s.measurements if m.id == "str-xz")
    m.positions = np.array([[0.0, 0, 0], [100, 0, 0], [200, 0, 0], [300, 0, 0]])
    m.deviation = np.array([0.0, 2.0, 1.0, 3.0])
    m.columns = {}
    lev = next(m for m in s.measurements if m.id == "lev-xa")
    lev.positions = m.positions.copy()
    lev.deviation = np.array([0.0, -4.0, 2.5, 1.0])
    lev.columns = {}
    return Session("h", "XYFZ", TRAVEL, [m, lev])


def test_straightness_and_angular_deviation_by_hand():
    """End-point line through (0, 0) and (300, 3): residuals 0, 1, -1, 0 -> 2 um.
    Least squares: mean s 150, mean d 1.5, Sxy = 225 - 25 - 25 + 225 = 400, Sxx = 50000,
    slope 0.008 um/mm (8 urad), intercept 0.3: residuals -0.3, 0.9, -0.9, 0.3 -> 1.8 um.
    Level: range of 0, -4, 2.5, 1 urad = 6.5 urad."""
    ev = evaluate_optics(_hand_session())
    r = ev["straightness"]["str-xz"]
    assert r["end_point"]["straightness_um"] == pytest.approx(2.0)
    assert r["end_point"]["slope_urad"] == pytest.approx(10.0)
    assert r["least_squares"]["straightness_um"] == pytest.approx(1.8)
    assert r["least_squares"]["slope_urad"] == pytest.approx(8.0)
    assert ev["angular"]["lev-xa"]["angular_deviation_urad"] == pytest.approx(6.5)


def test_optical_square_pairs_recover_the_squareness_under_reference_rotations():
    """Noise-free readings from a random machine, each reference group rotated by a random
    50 urad, each square off 90 degrees by its certificate's value: the end-point figure is
    the machine's squareness (its straightness functions are end-point normalised)."""
    truth = random_machine(TRAVEL, "XYFZ", seed=41)
    s = plan_session(TRAVEL, "XYFZ", 8, ("direct",), runs=1, iso_spacing=False,
                     linear_margin_mm=0.0)
    s.references = {"xy": {"square_deviation_urad": 4.0, "u_square_urad": 0.5},
                    "xz": {"square_deviation_urad": -3.0, "u_square_urad": 0.5},
                    "yz": {"square_deviation_urad": 2.0, "u_square_urad": 0.5}}
    annotate_references(s.measurements, s.references)
    rng = np.random.default_rng(3)
    drawn: dict[str, float] = {}
    s.measurements = [m for m in s.measurements if m.kind != "linear"]
    for m in s.measurements:
        nuis = {}
        for name in reference_columns(m):
            if name.endswith(":square"):
                drawn[name] = s.references[name.split(":")[1]]["square_deviation_urad"]
            nuis[name] = drawn.setdefault(name, float(rng.normal(0, 50)))
        m.deviation = optic_exact(truth, m, OpticSetup(nuisances=nuis))
    ev = evaluate_optics(s)
    got = {r["name"]: r for r in ev["squareness"] if "roll" not in r["lines"][1]}
    for j, name in enumerate(("EC0Y", "EB0Z", "EA0Z")):
        assert got[name]["end_point"][name] == pytest.approx(truth.squareness[j], abs=0.01)
        # the least-squares lines differ by the straightness curvature
        assert got[name]["least_squares"][name] != pytest.approx(truth.squareness[j], abs=0.01)


def test_cli_evaluate_optics_json(tmp_path, monkeypatch, capsys):
    from volcal.cli import main

    s = _hand_session()
    write_session(s, tmp_path / "s")
    monkeypatch.setattr(sys, "argv", ["volcal", "evaluate", "optics", str(tmp_path / "s"),
                                      "--json"])
    with pytest.raises(SystemExit) as exc:
        main()
    assert not exc.value.code
    out = json.loads(capsys.readouterr().out)
    assert out["straightness"]["str-xz"]["least_squares"]["straightness_um"] == pytest.approx(1.8)
