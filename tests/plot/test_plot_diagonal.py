import numpy as np

from volcal.plan.geometry import diagonal_test, step_diagonal_test
from volcal.plot import diagonal_fit_plot
from volcal.plot.diagonal import beam_displacement
from volcal.session.format import Measurement

TRAVEL = np.array([[0, 800], [0, 600], [0, 500]], float)


def _meas(mid, kind, g, dev):
    return Measurement(mid, kind, "retroreflector", g.positions, dev, g.beam_direction)


def test_beam_displacement_of_a_body_diagonal_is_its_length():
    g = diagonal_test("npp", TRAVEL, 10)
    s = beam_displacement(_meas("d", "diagonal", g, None))
    assert np.isclose(s[-1], np.sqrt(800**2 + 600**2 + 500**2))
    assert np.all(np.diff(s) > 0)


def test_fit_and_residuals():
    g = diagonal_test("ppp", TRAVEL, 4)
    dev = np.array([0.0, 1.0, 2.0, 1.0, 0.0])
    fit = np.array([0.0, 0.5, 2.5, 1.0, 0.0])
    gs = step_diagonal_test("ppp", TRAVEL, 2)
    ds = np.linspace(0, 3, gs.positions.shape[0])
    ms = [_meas("d", "diagonal", g, dev), _meas("s", "step_diagonal", gs, ds)]
    fig = diagonal_fit_plot(ms, fitted={"d": fit}, title="t")
    axes = fig.axes
    assert len(axes) == 4
    res = [ln for ln in axes[2].get_lines() if ln.get_gid() == "d residual"][0]
    np.testing.assert_allclose(res.get_ydata(), [0, 0.5, -0.5, 0, 0])
    assert axes[2].get_title() == f"residual rms {np.sqrt(0.5 / 5):.2f} µm"
    # no fit for 's': readings only, no residuals
    assert [ln.get_gid() for ln in axes[1].get_lines()] == ["s reading"]
