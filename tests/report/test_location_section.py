"""The report's and the certificate's location-error sections: scatter and per-path test.

A trunnion (``CAXYFZ``, the plan's pivots and sphere) whose C line is off by EX0C =
500 um, nothing else wrong, probed without noise at C = 0, 60, ..., 300 deg x A = -90 ...
90 deg. By hand: the table turns by -theta about a line d = 500 um off in X, so the sphere the
first pose located (C = 0) is found at ``(I - R_z(-theta)) d e_x`` = d (1 - cos theta,
sin theta, 0) from where the configured kinematics put it: on the path "C at A = 0" (C =
0, 60, ..., 300 deg) X spans 2 d = 1000 um, Y spans 2 d sin 60 deg = 866.03 um, Z none;
with C standing (an A path) the offset is a workpiece shift, no range. With the
identified location errors the residual is the rounding of the CSV (1 nm). The
ISO 10791-6-style test with T = 20 um then fails as found and passes after; the
certificate states it in ``results.as_found.location`` and validates against its schema.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from volcal_cli_helpers import run_volcal, volcal_process

EX0C_UM = 500.0


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    from volcal.measure.spheres import probe_centres
    from volcal.session.format import read_session
    from volcal.session.probe_sphere import _angles, _keys, five_axis_machine

    folder = tmp_path_factory.mktemp("loc") / "S"
    p = volcal_process("plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ",
                       "--tests", "probe_sphere", "-o", str(folder))
    assert p.returncode == 0, p.stderr
    m = read_session(folder, require_deviation=False).measurements[0]
    k = _keys(m)
    ang = _angles(m)
    truth = five_axis_machine(m, None, {"EX0C": EX0C_UM})
    q = probe_centres(truth, ang, k["sphere_mm"], m.tool_offset)
    rows = ["c_deg,a_deg,x_mm,y_mm,z_mm"] + [
        f"{ang['C'][i]:g},{ang['A'][i]:g},{q[i, 0]:.6f},{q[i, 1]:.6f},{q[i, 2]:.6f}"
        for i in range(q.shape[0])]
    (folder / "probe_sphere.csv").write_text("\n".join(rows) + "\n")
    return folder


def test_scatter_before_after_and_path_ranges_by_hand(session):
    from volcal.identify.location_evaluation import locate_session, path_decisions
    from volcal.session.format import read_session

    s = read_session(session)
    (lc,) = locate_session(s)
    m = s.measurements[0]
    # before: the dispersion the control's cycle reports (the kind's own, on reading)
    np.testing.assert_allclose(np.linalg.norm(lc.before_um, axis=1), m.deviation, atol=1e-9)
    assert np.abs(lc.after_um).max() < 0.01  # the CSV's 1 nm rounding
    assert lc.result.estimate["EX0C"] == pytest.approx(EX0C_UM, abs=0.01)
    paths = {p.path: p for p in lc.paths}
    assert len(paths) == 5 + 6  # C at each of 5 A angles, A at each of 6 C angles
    p = paths["C at A = 0°"]
    assert p.n_poses == 6
    np.testing.assert_allclose(p.range_before_um, [2 * EX0C_UM,
                                                   2 * EX0C_UM * np.sin(np.pi / 3), 0.0],
                               atol=1e-3)
    assert p.U_um == pytest.approx(2 * np.sqrt(2) * 1.0)  # k sqrt(2) sigma, noise_um = 1
    # simple rule: before fails, after passes; guarded with T inside U of the after range
    d = path_decisions([lc], 20.0)
    before = {x["path"]: x["verdict_before"] for x in d}
    assert {v for k, v in before.items() if k.startswith("C at")} == {"fail"}
    # with C standing, C's line off its place only shifts the sphere: no A path sees it
    assert {v for k, v in before.items() if k.startswith("A at")} == {"pass"}
    assert max(p.before_um for p in lc.paths if p.moving == "A") < 1e-3
    assert {x["verdict_after"] for x in d} == {"pass"}
    d = path_decisions([lc], 2.0, "guarded")  # w = U = 2.83 um >= T: no pass possible
    assert {x["verdict_after"] for x in d} == {"conditional"}


def test_report_and_certificate_sections(session, tmp_path, monkeypatch, capsys):
    import jsonschema

    from volcal.report.certificate_files import schema

    out = tmp_path / "R"
    code, _, err = run_volcal(monkeypatch, capsys, "report", str(session), "-o", str(out),
                              "--certificate", "--location-tolerance-um", "20")
    assert code == 0, err
    html = (out / "report.html").read_text()
    assert "ISO 10791-6-style test of the sphere centre per path" in html
    assert "fail as found with the configured kinematics; pass predicted" in html
    # its References list the five-axis sources it cites, not the diagonal papers (session
    # 21: every report listed the same nine, none of these three)
    refs = html[html.index('id="references"'):]
    assert "ISO 10791-6:2014" in refs and "Weikert" in refs and "Ibaraki" in refs
    assert "LAMDAMAP" not in refs and "step-diagonal test" not in refs
    doc = json.loads((out / "certificate.json").read_text())
    jsonschema.validate(doc, schema(), cls=jsonschema.Draft202012Validator)
    method = next(x for x in doc["methods"] if x["id"] == "ISO 230-1 location errors")
    assert method["measurements"] == ["probe_sphere"]
    (loc,) = doc["results"]["as_found"]["location"]
    assert loc["chain"] == "CAXYFZ" and loc["tolerance"]["verdict_before"] == "fail"
    assert loc["tolerance"]["verdict_after"] == "pass"
    ex = next(e for e in loc["errors"] if e["name"] == "EX0C")
    assert ex["value"] == pytest.approx(EX0C_UM, abs=0.01) and ex["U"] > 0
    red = next(e for e in loc["errors"] if e["name"] == "EC0C")
    assert red["value"] is None and red["status"] == "redundant (held at zero)"
    # the schema is not vacuous for the new section
    bad = json.loads(json.dumps(doc))
    bad["results"]["as_found"]["location"][0]["errors"][0]["status"] = "guessed"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema(), cls=jsonschema.Draft202012Validator)
    # a bad tolerance is named as the command line spells it
    code, _, err = run_volcal(monkeypatch, capsys, "report", str(session), "-o",
                              str(tmp_path / "R2"), "--location-tolerance-um", "-1")
    assert code == 2 and "--location-tolerance-um -1" in err
