"""``volcal advise`` ranks candidate poses and sphere positions for the location errors.

The design: a trunnion (``CAXYFZ``, the plan's pivots and sphere) probed with C at 0, 90,
180, 270 deg at A = 0 and once at C = 0, A = 45 deg. It determines 7 of the 10 location
errors: besides the two zeros no probing separates (EC0C, EA0A), the orientation of A's
line about Z (EC0A) is held at zero, since A turned only once. The top-ranked candidate
must make EC0A determined (checked by the identifiability analysis ``volcal locate``
runs), and the U the ranking predicts for the design with that pose must be the U
``volcal locate`` states after that pose is measured on a virtual machine with hidden
location errors (pivots off by up to 2 mm, tilts up to 200 urad) within 10 %.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from volcal_cli_helpers import run_volcal

DESIGN = [(0, 0), (90, 0), (180, 0), (270, 0), (0, 45)]  # (C, A) [deg]


def _planned(tmp_path, monkeypatch, capsys, poses=DESIGN):
    folder = tmp_path / "S"
    code, _, err = run_volcal(monkeypatch, capsys, "plan", "--travel", "0:800,0:600,0:500",
                              "--chain", "XYFZ", "--tests", "probe_sphere", "-o", str(folder))
    assert code == 0, err
    (folder / "probe_sphere.csv").write_text(
        "c_deg,a_deg\n" + "".join(f"{c},{a}\n" for c, a in poses))
    return folder


def _advice(monkeypatch, capsys, *args):
    code, out, err = run_volcal(monkeypatch, capsys, "advise", *args, "--json")
    assert code == 0, err
    return json.loads(out)


def test_top_candidate_determines_what_the_design_leaves_and_predicts_locates_u(
        tmp_path, monkeypatch, capsys):
    from volcal.identify.location import analyse_location, design_jacobian
    from volcal.kinds.probe_sphere import five_axis_machine, sphere_readings
    from volcal.model.fiveaxis import location_parameter_names
    from volcal.session.format import read_session

    folder = _planned(tmp_path, monkeypatch, capsys)
    d = _advice(monkeypatch, capsys, str(folder), "--top", "3")
    rank = d["location_candidates"][0]
    assert rank["chain"] == "CAXYFZ" and rank["source"] == "generated"
    assert rank["redundant"] == ["EC0C", "EC0A", "EA0A"]
    best = rank["candidates"][0]
    assert best["determines"] == ["EC0A"] and best["n_poses"] == 1
    assert "determines EC0A (held at zero before)" in best["reason"]
    c, a = best["angles_deg"]["C"][0], best["angles_deg"]["A"][0]
    assert a != 0.0  # a second A angle away from the one the design has
    # the identifiability analysis of the design with that pose agrees
    (folder / "probe_sphere.csv").write_text(
        "c_deg,a_deg\n" + "".join(f"{x},{y}\n" for x, y in [*DESIGN, (c, a)]))
    s = read_session(folder, require_deviation=False)
    m = s.measurements[0]
    nominal = five_axis_machine(m)
    Jx, Jn, nn, _, _ = design_jacobian(nominal, [sphere_readings(m, nominal_centres=True)])
    rep = analyse_location(Jx, Jn, location_parameter_names("CAXYFZ"), nn, nominal.chain_obj)
    assert rep.fixed == ("EC0C", "EA0A") and "EC0A" in rep.free
    # measured on a virtual machine: locate's U is the predicted one within 10 %
    code, _, err = run_volcal(monkeypatch, capsys, "simulate", str(folder), "--seed", "5")
    assert code == 0, err
    code, out, err = run_volcal(monkeypatch, capsys, "locate", str(folder), "--json")
    assert code == 0, err
    located = {r["name"]: r for r in json.loads(out)["location_errors"]}
    assert located["EC0A"]["status"] == "identified"
    assert set(best["U_after"]) == {n for n, r in located.items() if r["U"] is not None}
    for name, U in best["U_after"].items():
        assert located[name]["U"] == pytest.approx(U, rel=0.10), name


def test_candidates_from_a_file_and_the_sphere_far_from_the_axis(tmp_path, monkeypatch,
                                                                  capsys):
    """A file of candidates: the pose that turns A again ranks above the one that only
    repeats A = 0; a second sphere far off the C axis above one on the axis."""
    folder = _planned(tmp_path, monkeypatch, capsys)
    cands = tmp_path / "cands.csv"
    cands.write_text("candidate,c_deg,a_deg,sphere_x_mm,sphere_y_mm,sphere_z_mm\n"
                     "repeat,45,0,,,\n"
                     "tilt,180,-45,,,\n"
                     + "".join(f"near,{c},{a},400,300,375.353\n" for c, a in DESIGN)
                     + "".join(f"far,{c},{a},650,300,375.353\n" for c, a in DESIGN))
    d = _advice(monkeypatch, capsys, str(folder), "--candidates", str(cands), "--top", "10")
    got = d["location_candidates"][0]
    assert got["source"] == "cands.csv" and got["n_candidates"] == 4
    order = [c["label"].split(":")[0] for c in got["candidates"]]
    assert order[0] == "C 180°, A -45° on S1"  # determines EC0A
    assert got["candidates"][0]["determines"] == ["EC0A"]
    assert order.index("far") < order.index("near")
    far = next(c for c in got["candidates"] if c["label"].startswith("far"))
    assert "250 mm off the C axis" in far["where"] and far["n_poses"] == 5
    # a bad file names the file, row and column
    cands.write_text("c_deg,a_deg\n0,abc\n")
    code, out, err = run_volcal(monkeypatch, capsys, "advise", str(folder), "--candidates",
                                str(cands))
    assert code == 2 and "cands.csv" in err and "a_deg" in err and "row 2" in err


def test_linear_advice_is_unchanged(monkeypatch, capsys, tmp_path):
    """Without probe_sphere tests the messages are the linear analysis' as before."""
    from volcal.identify import advise as run
    from volcal.session.format import read_session
    from volcal.steps.advise import advise

    folder = tmp_path / "L"
    code, _, err = run_volcal(monkeypatch, capsys, "plan", "--travel", "0:400,0:300,0:200",
                              "--chain", "XYFZ", "--tests", "linear:x", "--steps", "4",
                              "-o", str(folder))
    assert code == 0, err
    s = read_session(folder, require_deviation=False)
    r = advise(s)
    assert r.locations == () and r.messages == run(s).messages
    with pytest.raises(Exception, match="no probe_sphere test"):
        advise(s, candidates=folder / "session.toml")
    with pytest.raises(Exception, match="top=0"):
        advise(s, top=0)


