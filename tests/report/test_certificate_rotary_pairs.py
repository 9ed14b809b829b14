"""The certificate's as-found / as-left pairs of the rotary tests (issue 27, deliver 6).

A full-circle C axis is simulated (volcal's virtual rotary axis), its LinuxCNC table written
by the compensate step from those readings, and the axis measured again as left: the
virtual axis with the table's trims applied (commanded ``t``, the axis goes to
``t + trim`` and reads ``trim + e(t + trim)``, ``e`` the simulated truth), fresh noise, the
test under another id. The certificate pairs the two tests by their axis; every number is
checked against the ISO 230-2 rotary evaluation of each session's readings, in urad in
the JSON and in arcsec in the printed table.
"""

from __future__ import annotations

import shutil

import jsonschema
import numpy as np
import pytest

ARCSEC_URAD = 4.8481368110953599
QUANTITIES = ("A", "E", "M", "R", "B")


@pytest.fixture(scope="module")
def found_left(tmp_path_factory):
    """(as-found folder, as-left folder) of one C axis, the table loaded in between."""
    import tomllib

    from volcal.compensate.rotary import rotary_removed_urad
    from volcal.compensate.rotary.profile import DEG_PER_URAD
    from volcal.measure.rotary import rotary_exact
    from volcal.session.format import read_session, write_session
    from volcal.steps.compensate import compensate
    from volcal.steps.plan import plan
    from volcal.steps.simulate import save, simulate

    root = tmp_path_factory.mktemp("rotpairs")
    found = root / "found"
    plan([[0, 400], [0, 300], [0, 200]], tests="rotary:c", steps=6, runs=2, output=found)
    sim = simulate(found, seed=3)
    save(sim, found)
    comp = root / "comp"
    r = compensate(None, format="linuxcnc", output=comp, session=found)
    assert r.rotary_only and list(r.files) == ["C.comp", "ROTARY_NOTES.TXT"]
    entry = tomllib.loads((comp / "volcal-compensation.toml").read_text())["rotary"][0]

    left = root / "left"
    shutil.copytree(found, left)
    s = read_session(left)
    m = s.measurements[0]
    setup = sim.setups[m.id]
    t = np.asarray(m.columns["target_deg"], dtype=float)
    d = np.asarray(m.columns["direction"]).astype(str)
    trim = -rotary_removed_urad(comp, "linuxcnc", entry, t, d) * DEG_PER_URAD  # [deg]
    assert np.ptp(trim) > 1e-4  # the table does something
    noise = np.random.default_rng(99).normal(0.0, sim.options.noise_um, m.n)
    dev = trim / DEG_PER_URAD + rotary_exact(setup, t + trim, d) + noise
    m.deviation = dev - dev[0]
    (left / m.file).unlink()
    m.id, m.file = "rotary-c-after", "rotary-c-after.csv"
    write_session(s, left)
    return found, left


def _iso(folder):
    from volcal.session.format import read_session
    from volcal.standards.iso230_2_rotary import evaluate_rotary_measurement

    return evaluate_rotary_measurement(read_session(folder).measurements[0]).iso


def test_certificate_pairs_the_rotary_tests_by_axis(found_left):
    from volcal.report.certificate import build_certificate
    from volcal.report.certificate_files import schema
    from volcal.report.certificate_layout import layout
    from volcal.session.format import read_session

    found, left = found_left
    before, after = _iso(found), _iso(left)
    assert float(after.A) < float(before.A) / 3  # the table took the error out
    doc = build_certificate(read_session(found), None, as_left=read_session(left))
    jsonschema.validate(doc, schema())
    pair = doc["as_found_as_left"]
    assert pair["pairs"] == []  # no linear test
    rows = {p["quantity"]: p for p in pair["rotary_pairs"]}
    assert sorted(rows) == sorted(QUANTITIES) and len(pair["rotary_pairs"]) == 5
    for k in QUANTITIES:
        p = rows[k]
        assert (p["measurement"], p["as_left_measurement"], p["axis"]) == (
            "rotary-c", "rotary-c-after", "C")
        assert p["as_found_urad"] == pytest.approx(float(getattr(before, k)), abs=1e-9)
        assert p["as_left_urad"] == pytest.approx(float(getattr(after, k)), abs=1e-9)
    # printed in --angle-units: arcsec (the JSON keeps urad), change = as-left - as-found
    blocks = [b for sec in layout(doc, "arcsec") for b in sec.blocks if b.kind == "table"
              and (b.title or "").startswith("Rotary axes measured as-found and as-left")]
    assert len(blocks) == 1 and blocks[0].title.endswith("[arcsec]")
    row = next(r for r in blocks[0].rows if r[2] == "A")
    a0, a1 = float(before.A) / ARCSEC_URAD, float(after.A) / ARCSEC_URAD
    assert row[:2] == ["rotary-c / rotary-c-after", "C"]
    assert row[3:] == [f"{a0:.2f}", f"{a1:.2f}", f"{a1 - a0:.2f}"]
    flags = [b.text for sec in layout(doc) for b in sec.blocks if b.kind == "flag"]
    assert not any("nothing to pair" in (f or "") for f in flags)
    urad = [b for sec in layout(doc) for b in sec.blocks if b.kind == "table"
            and (b.title or "").startswith("Rotary axes measured")]
    assert urad[0].title.endswith("[µrad]")
    assert next(r for r in urad[0].rows if r[2] == "A")[3] == f"{float(before.A):.2f}"
    from volcal.report.certificate_html import render_certificate_html

    html = render_certificate_html(doc, "arcsec")
    assert "Rotary axes measured as-found and as-left [arcsec]" in html
    assert f"{a0:.2f}" in html and f"{a1:.2f}" in html


def test_rotary_pairs_schema_is_additive(found_left):
    """Certificates without ``rotary_pairs`` stay valid; a wrong pair is refused."""
    from volcal.report.certificate import build_certificate
    from volcal.report.certificate_files import schema
    from volcal.session.format import read_session

    found, left = found_left
    doc = build_certificate(read_session(found), None, as_left=read_session(left))
    old = {**doc, "as_found_as_left": {k: v for k, v in doc["as_found_as_left"].items()
                                       if k != "rotary_pairs"}}
    jsonschema.validate(old, schema())
    bad = {**doc, "as_found_as_left": {**doc["as_found_as_left"], "rotary_pairs": [
        {**doc["as_found_as_left"]["rotary_pairs"][0], "quantity": "E_D"}]}}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema())


def test_two_tests_of_one_axis_under_other_ids_are_not_paired():
    """Matched by axis: the same id first; an axis with several tests pairs by id only."""
    from volcal.report.certificate import _rotary_pairs

    def res(*rows):
        return {"rotary": [{"measurement": mid, "axis": ax, "values": {"A": a}}
                           for mid, ax, a in rows]}

    found = res(("c1", "C", 10.0), ("c2", "C", 20.0), ("a1", "A", 30.0))
    left = res(("c2", "C", 2.0), ("c9", "C", 1.0), ("a-left", "A", 3.0))
    got = {(p["measurement"], p["as_left_measurement"]): (p["as_found_urad"],
                                                           p["as_left_urad"])
           for p in _rotary_pairs(found, left)}
    assert got == {("c2", "c2"): (20.0, 2.0), ("a1", "a-left"): (30.0, 3.0)}
