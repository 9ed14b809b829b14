"""Drift: estimated where the design separates it from geometry, refused elsewhere."""

from __future__ import annotations

import numpy as np
import pytest
from identify_helpers import TRAVEL, seeds_session

from volcal.errors import VolcalInputError
from volcal.identify import IdentifyOptions, identify
from volcal.identify.design import choose_nodes, drift_separable
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine


def test_single_pass_tests_cannot_separate_drift():
    s = seeds_session("XYFZ", tests=("step-diagonal", "diagonal"))
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=2),
                     SimulationOptions(noise_um=0.5, seed=1, drift_um_per_h=5.0))
    assert not any(drift_separable(m) for m in s.measurements)
    with pytest.raises(VolcalInputError, match="single pass"):
        identify(s, IdentifyOptions(drift=True, suggest=False))


def test_drift_improves_the_result_where_runs_repeat():
    errs = {False: [], True: []}
    for seed in range(2):
        s = seeds_session("XYFZ", tests=("linear",), runs=2)
        truth = random_machine(TRAVEL, "XYFZ", seed=30 + seed)
        simulate_session(s, truth, SimulationOptions(noise_um=0.3, seed=seed,
                                                     drift_um_per_h=150.0))
        assert all(drift_separable(m) for m in s.measurements)
        for drift in (False, True):
            r = identify(s, IdentifyOptions(drift=drift, suggest=False))
            # the linear lines determine the positioning errors: compare them with the truth
            d = [r.errors.function(n, choose_nodes(s, refine=1)[k])
                 - truth.function(n, choose_nodes(s, refine=1)[k])
                 for k, n in enumerate(("EXX", "EYY", "EZZ"))]
            errs[drift].append(float(np.sqrt(np.mean(np.concatenate(d) ** 2))))
            if drift:
                assert any("Drift estimated" in t for t in r.report.messages)
    assert all(w < 0.6 * wo for w, wo in zip(errs[True], errs[False], strict=True)), errs
