"""Systematic budget inputs carried into the identified model (volcal.identify.systematic).

The check is physical, not the formula again: a wavelength scale error of eps makes every
length reading L (1 + eps); on the X axis' linear lines that is a positioning error eps x,
so the identified EXX must move by eps x. Identifying the session with its readings
scaled shows it; the propagated systematic factor must predict the same change.
"""

import copy

import numpy as np
import pytest
from identify_helpers import TRAVEL, exact_fill, seeds_session

from volcal.identify import identify
from volcal.identify.result import IdentificationResult
from volcal.identify.systematic import attach_systematic
from volcal.measure.virtual import random_machine
from volcal.uncertainty.budget import parse_budget


def budget(**kw):
    doc = {"laser": {"u_wavelength_ppm": 0.0},
           "air": {"temperature_c": 20.0, "pressure_pa": 101325.0, "humidity_pct": 50.0,
                   "u_temperature_k": 0.0, "u_pressure_pa": 0.0, "u_humidity_pct": 0.0},
           "material": {"temperature_c": 20.0, "u_temperature_k": 0.0,
                        "expansion_ppm_per_k": 11.5, "u_expansion_ppm_per_k": 0.0},
           "setup": {"u_misalignment_urad": 0.0, "dead_path_mm": 0.0}}
    for key, v in kw.items():
        sec, k = key.split("__")
        doc[sec][k] = v
    return parse_budget(doc)


@pytest.fixture(scope="module")
def fitted():
    s = seeds_session(steps=6)
    exact_fill(s, random_machine(TRAVEL, "XYFZ", 1), 1, noise_um=0.3)
    return s, identify(s)


def test_wavelength_scale_error_moves_exx_by_eps_x(fitted):
    s, r = fitted
    attach_systematic(r, budget(laser__u_wavelength_ppm=1.0), "b.toml")
    assert r.sys_labels == ["laser wavelength"]
    x = r.layout.nodes[0]
    sys_u = r.function_std("EXX", x, systematic=True)
    noise_u = r.function_std("EXX", x, systematic=False)
    # EXX gauge at x = 0: the scale error's part grows as x u_rel (1 ppm: 0.8 um at 800 mm)
    assert np.sqrt(sys_u**2 - noise_u**2) == pytest.approx(x * 1e-3, abs=0.01)
    # readings scaled by (1 + eps), identified again: EXX moves by the propagated amount
    eps = 2e-6
    s2 = copy.deepcopy(s)
    for m in s2.measurements:
        L = (m.positions - m.positions[0]) @ m.beam_direction
        m.deviation = m.deviation + L * eps * 1e3
    r2 = identify(s2)
    moved = r2.errors.values[0][:, 0] - r.errors.values[0][:, 0]
    pos = -np.ones(r.layout.size, dtype=int)
    pos[r.free] = np.arange(r.free.size)
    p = pos[r.layout.indices(0, 0)]
    predicted = np.where(p >= 0, r.sys_factor[np.maximum(p, 0), 0], 0.0) * eps / 1e-6
    assert moved == pytest.approx(predicted, abs=0.02 * eps * 1e3 * 800)
    assert moved[-1] == pytest.approx(eps * x[-1] * 1e3, rel=0.03)


def test_model_file_keeps_the_parts_apart(fitted, tmp_path):
    _, r = fitted
    attach_systematic(r, budget(laser__u_wavelength_ppm=0.5, air__u_temperature_k=0.2,
                                material__temperature_c=21.0,
                                material__u_expansion_ppm_per_k=1.0), "b.toml")
    assert r.sys_labels[0] == "laser wavelength" and "material, X" in r.sys_labels
    assert sum(lab.startswith("air, ") for lab in r.sys_labels) == len(
        [m for m in r.design.measurements])
    from volcal.identify.modelfile import load_model

    q = np.array([[800.0, 600.0, 500.0], [400.0, 300.0, 250.0]])
    _, ut = r.predict(q)
    _, un = r.predict(q, systematic=False)
    # the model file (JSON + MODEL.npz with noise_factor and systematic_factor) and the
    # single-file format 2 of `identify -o -`
    for loaded in (load_model(r.to_json(tmp_path / "m.json")),
                   IdentificationResult.from_dict(r.to_single_file_dict())):
        assert loaded.sys_labels == r.sys_labels and loaded.sys_source == "b.toml"
        _, ul = loaded.predict(q)
        assert ul == pytest.approx(ut, rel=1e-5)
    with np.load(tmp_path / "m.npz") as z:
        assert z["systematic_factor"].shape == (r.free.size, len(r.sys_labels))
    assert np.all(ut >= un) and np.any(ut > un * 1.001)
    # without a budget the model file has no systematic section and nothing changes
    r.sys_factor = None
    assert "systematic" not in r.to_dict()
    assert r.predict(q)[1] == pytest.approx(un)


def test_predict_covers_the_truth_with_systematic_errors_drawn_from_the_budget():
    """Simulated machines whose readings carry wavelength, air (per set-up) and material
    (per axis) errors drawn from the budget: predict's 95 % intervals (k = 2) cover the
    truth 0.90-0.99 with the propagated systematic part, and fall short without it (the
    test has teeth). 12 machines, about 5 s."""
    from identify_helpers import grid

    from volcal.identify import IdentifyOptions
    from volcal.identify.design import choose_nodes
    from volcal.measure.systematic import apply_systematic, draw_systematic
    from volcal.model.kinematics import volumetric_error

    b = budget(laser__u_wavelength_ppm=1.0, air__u_temperature_k=0.5,
               air__u_pressure_pa=100.0, air__u_humidity_pct=5.0,
               material__temperature_c=22.0, material__u_temperature_k=0.3,
               material__u_expansion_ppm_per_k=1.0)
    s = seeds_session("XYFZ", steps=6, runs=2)
    q = grid(choose_nodes(s, refine=1), stride=3)
    hits, hits_noise = [], []
    for seed in range(12):
        truth = random_machine(TRAVEL, "XYFZ", seed=300 + seed)
        exact_fill(s, truth, seed=seed, noise_um=0.3)
        apply_systematic(s, draw_systematic(s, b, np.random.default_rng(seed)))
        r = attach_systematic(identify(s, IdentifyOptions(suggest=False)), b)
        err = np.abs(r.predict(q)[0] - volumetric_error(truth, q))
        hits.append(err <= 2 * r.predict(q)[1])
        hits_noise.append(err <= 2 * r.predict(q, systematic=False)[1])
    cover = np.mean(np.concatenate([h.ravel() for h in hits]))
    cover_noise = np.mean(np.concatenate([h.ravel() for h in hits_noise]))
    assert 0.90 <= cover <= 0.99, cover                  # 0.970 when written
    assert cover_noise < 0.85, cover_noise               # 0.761: the noise part alone
