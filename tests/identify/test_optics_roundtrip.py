"""identify(simulate(truth)) with direct optics: the classic direct set, and fused with the seeds.

Random machines WITH roll (``random_machine`` draws every angular error, the rolls
included), exact simulation with the optics' set-up rotations and noise
(``volcal.measure.optics_simulate``). Larger study: ``benchmarks/optics_study.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from identify_helpers import TRAVEL, grid, seeds_session

from volcal.identify import IdentifyOptions, identify
from volcal.identify.design import choose_nodes
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.kinematics import volumetric_error
from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES
from volcal.model.rigid import remove_rigid_body
from volcal.plan.planner import plan_session
from volcal.session.format import Session
from volcal.session.optics import DEFAULT_U_SQUARE_URAD
from volcal_cli_helpers import run_volcal

ROLLS = ("EAX", "EBY", "ECZ")


def direct_session(chain="XYFZ", sensor_on_table=False):
    s = plan_session(TRAVEL, chain, 10, ("direct",), runs=1, iso_spacing=False,
                     linear_margin_mm=0.0)
    if sensor_on_table:  # XYFZ: X carries the table; read its straightness from the table
        for m in s.measurements:
            if m.id in ("str-xy", "str-xz"):
                m.meta["sensor_position_mm"] = [400.0, 0.0, 0.0]
    return s


def _fit(s, truth, seed):
    simulate_session(s, truth, SimulationOptions(seed=seed))
    r = identify(s, IdentifyOptions(suggest=False))
    q = grid(choose_nodes(s, refine=1), stride=2)
    e, _ = r.predict(q)
    rms = float(np.sqrt(np.mean(remove_rigid_body(q, e - volumetric_error(truth, q)) ** 2)))
    return r, rms


def _roll_hits(r, truth):
    hits = []
    for name in ROLLS:
        k = "XYZ".index(name[2])
        x = np.linspace(*TRAVEL[k], 21)[1:]  # the start is the gauge (zero in both)
        d = r.errors.function(name, x) - truth.function(name, x)
        hits.append(np.abs(d) <= 1.96 * r.function_std(name, x))
    return np.concatenate(hits)


def test_classic_direct_set_determines_all_21_errors():
    """Per axis a linear line, two straightness lines, pitch and yaw, the roll by a level (X, Y)
    or by Z's straightness at two tool offsets against one reference; squareness by optical
    squares. Noise 0.5 um (straightness + 1 %), 0.2 urad (angular), 1 urad (level)."""
    hits, sq_z = [], []
    for i, (seed, table) in enumerate(((700, False), (701, False), (702, True), (703, True))):
        truth = random_machine(TRAVEL, "XYFZ", seed=seed)
        r, rms = _fit(direct_session("XYFZ", table), truth, i)
        q = grid(choose_nodes(direct_session(), refine=1), stride=2)
        truth_rms = np.sqrt(np.mean(remove_rigid_body(q, volumetric_error(truth, q)) ** 2))
        assert rms < 1.0, (seed, rms)  # near the 0.5 um noise
        assert rms < 0.15 * truth_rms, (seed, rms, truth_rms)
        det = r.report.determined_fraction
        assert all(det[n] > 1 - 1e-9 for n in COMPONENT_NAMES), det
        # the squareness by the optical squares, to their certificate's 2.5 urad
        assert all(det[n] > 0.95 for n in SQUARENESS_NAMES), det
        assert r.report.ambiguity_rms_um < 0.3, r.report.ambiguity_rms_um
        hits.append(_roll_hits(r, truth))
        for j, name in enumerate(SQUARENESS_NAMES):
            u = float(r.function_std(name, [0.0])[0])
            # the optical square's certificate (2.5 urad) bounds it; the lines add little
            assert 0.5 * DEFAULT_U_SQUARE_URAD < u < 1.5 * DEFAULT_U_SQUARE_URAD, (name, u)
            sq_z.append((r.errors.squareness[j] - truth.squareness[j]) / u)
    cover = float(np.mean(np.concatenate(hits)))
    assert 0.90 <= cover <= 0.99, cover
    # squareness from the optical-square groups under random reference rotations (50 urad)
    assert np.max(np.abs(sq_z)) < 3.0, sq_z
    assert 0.4 < np.sqrt(np.mean(np.square(sq_z))) < 1.6, sq_z


def test_seeds_plus_levels_and_z_straightness_pair_beat_the_seeds():
    """The seeds' full set plus a level on X and Y and Z's straightness at two tool offsets
    in one reference group: at most 0.8x the seeds' volumetric residual; the rolls within
    their reported uncertainty."""
    hits = []
    for i, seed in enumerate((700, 701, 702)):
        truth = random_machine(TRAVEL, "XYFZ", seed=seed)
        _, rms_seeds = _fit(seeds_session("XYFZ", runs=2), truth, i)
        s = seeds_session("XYFZ", runs=2)
        extra = [m for m in direct_session().measurements
                 if m.id in ("lev-xa", "lev-yb", "str-zx", "str-zx-roll")]
        for m in extra:
            if m.kind == "straightness":
                m.meta["reference"] = "z-roll"
        fused = Session(s.name, s.chain, s.travel, s.measurements + extra)
        r, rms = _fit(fused, truth, i)
        assert rms <= 0.8 * rms_seeds, (seed, rms, rms_seeds)
        hits.append(_roll_hits(r, truth))
    cover = float(np.mean(np.concatenate(hits)))
    assert cover >= 0.85, cover


@pytest.mark.parametrize("chain", ["FXYZ"])
def test_direct_set_on_a_gantry(chain):
    truth = random_machine(TRAVEL, chain, seed=710)
    r, rms = _fit(direct_session(chain), truth, 3)
    assert rms < 1.0, rms
    assert np.mean(_roll_hits(r, truth)) >= 0.85


def test_advise_ranks_direct_optics():
    """On the seeds' plan the rolls are the ambiguity; a level on X is ranked and named."""
    import re

    from volcal.identify.api import advise

    rep = advise(seeds_session("XYFZ", runs=1))
    optic = [s for s in rep.suggestions if s.startswith("direct optics: a level on X")]
    assert optic, rep.suggestions
    base, after = (float(v) for v in re.findall(r"ambiguity ([\d.]+) -> ([\d.]+)", optic[0])[0])
    assert after < 0.5 * base
    assert any(m.startswith(("Best direct optic: a level on X determines EAX",
                             "Best extra measurement: direct optics: a level on X determines "
                             "EAX"))
               for m in rep.messages), rep.messages


