"""``volcal compensate MODEL.json``: an identified model goes through the same tables."""

import numpy as np
import pytest

from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.generic import read_generic
from volcal.compensate.source import load_errors
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session

modelfile = pytest.importorskip("volcal.identify.modelfile")
api = pytest.importorskip("volcal.identify.api")


def test_identified_model_json_to_tables(tmp_path):
    travel = np.array([[0.0, 600.0], [0.0, 400.0], [0.0, 300.0]])
    s = plan_session(travel, "XYFZ", 6, ["step-diagonal", "diagonal", "linear"], 2)
    truth = random_machine(travel, "XYFZ", 5)
    simulate_session(s, truth, SimulationOptions(noise_um=0.05, mirror_misalignment_urad=0.0,
                                                 seed=5))
    path = api.identify(s).to_json(tmp_path / "MODEL.json")
    model = load_errors(path)
    write_compensation(model, "csv", tmp_path / "c", CompensationOptions("correction", 25.0))
    for k, t in enumerate(read_generic(tmp_path / "c" / "pitch.csv")):
        # exactly the identified model, resampled and rounded to 0.001 um ...
        np.testing.assert_allclose(t.values, -model.component(k, t.positions)[:, k],
                                   atol=0.0005 + 1e-9)
        # ... which is close to the hidden truth of the simulation (linear tests, low noise)
        err = np.max(np.abs(t.values + truth.component(k, t.positions)[:, k]))
        assert err < 1.0
