import numpy as np
import pytest

from volcal.plot import direction_statistics, linear_deviation_plot
from volcal.session.format import Measurement


def _linear():
    # 3 bidirectional runs over targets 0, 100, 200 mm along X; deviations chosen by hand
    pos, dev, run, dirs = [], [], [], []
    up = {0: [0.0, 0.0, 0.0], 100: [1.0, 2.0, 3.0], 200: [4.0, 4.0, 7.0]}
    down = {0: [-1.0, -1.0, -1.0], 100: [0.0, 0.5, 1.0], 200: [2.0, 3.0, 4.0]}
    for r in range(3):
        for t in (0, 100, 200):
            pos.append([t, 0, 0])
            dev.append(up[t][r])
            run.append(r + 1)
            dirs.append("+")
        for t in (200, 100, 0):
            pos.append([t, 0, 0])
            dev.append(down[t][r])
            run.append(r + 1)
            dirs.append("-")
    return Measurement("lin", "linear", "retroreflector", np.array(pos, float), np.array(dev),
                       [1, 0, 0], columns={"run": np.array(run), "direction": np.array(dirs)},
                       meta={"axis": "X"})


def test_direction_statistics_hand_values():
    st = direction_statistics(_linear())
    up, down = st["+"], st["-"]
    np.testing.assert_allclose(up.targets, [0, 100, 200])
    np.testing.assert_allclose(up.mean, [0.0, 2.0, 5.0])
    # s of (1,2,3) = 1; s of (4,4,7) = sqrt(((1)^2+(1)^2+(2)^2)/2) = sqrt(3)
    np.testing.assert_allclose(up.std, [0.0, 1.0, np.sqrt(3.0)])
    np.testing.assert_allclose(down.mean, [-1.0, 0.5, 3.0])
    np.testing.assert_allclose(down.std, [0.0, 0.5, 1.0])
    assert up.runs == 3 and down.runs == 3


def _line(fig, gid):
    ax = fig.axes[0]
    found = [ln for ln in ax.get_lines() if ln.get_gid() == gid]
    assert len(found) == 1, gid
    return found[0]


def test_envelopes_are_mean_plus_minus_two_s():
    fig = linear_deviation_plot(_linear())
    np.testing.assert_allclose(_line(fig, "upper +").get_ydata(),
                               [0.0, 4.0, 5.0 + 2 * np.sqrt(3.0)])
    np.testing.assert_allclose(_line(fig, "lower -").get_ydata(), [-1.0, -0.5, 1.0])
    np.testing.assert_allclose(_line(fig, "mean -").get_xdata(), [0, 100, 200])
    # one thin line per run and direction
    runs = [ln for ln in fig.axes[0].get_lines() if str(ln.get_gid()).startswith("run ")]
    assert len(runs) == 6
    assert "[mm]" in fig.axes[0].get_xlabel() and "[µm]" in fig.axes[0].get_ylabel()


def test_no_deviation_is_an_error():
    m = _linear()
    m.deviation = None
    with pytest.raises(ValueError, match="no deviations"):
        linear_deviation_plot(m)


def test_error_bars_of_the_targets_are_plus_minus_U():
    fig = linear_deviation_plot(_linear(), uncertainty=([0, 100, 200], [-0.5, 1.25, 4.0],
                                                        [0.2, 0.3, 0.5]))
    ax = fig.axes[0]
    bars = [c for c in ax.containers if c.get_label() == "x̄ ± U (95 %)"]
    assert len(bars) == 1
    segs = bars[0].lines[2][0].get_segments()  # one vertical segment per target
    np.testing.assert_allclose([s[0][1] for s in segs], [-0.7, 0.95, 3.5])
    np.testing.assert_allclose([s[1][1] for s in segs], [-0.3, 1.55, 4.5])
    assert "x̄ ± U (95 %)" in [t.get_text() for t in ax.get_legend().get_texts()]
