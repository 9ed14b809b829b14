import numpy as np

from volcal.plot import identifiability_plot
from volcal.plot.identifiability import function_uncertainty


def _std():
    std = [np.full((5, 6), 0.1) for _ in range(3)]
    std[0][2, 0] = 0.4            # EXX worst node
    std[1][:, 3] = np.inf         # EAY (tilt of Y about X) not identified
    std[2][:, 5] = [1, 2, 3, 4, 9]  # ECZ
    return std


def test_function_uncertainty_takes_the_worst_node():
    u = function_uncertainty(_std(), [0.5, np.nan, 2.0])
    assert len(u) == 21
    assert u["EXX"] == 0.4 and u["ECZ"] == 9.0 and u["EYZ"] == 0.1
    assert np.isinf(u["EAY"]) and np.isinf(u["EB0Z"]) and u["EA0Z"] == 2.0


def test_bars_and_spectrum():
    fig = identifiability_plot(_std(), [0.5, 1.0, 2.0], singular_values=[1e-6, 10.0, 1.0])
    lin = fig.axes[0].patches
    assert [p.get_height() for p in lin][0] == 0.4 and len(lin) == 9
    ang = fig.axes[1].patches
    assert len(ang) == 12
    # the unidentified tilt is hatched and marked n/i
    eay = ang[3]
    assert eay.get_hatch() == "//"
    assert any(t.get_text() == "n/i" for t in fig.axes[1].texts)
    sv = [ln for ln in fig.axes[2].get_lines() if ln.get_gid() == "singular values"][0]
    np.testing.assert_allclose(sv.get_ydata(), [1.0, 0.1, 1e-7])


def test_determined_fraction_panel_colours_by_limits():
    frac = {"EXX": 0.999, "EAX": 0.36, "EYX": 0.74}
    fig = identifiability_plot(_std(), determined_fraction=frac)
    assert len([ax for ax in fig.axes if ax.axison]) == 3  # + one row holding the legend
    bars = fig.axes[2].patches
    np.testing.assert_allclose([b.get_width() for b in bars], [99.9, 36.0, 74.0])
    import matplotlib.colors as mc
    assert [mc.to_hex(b.get_facecolor()) for b in bars] == [
        mc.to_hex("tab:green"), mc.to_hex("tab:red"), mc.to_hex("tab:orange")]


def test_panels_split_the_names_by_the_table_units():
    from volcal.model.names import ERROR_TABLE

    fig = identifiability_plot(_std(), [0.5, 1.0, 2.0])
    lin = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    ang = [t.get_text() for t in fig.axes[1].get_xticklabels()]
    assert lin == [n for n, e in ERROR_TABLE.items() if e.kind in ("positioning",
                                                                    "straightness")]
    assert ang == [n for n, e in ERROR_TABLE.items() if e.kind in ("roll", "tilt",
                                                                    "squareness")]
    assert fig.axes[0].get_ylabel().endswith("[µm]") and fig.axes[1].get_ylabel().endswith(
        "[µrad]")
