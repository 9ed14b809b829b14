"""ISO 230-2 evaluation checked against values computed by hand from the definitions.

Data shaped like a real test: 5 unequally spaced targets, 5 runs, 2 directions. The
deviations of each target and direction are built as ``mean + s * (-1, -1, 0, 1, 1)``:
the offsets have mean 0 and sum of squares 4, so the sample standard deviation
(n - 1 = 4) is exactly ``s``. All expected figures below are worked out by hand from the
ISO 230-2:2014 definitions (see the comments).
"""

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.standards.iso230_2 import evaluate

TARGETS = np.array([0.0, 180.0, 420.0, 610.0, 800.0])
MU_UP = np.array([0.0, 3.0, 5.0, 2.0, -1.0])
MU_DN = np.array([-2.0, 1.0, 4.0, 3.0, -4.0])
S_UP = np.array([0.5, 1.0, 0.5, 1.5, 1.0])
S_DN = np.array([1.0, 0.5, 1.0, 0.5, 2.0])
OFFS = np.array([-1.0, -1.0, 0.0, 1.0, 1.0])

# Hand computation
# B_i = mu_up - mu_dn = [2, 2, 1, -1, 3] -> B = 3, B_mean = 7/5 = 1.4
# R_up_i = 4 s_up = [2, 4, 2, 6, 4] -> R_up = 6 ; R_dn_i = [4, 2, 4, 2, 8] -> R_down = 8
# 2s_up + 2s_dn + |B_i| = [5, 5, 4, 5, 9]; R_i = max(that, R_up_i, R_dn_i) = [5, 5, 4, 6, 9]
#   (at 610 mm R_i = R_up_i = 6 exceeds the sum 5: the trap of a formula without the max)
# E_up = 5 - (-1) = 6 ; E_down = 4 - (-4) = 8 ; E = max(5, 4) - min(-1, -4) = 9
# mean_i = [-1, 2, 4.5, 2.5, -2.5] -> M = 4.5 - (-2.5) = 7
# A_up = max(mu_up + 2s) - min(mu_up - 2s) = max[1, 5, 6, 5, 1] - min[-1, 1, 4, -1, -3] = 9
# A_down = max[0, 2, 6, 4, 0] - min[-4, 0, 2, 2, -8] = 14 ; A = max(6, 6) - min(-3, -8) = 14
EXPECTED = dict(A=14.0, A_up=9.0, A_down=14.0, E=9.0, E_up=6.0, E_down=8.0, M=7.0, R=9.0,
                R_up=6.0, R_down=8.0, B=3.0, B_mean=1.4)


def cycle(mu_up=MU_UP, mu_dn=MU_DN, s_up=S_UP, s_dn=S_DN, shuffle=None):
    """ISO 230-2 standard cycle: each run goes up through the targets, then down."""
    t, run, d, dev = [], [], [], []
    for j in range(5):
        for i in range(5):
            t.append(TARGETS[i])
            run.append(j + 1)
            d.append("+")
            dev.append(mu_up[i] + s_up[i] * OFFS[j])
        for i in reversed(range(5)):
            t.append(TARGETS[i])
            run.append(j + 1)
            d.append("-")
            dev.append(mu_dn[i] + s_dn[i] * OFFS[(j + 2) % 5])
    t, run, d, dev = map(np.array, (t, run, d, dev))
    if shuffle is not None:
        p = np.random.default_rng(shuffle).permutation(t.size)
        t, run, d, dev = t[p], run[p], d[p], dev[p]
    return t, run, d, dev


def test_hand_computed_values():
    res = evaluate(*cycle())
    for k, v in EXPECTED.items():
        assert getattr(res, k) == pytest.approx(v, abs=1e-12), k
    tab = res.targets
    np.testing.assert_allclose(tab.B, [2, 2, 1, -1, 3])
    np.testing.assert_allclose(tab.R, [5, 5, 4, 6, 9])
    np.testing.assert_allclose(tab.s_up, S_UP)
    np.testing.assert_allclose(tab.mean, [-1, 2, 4.5, 2.5, -2.5])
    assert res.warnings == []