def test_ranking_numbers_match_the_analysis():
    """The predicted U of a candidate is the covariance locate computes (no prior), and
    the D gain is the log-det difference; checked by hand on the library."""
    from volcal.identify.location_advice import rank_candidates
    from volcal.measure.fiveaxis_virtual import nominal_machine
    from volcal.measure.spheres import SphereReadings

    nom = nominal_machine("CAFXYZ", {"C": [0, 0, 0], "A": [0, 0, -120]})
    ang = {"C": np.array([0.0, 90.0, 180.0, 270.0, 0.0, 180.0]),
           "A": np.array([0.0, 0.0, 0.0, 0.0, 45.0, 45.0])}
    b = SphereReadings("m", "probe", ang, np.zeros((6, 3)), "S1", np.array([150.0, 0, 40]),
                       np.zeros(3), None, 1.0)
    r = rank_candidates(nom, [b], top=1)
    assert r.redundant == ("EC0C", "EA0A")
    # the position of C's line seen by 4 C angles 90 deg apart at A = 0 and 2 at A = 45:
    # EX0C from the x readings, 1 um noise: U of the design as planned is finite and small
    assert 0.5 < r.U["EX0C"] < 2.0
    best = r.candidates[0]
    assert best.gain > 0 and best.gain_per_pose == pytest.approx(best.gain)
    assert all(best.U_after[n] <= r.U[n] + 1e-9 for n in r.U)  # a pose never adds U


def test_locate_and_advise_say_which_redundant_errors_poses_would_separate():
    """A trunnion probed with A standing at 0: A's line acts on no reading; other poses
    would determine it (the ranking names them), the two zeros stay redundant."""
    from volcal.identify.location import analyse_location, design_jacobian, separation_advice
    from volcal.measure.fiveaxis_virtual import nominal_machine
    from volcal.measure.spheres import SphereReadings
    from volcal.model.fiveaxis import location_parameter_names

    nom = nominal_machine("CAFXYZ", {"C": [0, 0, 0], "A": [0, 0, -120]})
    ang = {"C": np.array([0.0, 90.0, 180.0, 270.0]), "A": np.zeros(4)}
    b = SphereReadings("m", "probe", ang, np.zeros((4, 3)), "S1", np.array([150.0, 0, 40]),
                       np.zeros(3), None, 1.0)
    Jx, Jn, nn, _, _ = design_jacobian(nom, [b])
    rep = analyse_location(Jx, Jn, location_parameter_names("CAFXYZ"), nn, nom.chain_obj)
    assert any(m.startswith("  EY0A (position of the A axis average line in Y) does not act "
                            "on these readings") for m in rep.messages)
    advice = separation_advice(nom, [b])
    assert ("Adding poses at other angles would determine EY0A, EZ0A, EB0A, EC0A (volcal "
            "advise ranks the candidate poses).") in advice
    assert any(a.startswith("No candidate reading separates EC0C, EA0A:") for a in advice)
