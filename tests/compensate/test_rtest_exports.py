"""The location exports on an R-test-only session: the residual they state is the R-test's.

A simulated R-test of a trunnion whose hidden tilts LinuxCNC's trt kinematics cannot hold:
the exports state before = the measured displacements' dispersion (recomputed here from the
session's CSV columns), after = the dispersion the pins leave, which must equal the one
recomputed from the hidden truth (the true machine, the true sphere, LinuxCNC's lines
built from the HAL file's setp values); the Siemens record and the ISG file, which hold the
tilts, leave none beyond the estimate's own error.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from volcal.compensate.linuxcnc_trt import trt_hal
from volcal.compensate.rtest_residual import machine_command, rtest_dispersion
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.fiveaxis import FiveAxisMachine
from volcal.model.rotary import RotaryAxis
from volcal.plan.planner import plan_session
from volcal.session.probe_sphere import five_axis_machine
from volcal.steps.locate import locate

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


@pytest.fixture(scope="module")
def rtest_only():
    s = plan_session(TRAVEL, "XYFZ", steps=4, tests=("r_test",), runs=2)
    machine = random_machine(TRAVEL, "XYFZ", seed=3)
    setups = simulate_session(s, machine, SimulationOptions(seed=7))
    return s, machine, setups, locate(s, model=machine)


def test_trt_residual_of_an_r_test_is_the_truths(rtest_only):
    s, machine, setups, loc = rtest_only
    m = s.measurements[0]
    truth = setups["r_test"]
    tilts = {n: truth.location[n] for n in ("EA0C", "EB0C", "EB0A", "EC0A")}
    assert max(abs(v) for v in tilts.values()) > 50.0  # urad: tilts the kinematics lack
    exp = loc.linuxcnc_trt()
    # before: the measured displacements (the CSV's columns), distance from their mean
    d = np.column_stack([m.columns[c] for c in ("dx_um", "dy_um", "dz_um")])
    np.testing.assert_allclose(exp.scatter_before_um, np.linalg.norm(d - d.mean(axis=0), axis=1),
                               atol=1e-9)
    # after: LinuxCNC's lines from the HAL file, the true machine and sphere
    pins = {k: float(v) for k, v in re.findall(r"^setp xyzac-trt-kins\.(\S+) (\S+)$",
                                                trt_hal(exp), flags=re.M)}
    c = [pins["x-rot-point"], pins["y-rot-point"], pins["z-rot-point"]]
    a = [c[0], c[1] + pins["y-offset"], c[2] + pins["z-offset"]]
    true = five_axis_machine(m, machine, truth.location)
    control = FiveAxisMachine(true.chain_obj, {"C": RotaryAxis("C", c),
                                               "A": RotaryAxis("A", a, full_circle=False)},
                              true.linear)
    block = loc.blocks[0]
    recomputed = rtest_dispersion(true, machine_command(control, block.tool_offset_mm), block,
                                  truth.sphere_mm)
    assert recomputed.max() > 20.0  # um: the tilts' share, not held
    assert exp.residual_um.max() > 20.0
    np.testing.assert_allclose(exp.residual_um, recomputed, atol=0.5)
    assert exp.scatter_before_um.max() > 10.0 * exp.residual_um.max()


def test_siemens_and_isg_residual_of_an_r_test(rtest_only):
    s, machine, setups, loc = rtest_only
    truth = setups["r_test"]
    true = five_axis_machine(s.measurements[0], machine, truth.location)
    block = loc.blocks[0]
    # the whole identified machine held (tilts too): what is left is the estimate's error
    held = loc.result.machine
    recomputed = rtest_dispersion(true, machine_command(held, block.tool_offset_mm), block,
                                  truth.sphere_mm)
    for exp in (loc.siemens_tcarr(), loc.isg_location()):
        assert exp.scatter_before_um.max() > 100.0
        assert exp.residual_um.max() < 0.05
        np.testing.assert_allclose(exp.residual_um, recomputed, atol=0.5)
