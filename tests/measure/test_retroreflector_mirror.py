"""Retroreflector with a return mirror (Soons, seed 004, section 2, second configuration)."""

import numpy as np

from volcal.identify import IdentifyOptions, identify
from volcal.measure.readings import (
    SetupErrors,
    perpendicular_basis,
    reading_exact,
    reading_first_order,
)
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.geometry import step_diagonal_test
from volcal.plan.planner import plan_session
from volcal.session.format import Measurement

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def _meas(target):
    g = step_diagonal_test("ppp", TRAVEL, 8)
    return Measurement("m", "step_diagonal", target, g.positions, None, g.beam_direction,
                       [0, 0, 80])


def test_tool_orientation_does_not_enter_but_the_return_mirror_tilt_does():
    vm = random_machine(TRAVEL, "XYFZ", seed=3)
    retro = _meas("retroreflector")
    rm = _meas("retroreflector_mirror")
    perfect = SetupErrors(np.zeros(3), np.zeros(3), align_beam=False)
    # no mirror tilt: identical to a plain retroreflector (orientation has no effect)
    np.testing.assert_allclose(reading_exact(vm, rm, perfect), reading_exact(vm, retro, perfect),
                               atol=1e-12)
    # a mirror tilt eps acts like the first-order tilt term tau = (eps x n) on the basis
    eps = np.cross(rm.beam_direction, [0.0, 0.0, 1.0])
    eps = 30.0 * eps / np.linalg.norm(eps)
    tilted = SetupErrors(eps, np.zeros(3), align_beam=False)
    tau = perpendicular_basis(rm.beam_direction) @ np.cross(eps, rm.beam_direction)
    exact = reading_exact(vm, rm, tilted)
    first = reading_first_order(vm, rm, tau)
    # a real effect: 30 urad over a lateral offset of up to one step (~56 mm) ~ 1.7 um
    assert np.abs(exact - reading_exact(vm, rm, perfect)).max() > 1.0
    half = reading_exact(vm.scaled(0.5), rm, SetupErrors(eps / 2, np.zeros(3), align_beam=False))
    first_half = reading_first_order(vm.scaled(0.5), rm, tau / 2)
    # second order: halving errors and tilt quarters the difference
    ratio = np.abs(exact - first).max() / np.abs(half - first_half).max()
    assert 3.6 < ratio < 4.4


def test_identify_step_diagonals_with_return_mirror_fits_to_the_noise():
    s = plan_session(TRAVEL, "XYFZ", 8, ("step-diagonal", "diagonal", "linear"), runs=2,
                     step_target="retroreflector_mirror")
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=9),
                     SimulationOptions(noise_um=0.3, mirror_misalignment_urad=20.0, seed=2))
    r = identify(s, IdentifyOptions(suggest=False))
    assert abs(r.fit["sigma_residual_um"] - 0.3) < 0.05
