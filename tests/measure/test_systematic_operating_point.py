"""``simulate --budget`` draws at the operating point the session records (issue 25, item 3).

"The budget gives uncertainties only; its operating point serves the sensitivities where
the session records none": the simulation's systematic errors take the air's and the
material's sensitivities at each measurement's recorded environment, as identify's
systematic part does (``volcal.identify.systematic._relative_u``), with the same random
draws. A measurement recording a material temperature of 25 degC under a budget at
20 degC is simulated exactly as under a budget at 25 degC; the others as before.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
import tomli_w

from volcal.uncertainty.budget import parse_budget

T_SESSION = 25.0
"""The material temperature the session records for one measurement [degC]."""


def budget(t_material: float):
    return parse_budget({
        "laser": {"u_wavelength_ppm": 0.5},
        "air": {"temperature_c": 20.5, "pressure_pa": 101000.0, "humidity_pct": 45.0,
                "u_temperature_k": 0.2, "u_pressure_pa": 50.0, "u_humidity_pct": 5.0},
        "material": {"temperature_c": t_material, "u_temperature_k": 0.3,
                     "expansion_ppm_per_k": 11.5, "u_expansion_ppm_per_k": 1.0},
        "setup": {"u_misalignment_urad": 0.0, "dead_path_mm": 0.0}})


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """A planned session (linear tests of X, Y, Z and the diagonals), and the same with
    ``material_temperature_c = 25`` recorded on its first X line."""
    from volcal.steps.plan import plan

    root = tmp_path_factory.mktemp("oppoint")
    plain, recorded = root / "plain", root / "recorded"
    for s in (plain, recorded):
        plan([[0, 800], [0, 600], [0, 500]], tests="linear,diagonal", steps=6, runs=2,
             output=s)
    p = recorded / "session.toml"
    doc = tomllib.loads(p.read_text(encoding="utf-8"))
    first = next(m for m in doc["measurements"] if m.get("axis") == "X")
    first["environment"] = {"material_temperature_c": T_SESSION}
    p.write_text(tomli_w.dumps(doc), encoding="utf-8")
    return plain, recorded, first["id"]


def _simulated(folder, b):
    from volcal.steps.simulate import simulate

    return simulate(folder, seed=5, budget=b)


def test_the_drawn_material_term_follows_the_session(planned):
    plain, recorded, mid = planned
    at_20 = _simulated(plain, budget(20.0))
    at_25 = _simulated(plain, budget(T_SESSION))
    rec = _simulated(recorded, budget(20.0))
    m20, m25 = at_20.systematic.material, at_25.systematic.material
    # the term depends on the temperature ((t - 20) dalpha): the test has teeth
    assert all(abs(m25[k] - m20[k]) > 1e-7 for k in "XYZ")
    # the measurement recording 25 degC: the draws of a budget at 25 degC, exactly
    d = rec.systematic
    assert d.material == m20  # the budget's operating point, for the others
    assert set(d.material_by_measurement) == {mid}
    assert d.material_by_measurement[mid] == pytest.approx(m25, rel=1e-12, abs=0)
    assert d.air == at_20.systematic.air and d.wavelength == at_20.systematic.wavelength
    # and the readings: that line as simulated under the budget at 25 degC, the others
    # as under the budget at 20 degC
    by = {s: {m.id: m.deviation for m in r.session.measurements}
          for s, r in (("20", at_20), ("25", at_25), ("rec", rec))}
    for k, dev in by["rec"].items():
        want = by["25"][k] if k == mid else by["20"][k]
        np.testing.assert_allclose(dev, want, rtol=0, atol=1e-12)
    assert np.max(np.abs(by["20"][mid] - by["25"][mid])) > 1e-4  # [um]: it moved
    # recorded in truth/systematic.toml
    assert rec.truth_files()["truth/systematic.toml"].count("material_by_measurement_ppm") == 1
    assert "material_by_measurement_ppm" not in at_20.truth_files()["truth/systematic.toml"]


def test_identify_takes_the_same_operating_point(planned):
    """The simulation's sensitivities are those identify's systematic part propagates."""
    from volcal.identify.systematic import _relative_u
    from volcal.session.format import read_session

    plain, recorded, mid = planned
    m_rec = next(m for m in read_session(recorded, require_deviation=False).measurements
                 if m.id == mid)
    m_plain = next(m for m in read_session(plain, require_deviation=False).measurements
                   if m.id == mid)
    assert _relative_u(budget(20.0), m_rec) == pytest.approx(
        _relative_u(budget(T_SESSION), m_plain), rel=1e-12)
    assert _relative_u(budget(20.0), m_rec)[1] > 1.0001 * _relative_u(budget(20.0), m_plain)[1]