def test_cli_identify_and_predict_on_a_session_written_by_hand(tmp_path, monkeypatch, capsys):
    """The issue's format as another tool writes it (letters upper case, a square's
    certificate in [references.NAME]): `volcal identify` and `volcal predict`."""
    import re

    from volcal.session.format import write_session

    truth = random_machine(TRAVEL, "XYFZ", seed=720)
    s = direct_session()
    simulate_session(s, truth, SimulationOptions(seed=9))
    folder = write_session(s, tmp_path / "S")
    toml = (folder / "session.toml").read_text()
    toml = re.sub(r'^(axis|error_direction|rotation) = "([a-z])"',
                  lambda m: f'{m.group(1)} = "{m.group(2).upper()}"', toml, flags=re.M)
    assert 'error_direction = "Y"' in toml and 'rotation = "B"' in toml
    toml = toml.replace("[[measurements]]", "[references.xy]\nsquare_deviation_urad = 0.0\n"
                        "u_square_urad = 2.5\n\n[[measurements]]", 1)
    (folder / "session.toml").write_text(toml)
    code, out, err = run_volcal(monkeypatch, capsys, "identify", str(folder), "-o",
                                str(tmp_path / "m.json"))
    assert code == 0, err
    assert "angular" in out and "straightness" in out
    pts = tmp_path / "p.csv"
    pts.write_text("x_mm,y_mm,z_mm\n0,0,0\n400,300,250\n800,600,500\n")
    code, _, err = run_volcal(monkeypatch, capsys, "predict", str(tmp_path / "m.json"), "--points",
                              str(pts), "-o", str(tmp_path / "o.csv"))
    assert code == 0, err
    rows = np.loadtxt(tmp_path / "o.csv", delimiter=",", skiprows=1)
    et = volumetric_error(truth, rows[:, :3])
    assert np.all(np.abs(rows[:, 3:6] - et) < 4 * rows[:, 6:9] + 0.2), (rows, et)


def test_optic_residuals_are_in_the_readings_unit():
    """Level rows weigh 0.5 (1 urad noise against 0.5 um): their residuals come back in
    urad, with the spread of the simulated 1 urad noise (not halved); fitted + residual =
    reading."""
    truth = random_machine(TRAVEL, "XYFZ", seed=721)
    s = plan_session(TRAVEL, "XYFZ", 10, ("direct",), runs=3, iso_spacing=False,
                     linear_margin_mm=0.0)
    simulate_session(s, truth, SimulationOptions(seed=4))
    r = identify(s, IdentifyOptions(suggest=False))
    lev = np.concatenate([r.residuals[k] for k in ("lev-xa", "lev-yb")])
    ang = np.concatenate([r.residuals[k] for k in r.residuals if k.startswith("ang-")])
    assert 0.6 < np.std(lev) < 1.2, np.std(lev)  # 1 urad noise, a few dof taken by the fit
    assert 0.1 < np.std(ang) < 0.25, np.std(ang)  # 0.2 urad
    m = s.get("lev-xa")
    np.testing.assert_allclose(r.fitted["lev-xa"] + r.residuals["lev-xa"], m.deviation)


def test_report_says_what_each_optic_reads():
    from identify_helpers import assert_labels_match_table

    from volcal.identify.optics import optics_notes
    from volcal.session.optics import annotate_references

    s = direct_session()
    annotate_references(s.measurements, {"xy": {"square_deviation_urad": 1.5,
                                                "u_square_urad": 0.5}})
    notes = optics_notes(s.measurements)
    text = " ".join(notes)
    assert "lev-xa EAX by level" in text and "ang-xb EBX by angular optics" in text
    assert "str-zx-roll EXZ" in text
    assert ("Reference group 'xz' reads the roll ECZ (roll of Z) from 2 parallel lines at "
            "different tool offsets and EB0Z through the optical square") in text
    assert "Reference group 'xy' reads EC0Y through the optical square, to its certificate " \
           "(1.5 +- 0.5 urad)" in text
    assert assert_labels_match_table(text) == 1  # ECZ (roll of Z): the table's meaning
    assert optics_notes(seeds_session("XYFZ", runs=1).measurements) == []
