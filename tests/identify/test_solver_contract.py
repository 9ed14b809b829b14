"""One contract every estimator of volcal passes (as scikit-rf's calibration tests do for
each calibration algorithm): random machine -> exact simulation with noise and set-up
errors -> identify -> the volumetric error recovered within the reported uncertainty.

The estimators are the configurations a user can choose: the default (evidence-chosen
hyperparameters), a stated repeatability, the robust fit, drift estimation (on a session
whose linear tests can separate it), the rolls held at zero (on a machine without roll)
and the tracking interferometer (multilateration with its station nuisances). Each runs on
its own random machine of the study's sequence (not chosen), seeds' full test set, 0.5 um
noise, 20 urad mirror and beam misalignment.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_study_designs import study

from volcal.identify import IdentifyOptions, identify
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.kinematics import volumetric_error
from volcal.model.names import ROLL_NAMES
from volcal.model.rigid import remove_rigid_body
from volcal.plan.planner import plan_session
from volcal.standards.volumetric import work_zone_grid

CASES = {
    "default": IdentifyOptions(suggest=False),
    "stated noise": IdentifyOptions(suggest=False, noise_um=0.5),
    "robust": IdentifyOptions(suggest=False, robust=True),
    "drift": IdentifyOptions(suggest=False, drift=True),
    "roll zero": IdentifyOptions(suggest=False, roll="zero"),
}


def _machine(index: int, no_roll: bool = False):
    case = study.cases(len(CASES) + 1, master_seed=4242)[index]
    travel = np.array(study.TRAVEL, dtype=float)
    truth = random_machine(travel, case.chain, seed=case.machine_seed)
    if no_roll:
        for k in range(3):  # EAX, EBY, ECZ: column 3 + k of axis k
            truth.values[k][:, 3 + k] = 0.0
        assert all(np.all(truth.function(n, travel[k]) == 0) for k, n in enumerate(ROLL_NAMES))
    return case, travel, truth


def _check(r, truth, travel):
    q = work_zone_grid(travel, 7)
    e, u = r.predict(q)
    d = e - volumetric_error(truth, q)
    cover = float(np.mean(np.abs(d) <= 1.96 * u))
    rms_d, rms_u = float(np.sqrt(np.mean(d**2))), float(np.sqrt(np.mean(u**2)))
    assert 0.85 <= cover, (cover, rms_d, rms_u)
    assert rms_d < 1.5 * rms_u, (rms_d, rms_u)
    # and it is a calibration, not a shrug: judged without the rigid-body motion of the
    # whole work zone, which no laser reading sees (the prior and the gauge decide it; the
    # study judges accuracy the same way). Judged with it, the XFYZ machine of the robust
    # case went from 1.2 to 5.1 um (truth 15.8) when the set-up tilts got a finite prior,
    # with 1.3 um after the removal and the 95 % intervals still covering 0.99 of the grid
    et = volumetric_error(truth, q)
    err = float(np.sqrt(np.mean(remove_rigid_body(q, d) ** 2)))
    assert err < 0.3 * float(np.sqrt(np.mean(remove_rigid_body(q, et) ** 2)))


@pytest.mark.parametrize("name", list(CASES))
def test_every_estimator_recovers_the_machine_within_its_uncertainty(name):
    index = list(CASES).index(name)
    case, travel, truth = _machine(index, no_roll=name == "roll zero")
    s = plan_session(travel, case.chain, 8, study.FULL, runs=2)
    drift = 3.0 if name == "drift" else 0.0
    simulate_session(s, truth, study.simulation_options(case.sim_seed, drift))
    r = identify(s, CASES[name])
    _check(r, truth, travel)


def test_multilateration_recovers_the_machine_within_its_uncertainty():
    from volcal.plan.multilateration import multilateration_tests
    from volcal.session.format import Session

    case, travel, truth = _machine(len(CASES))
    s = Session("trk", case.chain, travel,
                multilateration_tests(travel, (5, 4, 4), None,
                                      ((0.0, 0.0, 0.0), (100.0, 100.0, 0.0))))
    simulate_session(s, truth, SimulationOptions(noise_um=0.2, seed=case.sim_seed))
    r = identify(s, IdentifyOptions(suggest=False))
    assert r.fit["multilateration"]["converged"]
    _check(r, truth, travel)
