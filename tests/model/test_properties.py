"""Property tests (hypothesis): random chains, tool offsets and error sets."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import ALL_CHAINS, TRAVEL, machine
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import (
    first_order_pose,
    volumetric_error,
    volumetric_error_exact,
)

chains = st.sampled_from(ALL_CHAINS)
seeds = st.integers(0, 2**31 - 1)
offsets = st.lists(st.floats(-300, 300), min_size=3, max_size=3)
scales = st.floats(0.01, 10.0)
points = st.lists(st.lists(st.floats(-100, 900), min_size=3, max_size=3), min_size=1,
                  max_size=20)


def _bound(m: MachineErrors, q, t) -> float:
    """Upper bound of the second-order remainder [um]: (sum|eps|)^2 |L| + sum|eps| sum|delta|."""
    ang = sum(np.abs(v[:, 3:]).max() for v in m.values) * 1e-6 + np.abs(m.squareness).max() * 1e-6
    lin = sum(np.abs(v[:, :3]).max() for v in m.values)  # um
    lever = np.abs(q).sum(axis=1).max() + np.abs(t).sum()  # mm
    return 2.0 * (ang**2 * lever * 1e3 + ang * lin) + 1e-9


@settings(max_examples=60, deadline=None)
@given(chains, seeds, offsets, scales, points)
def test_first_order_close_to_exact(chain, seed, t, scale, q):
    m = machine(chain, seed % 1000, scale, n_nodes=9)
    q, t = np.array(q), np.array(t)
    d = volumetric_error_exact(m, q, t) - volumetric_error(m, q, t)
    assert np.abs(d).max() <= _bound(m, q, t)


@settings(max_examples=40, deadline=None)
@given(chains, seeds, seeds, offsets, points)
def test_first_order_is_linear_in_the_errors(chain, s1, s2, t, q):
    a = machine(chain, s1 % 1000, n_nodes=9)
    b = machine(chain, s2 % 1000, n_nodes=9)
    ab = MachineErrors(chain, a.nodes, [va + vb for va, vb in zip(a.values, b.values, strict=True)],
                       a.squareness + b.squareness)
    ea, wa = first_order_pose(a, q, t)
    eb, wb = first_order_pose(b, q, t)
    e, w = first_order_pose(ab, q, t)
    np.testing.assert_allclose(e, ea + eb, atol=1e-9)
    np.testing.assert_allclose(w, wa + wb, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(chains, seeds, points, st.lists(st.floats(-300, 300), min_size=3, max_size=3))
def test_tool_offset_acts_through_orientation_only(chain, seed, q, dt):
    """e(q, t + dt) - e(q, t) = omega(q) x dt: the offset is rigid with the tool."""
    m = machine(chain, seed % 1000, n_nodes=9)
    q, dt = np.array(q), np.array(dt)
    t = np.array([10.0, -20.0, 30.0])
    e1, w = first_order_pose(m, q, t)
    e2, _ = first_order_pose(m, q, t + dt)
    np.testing.assert_allclose(e2 - e1, np.cross(w * 1e-6, dt) * 1e3, atol=1e-9)


def test_travel_fixture_is_realistic():
    """The virtual machine respects the documented ranges (issue 2, item 5)."""
    for seed in range(20):
        m = machine("XYFZ", seed)
        for k in range(3):
            v = m.values[k]
            np.testing.assert_array_equal(v[0], 0.0)  # zero at travel start
            assert 5.0 <= np.ptp(v[:, k]) <= 20.0 + 1e-9
            for c in {0, 1, 2} - {k}:  # straightness: zero at both ends
                assert abs(v[-1, c]) < 1e-12
                assert 3.0 - 1e-9 <= np.ptp(v[:, c]) <= 10.0 + 1e-9
            assert np.all((np.ptp(v[:, 3:], axis=0) >= 5.0 - 1e-9)
                          & (np.ptp(v[:, 3:], axis=0) <= 30.0 + 1e-9))
        assert np.all(np.abs(m.squareness) <= 50.0)
        np.testing.assert_allclose(m.travel, TRAVEL)
    # reproducible from the seed
    np.testing.assert_array_equal(machine("XYFZ", 4).values[1], machine("XYFZ", 4).values[1])
