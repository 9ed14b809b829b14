import numpy as np

from volcal.measure.virtual import random_machine
from volcal.model.errorfunctions import MachineErrors
from volcal.plot import error_functions_plot

TRAVEL = np.array([[0, 800], [0, 600], [0, 500]], float)


def _by_gid(fig, gid):
    for ax in fig.axes:
        for art in [*ax.get_lines(), *ax.collections]:
            if art.get_gid() == gid:
                return ax, art
    raise AssertionError(gid)


def test_truth_band_and_squareness_drawn_from_the_data():
    truth = random_machine(TRAVEL, "XYFZ", seed=3, n_nodes=41)
    est = MachineErrors("XYFZ", [n[::4] for n in truth.nodes],
                        [v[::4] * 0.9 for v in truth.values], truth.squareness + 2.0)
    std = [np.full((n.size, 6), 0.25) for n in est.nodes]
    fig = error_functions_plot(est, std, truth=truth, squareness_std=np.array([1.0, 2.0, 3.0]))
    # 18 component panels + 1 squareness panel
    assert len(fig.axes) == 19
    ax, line = _by_gid(fig, "EBY truth")
    assert ax.get_title() == "EBY [µrad]\nroll of Y"
    x = line.get_xdata()
    np.testing.assert_allclose(line.get_ydata(), truth.function("EBY", x))
    _, est_line = _by_gid(fig, "EBY estimate")
    np.testing.assert_allclose(est_line.get_ydata(), est.values[1][:, 4])
    # the band is estimate +- 2u: its polygon spans exactly that vertically
    _, band = _by_gid(fig, "EZX band")
    verts = band.get_paths()[0].vertices
    v = est.values[0][:, 2]
    assert np.isclose(verts[:, 1].max(), (v + 0.5).max())
    assert np.isclose(verts[:, 1].min(), (v - 0.5).min())
    sq_ax = fig.axes[-1]
    np.testing.assert_allclose([b.get_height() for b in sq_ax.patches], est.squareness)
    _, marks = _by_gid(fig, "squareness truth")
    np.testing.assert_allclose(marks.get_ydata(), truth.squareness)


def test_without_std_or_truth_draws_only_the_estimate():
    m = random_machine(TRAVEL, "FXYZ", seed=1, n_nodes=11)
    fig = error_functions_plot(m)
    assert all(not ax.collections for ax in fig.axes[:18])
    assert sum(len(ax.get_lines()) for ax in fig.axes[:18]) == 18


def test_panel_titles_and_squareness_ticks_come_from_the_name_table():
    from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES, info

    fig = error_functions_plot(random_machine(TRAVEL, "XYFZ", seed=2, n_nodes=11))
    for ax, name in zip(fig.axes[:18], COMPONENT_NAMES, strict=True):
        e = info(name)
        head, meaning = ax.get_title().split("\n")
        assert head == f"{name} [{e.unit_symbol}]" and meaning == e.label
        assert ax.get_lines()[0].get_gid() == f"{name} estimate"
    ticks = [t.get_text() for t in fig.axes[18].get_xticklabels()]
    assert ticks == [f"{n}\n{info(n).axis} to {info(n).reference}" for n in SQUARENESS_NAMES]
    assert [t.split("\n")[1] for t in ticks] == ["Y to X", "Z to X", "Z to Y"]
