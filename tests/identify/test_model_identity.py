"""Model <-> session identity, the typed fit record, model format versions."""

from __future__ import annotations

import copy
import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from timing import scaled_timeout
from volcal.errors import VolcalInputError
from volcal.identify import identify, load_model
from volcal.identify.modelfile import check_model_session, model_session_differences
from volcal.identify.record import FitRecord, readings_sha256, session_identity
from volcal.identify.result import MODEL_FORMAT, IdentificationResult
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session
from volcal_cli_helpers import volcal_process

DATA = Path(__file__).parent / "data"
TRAVEL = np.array([[0.0, 300.0], [0.0, 200.0], [0.0, 100.0]])


def volcal(*args):
    """``volcal *args`` in-process (VOLCAL_TEST_SUBPROCESS=1: in a process of its own)."""
    return volcal_process(*args, timeout=scaled_timeout(180))


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A small simulated session, its model, written to disk."""
    from conftest import machine

    root = tmp_path_factory.mktemp("ident")
    s = plan_session(TRAVEL, "XYFZ", 4, ("step-diagonal", "diagonal", "linear"), runs=2,
                     name="MILL-A")
    simulate_session(s, machine("XYFZ", 1, travel=TRAVEL, n_nodes=9),
                     SimulationOptions(noise_um=0.3, seed=2))
    write_session(s, root / "S")
    s = read_session(root / "S")
    r = identify(s)
    r.to_json(root / "model.json")
    return root, s, r


def test_hash_is_a_hand_computed_sha256_of_canonical_lines():
    s = plan_session(TRAVEL, "XYFZ", 2, ("linear",), runs=1, name="H")
    s.measurements = s.measurements[:1]
    m = s.measurements[0]
    m.deviation = np.arange(m.positions.shape[0], dtype=float) * 0.5
    m.deviation[1] = np.nan  # unmeasured reading: left out, and not counted
    kept = [i for i in range(m.positions.shape[0]) if i != 1]
    lines = "".join(f"{m.id},{j},{m.positions[i][0]:.9g},{m.positions[i][1]:.9g},"
                    f"{m.positions[i][2]:.9g},{m.deviation[i]:.9g}\n"
                    for j, i in enumerate(kept))
    digest, n = readings_sha256(s)
    assert digest == hashlib.sha256(lines.encode()).hexdigest()
    assert n == m.positions.shape[0] - 1
    # volcal before issue 25 numbered the readings by their index, the NaN's included
    old = "".join(f"{m.id},{i},{p[0]:.9g},{p[1]:.9g},{p[2]:.9g},{m.deviation[i]:.9g}\n"
                  for i, p in enumerate(m.positions) if i != 1)
    assert readings_sha256(s, legacy=True)[0] == hashlib.sha256(old.encode()).hexdigest()
    assert old != lines


def test_fresh_and_loaded_have_one_shape(small):
    root, s, r = small
    loaded = load_model(root / "model.json")
    assert isinstance(r.fit, FitRecord) and isinstance(loaded.fit, FitRecord)
    assert loaded.format == MODEL_FORMAT == "volcal-model/3"
    assert loaded.session == r.session == session_identity(s)
    assert loaded.session.name == "MILL-A" and loaded.session.chain == "XYFZ"
    assert loaded.fit.n_readings == r.fit.n_readings == sum(m.deviation.size
                                                            for m in s.measurements)
    assert loaded.fit.sigma_um == pytest.approx(r.fit.sigma_um, rel=1e-6)
    assert loaded.fit["sigma_um"] == loaded.sigma_um  # dict-style access still works
    assert loaded.fit.hyperparameters.keys() == r.fit.hyperparameters.keys()
    assert set(loaded.fitted) == set(r.fitted)
    for x in (r, loaded):
        text = repr(x)
        assert len(text) < 300 and "MILL-A" in text
        lines = x.summary().splitlines()
        assert 3 <= len(lines) <= 10
        assert lines[0] == "model of MILL-A (chain XYFZ, travel 0..300 x 0..200 x 0..100 mm)"


def test_matching_session_passes_and_foreign_ones_are_named(small):
    root, s, r = small
    assert check_model_session(r, s) == []
    other = copy.deepcopy(s)
    other.name = "LATHE-9"
    other.travel = np.array([[0.0, 300.0], [0.0, 250.0], [0.0, 100.0]])
    other.measurements[0].deviation = other.measurements[0].deviation + 1.0
    d = model_session_differences(r, other)
    assert d[0] == "machine name 'MILL-A' (model) vs 'LATHE-9' (session)"
    assert d[1] == "travel 0..300 x 0..200 x 0..100 mm (model) vs 0..300 x 0..250 x 0..100 mm " \
                   "(session)"
    assert d[2].startswith(f"readings: the model was identified from {r.session.n_readings}")
    with pytest.raises(VolcalInputError, match="the model does not belong to this session: "
                       "machine name 'MILL-A'"):
        check_model_session(r, other)
    assert check_model_session(r, other, force=True) == d


def test_report_and_predict_refuse_a_foreign_model(small, tmp_path):
    root, s, r = small
    foreign = tmp_path / "F"
    shutil.copytree(root / "S", foreign)
    toml = (foreign / "session.toml").read_text().replace('"MILL-A"', '"MILL-B"')
    (foreign / "session.toml").write_text(toml)
    out = volcal("report", foreign, "--model", root / "model.json", "-o", tmp_path / "rep")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "machine name 'MILL-A' (model) vs 'MILL-B' (session)" in " ".join(out.stderr.split())
    assert not (tmp_path / "rep").exists()
    pts = tmp_path / "p.csv"
    pts.write_text("x_mm,y_mm,z_mm\n10,20,30\n")
    out = volcal("predict", root / "model.json", "--points", pts, "-o", tmp_path / "e.csv",
                 "--session", foreign)
    assert out.returncode == 2 and "MILL-B" in out.stderr and not (tmp_path / "e.csv").exists()
    out = volcal("predict", root / "model.json", "--points", pts, "-o", tmp_path / "e.csv",
                 "--session", foreign, "--force")
    assert out.returncode == 0, out.stderr
    assert "warning" in out.stderr and "warning" not in out.stdout  # stdout: results only
    assert (tmp_path / "e.csv").is_file()


def test_format_1_model_loads_with_defaults():
    m = load_model(DATA / "model_v1.json")  # written by volcal 0.1.0 (format 1)
    assert m.format == "volcal-model/1" and m.session is None
    assert m.fit.n_readings == 252 and m.fit.method == "bayes"
    assert set(m.fit.hyperparameters) == {"positioning_um", "straightness_um", "angular_urad",
                                          "kappa"}
    assert m.fit.convergence.converged is None
    assert "optimiser convergence not recorded" in m.summary()


def test_format_1_without_sigma_loads_and_reports(tmp_path):
    doc = json.loads((DATA / "model_v1.json").read_text())
    del doc["fit"]["sigma_um"]
    p = tmp_path / "m.json"
    p.write_text(json.dumps(doc))
    m = load_model(p)
    assert m.sigma_um is None
    assert "the model file gives no reading noise (fit.sigma_um)" in m.summary()


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.update(format="volcal-model/9"), "unknown model format 'volcal-model/9'"),
    (lambda d: d["fit"].update(n_readings="many"), "fit.n_readings: expected a number"),
    (lambda d: d.update(fit=[1, 2]), "invalid 'fit' section"),
    (lambda d: d.update(session={"name": "x"}), "invalid 'session' section"),
    (lambda d: d.update(nuisances={"a": 3}), "invalid 'nuisances' section"),
])
def test_bad_model_files_are_refused_with_a_message(tmp_path, edit, message):
    doc = json.loads((DATA / "model_v1.json").read_text())
    edit(doc)
    p = tmp_path / "m.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(VolcalInputError, match=message):
        load_model(p)


def test_convergence_from_the_estimator_is_kept(small, tmp_path):
    _, _, r = small
    d = r.to_dict()
    d["fit"]["convergence"] = {"optimiser": "L-BFGS-B", "iterations": 12, "evaluations": 30,
                               "converged": False, "message": "ABNORMAL"}
    back = IdentificationResult.from_dict(d)
    assert back.fit.convergence.iterations == 12
    assert "optimiser L-BFGS-B did NOT converge after 12 iterations (ABNORMAL)" in back.summary()


def test_known_takes_a_subset_of_functions(small, tmp_path):
    root, _, _ = small
    known = tmp_path / "roll.csv"
    known.write_text("axis,position_mm,EA_urad\nX,0,0\nX,150,5\nX,300,10\n")
    out = volcal("identify", root / "S", "--known", known, "-o", tmp_path / "m.json")
    assert out.returncode == 0, out.stderr
    m = load_model(tmp_path / "m.json")
    np.testing.assert_allclose(m.errors.function("EAX", [0.0, 75.0, 150.0, 300.0]),
                               [0.0, 2.5, 5.0, 10.0], atol=1e-4)
    assert m.fit.known == ["EAX"]


@pytest.mark.parametrize("text, message", [
    ("axis,position_mm,EA_urad\nX,0,0\nX,150,\nX,300,10\n",
     "row 3, column 'EA_urad': axis X: either fill every row of this axis or none"),
    ("axis,position_mm,EA_urad\nX,0,0\nX,300,1\nX,150,10\n",
     "row 4, column 'position_mm': positions of an axis must increase strictly"),
    ("axis,position_mm,EA_urad\nX,0,\nX,300,\n", "no known function"),
    ("axis,position_mm,EA_urad\nW,0,1\n", "row 2, column 'axis'"),
    ("axis,position_mm,EA_urad\nX,0,1e308\nX,1,0\n", "row 2, column 'EA_urad': absurd value"),
])
def test_known_table_mistakes_are_located(tmp_path, text, message):
    from volcal.session.errortable import read_known_functions

    p = tmp_path / "k.csv"
    p.write_text(text)
    with pytest.raises(VolcalInputError) as exc:
        read_known_functions(p)
    assert message in str(exc.value)
