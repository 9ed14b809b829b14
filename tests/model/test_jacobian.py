"""The pose Jacobian equals finite differences of the first-order model."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ALL_CHAINS, TRAVEL, machine
from volcal.model.kinematics import first_order_pose, pose_jacobian
from volcal.model.parameters import ParameterLayout


@pytest.mark.parametrize("chain", ["FXYZ", "XYFZ", "YFXZ", "ZXFY", "YZXF"])
def test_pose_jacobian_is_finite_difference(chain, rng):
    m = machine(chain, seed=5, n_nodes=7)
    lay = ParameterLayout(tuple(m.nodes))
    theta = lay.pack(m)
    q = rng.uniform(TRAVEL[:, 0], TRAVEL[:, 1], (15, 3))
    t = rng.uniform(-100, 100, 3)
    Je, Jo = pose_jacobian(m.chain_obj.order, m.nodes, q, t)
    e0, w0 = first_order_pose(m, q, t)
    # the model is linear: J theta reproduces it
    np.testing.assert_allclose(Je @ theta, e0.ravel(), atol=1e-9)
    np.testing.assert_allclose(Jo @ theta, w0.ravel(), atol=1e-9)
    h = 0.5
    Je_d, Jo_d = Je.toarray(), Jo.toarray()
    for j in range(lay.size):
        th = theta.copy()
        th[j] += h
        e1, w1 = first_order_pose(lay.unpack(th, chain), q, t)
        np.testing.assert_allclose((e1 - e0).ravel() / h, Je_d[:, j], atol=1e-9)
        np.testing.assert_allclose((w1 - w0).ravel() / h, Jo_d[:, j], atol=1e-9)


def test_layout_pack_unpack_roundtrip():
    m = machine(ALL_CHAINS[7], seed=2, n_nodes=9)
    lay = ParameterLayout(tuple(m.nodes))
    assert lay.size == 3 * 9 * 6 + 3
    m2 = lay.unpack(lay.pack(m), m.chain)
    for k in range(3):
        np.testing.assert_array_equal(m2.values[k], m.values[k])
    np.testing.assert_array_equal(m2.squareness, m.squareness)
    # indices address the documented function: EBY (axis 1, component 4)
    np.testing.assert_array_equal(lay.pack(m)[lay.indices(1, 4)], m.values[1][:, 4])