def test_row_order_does_not_matter():
    a, b = evaluate(*cycle()), evaluate(*cycle(shuffle=3))
    assert a.to_dict() == b.to_dict()


def test_constant_offset_leaves_E_M_R_B_unchanged():
    t, run, d, dev = cycle()
    a, b = evaluate(t, run, d, dev), evaluate(t, run, d, dev + 17.3)
    for k in ("E", "E_up", "E_down", "M", "R", "R_up", "R_down", "B", "B_mean", "A"):
        assert getattr(b, k) == pytest.approx(getattr(a, k), abs=1e-9), k
    np.testing.assert_allclose(b.targets.mean_up, a.targets.mean_up + 17.3)


def test_swapping_directions_swaps_up_and_down():
    t, run, d, dev = cycle()
    sw = np.where(d == "+", "-", "+")
    a, b = evaluate(t, run, d, dev), evaluate(t, run, sw, dev)
    for up, down in (("A_up", "A_down"), ("E_up", "E_down"), ("R_up", "R_down")):
        assert getattr(b, up) == pytest.approx(getattr(a, down))
        assert getattr(b, down) == pytest.approx(getattr(a, up))
    for k in ("A", "E", "M", "R", "B"):
        assert getattr(b, k) == pytest.approx(getattr(a, k))
    assert b.B_mean == pytest.approx(-a.B_mean)


def test_edition_1988_uses_three_sigma():
    res = evaluate(*cycle(), edition="1988")
    # R_up = 6 max s_up = 9 ; A_up = max(mu + 3s) - min(mu - 3s) = 6.5 - (-4) = 10.5
    assert res.R_up == pytest.approx(9.0)
    assert res.A_up == pytest.approx(10.5)
    assert evaluate(*cycle(), edition="1997").to_dict()["A"] == pytest.approx(14.0)
    with pytest.raises(VolcalInputError, match="edition"):
        evaluate(*cycle(), edition="2099")


def test_test_cycle_warnings():
    t, run, d, dev = cycle()
    keep = run <= 3
    res = evaluate(t[keep], run[keep], d[keep], dev[keep])
    assert any("5 runs" in w for w in res.warnings)
    tt = np.round(t / 200.0) * 200.0  # equally spaced 0, 200, 400, 600, 800
    assert any("equally spaced" in w for w in evaluate(tt, run, d, dev).warnings)


@pytest.mark.parametrize("mutate, column, match", [
    (lambda t, r, d, v: (t[d == "+"], r[d == "+"], d[d == "+"], v[d == "+"]), "direction",
     "direction '-'"),
    (lambda t, r, d, v: (t, np.where(d == "+", 1, r), d, v), "run", "only 1 run"),
    (lambda t, r, d, v: (t, r, d, np.where(np.arange(v.size) == 7, np.nan, v)),
     "deviation_um", "finite"),
    (lambda t, r, d, v: (np.append(t, t[0]), np.append(r, r[0]), np.append(d, d[0]),
                         np.append(v, v[0])), "target_mm", "duplicate"),
    (lambda t, r, d, v: (t[1:], r[1:], d[1:], v[1:]), "target_mm", "missing reading"),
    (lambda t, r, d, v: (t, r, np.where(np.arange(d.size) == 4, "up", d), v), "direction",
     "'\\+' or '-'"),
])
def test_bad_input_names_column(mutate, column, match):
    t, r, d, v = mutate(*cycle())
    rows = np.arange(2, t.size + 2)
    with pytest.raises(VolcalInputError, match=match) as exc:
        evaluate(t, r, d, v, file="axis.csv", rows=rows)
    assert exc.value.column == column
    assert exc.value.file == "axis.csv"


def test_nan_error_names_row():
    t, r, d, v = cycle()
    v[7] = np.nan
    with pytest.raises(VolcalInputError) as exc:
        evaluate(t, r, d, v, file="axis.csv", rows=np.arange(2, t.size + 2))
    assert exc.value.row == 9
