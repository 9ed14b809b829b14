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


def _coo_pose_jacobian(order, nodes, q, t):
    """The pose Jacobian assembled entry by entry in COO form (the reference layout)."""
    import scipy.sparse as sp

    from volcal.model.errorfunctions import interp_weights

    m = q.shape[0]
    starts = np.concatenate([[0], np.cumsum([len(n) * 6 for n in nodes])])
    re, ce, ve, ro, co, vo = [], [], [], [], [], []
    lever = np.broadcast_to(np.asarray(t, dtype=float), (m, 3)).copy()
    levers = {}
    for k in reversed(order):
        levers[k] = lever.copy()
        lever[:, k] += q[:, k]
    for k in range(3):
        i0, i1, w = interp_weights(nodes[k], q[:, k])
        L = levers[k]
        zero = np.zeros(m)
        cross = [np.stack(v, 1) for v in ([zero, -L[:, 2], L[:, 1]], [L[:, 2], zero, -L[:, 0]],
                                          [-L[:, 1], L[:, 0], zero])]
        for idx, wt in ((i0, 1.0 - w), (i1, w)):
            base = starts[k] + idx * 6
            for c in range(3):
                re.append(3 * np.arange(m) + c), ce.append(base + c), ve.append(wt)
                ro.append(3 * np.arange(m) + c), co.append(base + 3 + c), vo.append(wt)
                for a in range(3):
                    re.append(3 * np.arange(m) + c), ce.append(base + 3 + a)
                    ve.append(wt * cross[a][:, c] * 1e-3)
    sq = starts[-1]
    for col, comp, val in ((sq, 0, -q[:, 1]), (sq + 1, 0, q[:, 2]), (sq + 2, 1, -q[:, 2])):
        re.append(3 * np.arange(m) + comp), ce.append(np.full(m, col)), ve.append(val * 1e-3)
    shape = (3 * m, int(sq) + 3)
    return [sp.csr_matrix((np.concatenate(v), (np.concatenate(r), np.concatenate(c))),
                          shape=shape) for r, c, v in ((re, ce, ve), (ro, co, vo))]


@pytest.mark.parametrize("n_nodes", [(7, 5, 9), (1, 4, 2), (3, 1, 1)])
def test_pose_jacobian_is_the_canonical_coo_assembly(n_nodes, rng):
    """Written in canonical CSR form directly, the Jacobian holds the entries a COO
    assembly gives, bit for bit, in the same order with the same stored zeros (a single
    node's two neighbours summed): the identification's numbers depend on the order."""
    nodes = [np.sort(rng.uniform(0, 800, n)) for n in n_nodes]
    q = rng.uniform(-50, 850, (23, 3))
    q[:4, 1] = 0.0
    for t in (None, rng.uniform(-100, 100, 3)):
        got = pose_jacobian((2, 0, 1), nodes, q, t)
        want = _coo_pose_jacobian((2, 0, 1), nodes, q, np.zeros(3) if t is None else t)
        for g, w in zip(got, want, strict=True):
            assert g.indices.dtype == w.indices.dtype and g.data.tobytes() == w.data.tobytes()
            np.testing.assert_array_equal(g.indices, w.indices)
            np.testing.assert_array_equal(g.indptr, w.indptr)
