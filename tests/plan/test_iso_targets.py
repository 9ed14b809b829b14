import numpy as np

from volcal.plan.geometry import iso_targets
from volcal.plan.planner import plan_session
from volcal.standards.iso230_2 import check_test_cycle


def test_iso_targets_unequal_within_a_quarter_interval_and_reproducible():
    t = iso_targets(0.0, 800.0, 10, seed=1)
    assert t[0] == 0.0 and t[-1] == 800.0 and t.size == 11
    assert np.all(np.abs(t - np.linspace(0, 800, 11)) <= 20.0 + 1e-9)  # p/4 = 20 mm
    assert np.ptp(np.diff(t)) > 1.0 and np.all(np.diff(t) > 0)
    np.testing.assert_array_equal(t, iso_targets(0.0, 800.0, 10, seed=1))


def test_planner_iso_spacing_silences_the_spacing_warning():
    s = plan_session([[0, 800], [0, 600], [0, 500]], "XYFZ", 10, ("linear",), iso_spacing=True)
    lines = [m for m in s.measurements if m.axis == 0]
    targets = [np.unique(m.positions[:, 0]) for m in lines]
    assert all(np.array_equal(targets[0], t) for t in targets)  # shared by the 3 lines
    assert not any("equally spaced" in w for w in check_test_cycle(targets[0], 5, 5))


def test_linear_margin_keeps_targets_inside_for_the_overrun():
    s = plan_session([[0, 800], [0, 600], [0, 500]], "XYFZ", 10, ("linear",),
                     linear_margin_mm=5.0, abbe_tool_offset_mm=120.0)
    for m in s.measurements:
        k = m.axis
        assert m.positions[:, k].min() == 5.0
        assert m.positions[:, k].max() == [800, 600, 500][k] - 5.0
    assert max(np.abs(m.tool_offset).max() for m in s.measurements) == 120.0
