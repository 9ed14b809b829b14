"""A rigid-body motion of the whole work zone changes no simulated reading.

The motion G = (translation T, rotation Omega) of the workpiece relative to the tool's
whole path is written as error functions of the first axis of the chain (the one next
to the workpiece): constant translation T plus the straightness/positioning slopes
q1 (R_Omega u1 - u1), and the constant rotation Omega composed with its roll, pitch and
yaw. Then H'(q) = G H(q) exactly at the nodes, and every laser reading (beam aligned to
the actual motion, mirror aligned to the beam) is unchanged.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import TRAVEL, machine
from volcal.measure.readings import SetupErrors, reading_exact
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import (
    axis_directions,
    exact_pose,
    rotation_matrices,
    volumetric_error_exact,
)
from volcal.plan.planner import plan_session

T_UM = np.array([800.0, -500.0, 300.0])
OMEGA_URAD = np.array([150.0, -250.0, 400.0])


def with_rigid_motion(m: MachineErrors, t_um=T_UM, omega_urad=OMEGA_URAD,
                      position: int = 0) -> MachineErrors:
    """The machine seen after moving the whole work zone by (T, Omega).

    ``position`` > 0 puts the same motion on a later axis of the chain instead: that is
    no longer a motion of the whole work zone (control case).
    """
    k1 = m.chain_obj.order[position]
    u1 = axis_directions(m.squareness)[k1]
    Rw = rotation_matrices(np.asarray(omega_urad).reshape(1, 3) * 1e-6)[0]
    s = m.nodes[k1]
    v = m.values[k1].copy()
    slope = (Rw @ u1 - u1) * 1e3  # um per mm of travel of axis k1
    v[:, :3] = t_um + s[:, None] * slope + v[:, :3] @ Rw.T
    rot = Rotation.from_matrix(Rw @ rotation_matrices(v[:, 3:] * 1e-6))
    v[:, 3:] = rot.as_rotvec() * 1e6
    values = [x.copy() for x in m.values]
    values[k1] = v
    return MachineErrors(m.chain, [n.copy() for n in m.nodes], values, m.squareness.copy(),
                         m.reversal.copy(), m.name)


@pytest.mark.parametrize("chain", ["FXYZ", "XYFZ", "YFXZ", "ZXYF"])
def test_rigid_motion_construction_is_exact(chain, rng):
    m = machine(chain, seed=6)
    g = with_rigid_motion(m)
    # commanded positions on the nodes of every axis
    q = np.c_[rng.choice(m.nodes[0], 30), rng.choice(m.nodes[1], 30), rng.choice(m.nodes[2], 30)]
    t = np.array([30.0, -40.0, 120.0])
    p, R = exact_pose(m, q, t)
    p2, R2 = exact_pose(g, q, t)
    Rw = rotation_matrices(OMEGA_URAD.reshape(1, 3) * 1e-6)[0]
    np.testing.assert_allclose(p2, T_UM * 1e-3 + p @ Rw.T, atol=1e-10)
    np.testing.assert_allclose(R2, Rw @ R, atol=1e-13)
    # the work zone really moved: the volumetric error changes by up to a millimetre
    d = volumetric_error_exact(g, q, t) - volumetric_error_exact(m, q, t)
    assert np.abs(d).max() > 300.0


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ", "YFXZ"])
def test_rigid_motion_changes_no_reading(chain):
    s = plan_session(TRAVEL, chain, steps=10,
                     tests=("step-diagonal", "diagonal", "linear", "face-step-diagonal"),
                     runs=1, step_orders=("xyz", "zyx"), tool_offset=(20.0, -35.0, 150.0))
    m = machine(chain, seed=7)
    g = with_rigid_motion(m)
    for ms in s.measurements:
        r0 = reading_exact(m, ms, SetupErrors.none())
        r1 = reading_exact(g, ms, SetupErrors.none())
        np.testing.assert_allclose(r1, r0, atol=1e-6, err_msg=ms.id)
    # and through the simulator (noise, drift and set-up tilts off)
    opts = SimulationOptions(noise_um=0.0, mirror_misalignment_urad=0.0, seed=3)
    simulate_session(s, m, opts)
    before = [ms.deviation.copy() for ms in s.measurements]
    simulate_session(s, g, opts)
    for ms, b in zip(s.measurements, before, strict=True):
        np.testing.assert_allclose(ms.deviation, b, atol=1e-6, err_msg=ms.id)
    assert max(np.abs(b).max() for b in before) > 5.0


def test_control_motion_on_a_later_axis_is_seen(rng):
    """The same errors on the second axis of the chain are not a rigid motion: seen."""
    s = plan_session(TRAVEL, "XYFZ", steps=10, tests=("step-diagonal", "linear"), runs=1)
    m = machine("XYFZ", seed=7)
    g = with_rigid_motion(m, t_um=np.zeros(3), omega_urad=np.array([0.0, 0.0, 100.0]),
                          position=1)
    diff = max(np.abs(reading_exact(g, ms, SetupErrors.none())
                      - reading_exact(m, ms, SetupErrors.none())).max()
               for ms in s.measurements)
    assert diff > 5.0
