"""Test geometry of every seed test, and the planner's default session."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import TRAVEL
from volcal.errors import VolcalInputError
from volcal.plan.geometry import diagonal_test, linear_test, step_diagonal_test
from volcal.plan.planner import plan_session

CORNERS = {"ppp": ([0, 0, 0], [800, 600, 500]), "npp": ([800, 0, 0], [0, 600, 500]),
           "pnp": ([0, 600, 0], [800, 0, 500]), "ppn": ([0, 0, 500], [800, 600, 0])}


@pytest.mark.parametrize("code", list(CORNERS))
def test_body_diagonal(code):
    g = diagonal_test(code, TRAVEL, 10)
    a, b = map(np.array, CORNERS[code])
    np.testing.assert_allclose(g.positions[0], a)
    np.testing.assert_allclose(g.positions[-1], b)
    np.testing.assert_allclose(g.beam_direction, (b - a) / np.linalg.norm(b - a))
    # equal increments of r = |b - a| / 10 along the beam
    np.testing.assert_allclose(np.diff(g.positions @ g.beam_direction),
                               np.linalg.norm(b - a) / 10)


@pytest.mark.parametrize("code", list(CORNERS))
@pytest.mark.parametrize("order", ["xyz", "yxz", "zyx"])
def test_step_diagonal(code, order):
    n_steps = 7
    g = step_diagonal_test(code, TRAVEL, n_steps, order)
    a, b = map(np.array, CORNERS[code])
    assert g.positions.shape == (1 + 3 * n_steps, 3)
    np.testing.assert_allclose(g.positions[-1], b, atol=1e-9)
    moves = np.diff(g.positions, axis=0)
    moved = np.abs(moves) > 1e-9
    assert np.all(moved.sum(axis=1) == 1)  # one axis per move
    axes = "xyz"
    np.testing.assert_array_equal(np.argmax(moved, axis=1)[:3], [axes.index(c) for c in order])
    # every third reading lies on the diagonal
    on = g.positions[::3] - a
    np.testing.assert_allclose(np.linalg.norm(np.cross(on, g.beam_direction), axis=1), 0,
                               atol=1e-9)
    assert g.meta["axis_order"] == order


def test_face_diagonals():
    g = diagonal_test("np", TRAVEL, 4, plane="yz", at_mm=100.0)
    np.testing.assert_allclose(g.positions[0], [100, 600, 0])
    np.testing.assert_allclose(g.positions[-1], [100, 0, 500])
    s = step_diagonal_test("pp", TRAVEL, 4, "xz", plane="xz")
    assert s.positions.shape == (9, 3)
    np.testing.assert_allclose(s.positions[:, 1], 0.0)
    with pytest.raises(VolcalInputError):
        step_diagonal_test("pp", TRAVEL, 4, "xyz", plane="xz")


def test_linear_bidirectional_iso230_2_cycle():
    g = linear_test("y", TRAVEL, 4, [10, 0, 20], runs=2, bidirectional=True)
    y = np.linspace(0, 600, 5)
    np.testing.assert_allclose(g.positions[:, 1], np.r_[y, y[::-1], y, y[::-1]])
    np.testing.assert_allclose(g.positions[:, [0, 2]], np.tile([10, 20], (20, 1)))
    assert "".join(g.direction) == "+" * 5 + "-" * 5 + "+" * 5 + "-" * 5
    np.testing.assert_array_equal(g.run, [1] * 10 + [2] * 10)


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ", "YFXZ", "ZXFY"])
def test_abbe_lines_give_three_independent_lever_arms(chain):
    """Per axis, the 3 lines separate positioning, pitch and yaw: the lever arms of the
    axis' angular errors (tool offset + downstream positions) span the plane across it."""
    from volcal.model.chain import parse_chain

    order = parse_chain(chain).order
    s = plan_session(TRAVEL, chain, steps=2, tests=("linear",), runs=1)
    for k in range(3):
        down = order[order.index(k) + 1:]
        a, b = [j for j in range(3) if j != k]
        rows = []
        for m in s.measurements:
            if m.axis != k:
                continue
            lever = m.tool_offset + np.array([m.positions[0, j] if j in down else 0.0
                                              for j in range(3)])
            rows.append([1.0, lever[a], lever[b]])
        assert len(rows) == 3
        assert abs(np.linalg.det(np.array(rows))) > 1e3  # [mm^2]


def test_default_plan_has_the_seed_test_set():
    s = plan_session(TRAVEL)
    kinds = [m.kind for m in s.measurements]
    assert kinds.count("step_diagonal") == 4 and kinds.count("diagonal") == 4
    assert kinds.count("linear") == 9
    assert {m.target for m in s.measurements if m.kind == "step_diagonal"} == {"flat_mirror"}
    assert len({m.id for m in s.measurements}) == 17
    for m in s.measurements:
        if m.kind == "linear":
            assert set(m.columns) == {"run", "direction"} and m.deviation is None


@pytest.mark.parametrize("kwargs", [dict(chain="XYZ"), dict(tests=("spiral",)), dict(steps=0),
                                    dict(runs=0), dict(travel=[[0, 1], [0, 1], [1, 0]]),
                                    dict(step_orders=("xxz",))])
def test_plan_rejects_bad_input(kwargs):
    args = dict(travel=TRAVEL) | kwargs
    with pytest.raises(VolcalInputError):
        plan_session(**args)
