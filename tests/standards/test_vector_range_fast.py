"""The model's U evaluated over all draws at once gives the numbers of the draw-by-draw code.

Issue 31, third round: the largest distance between two error vectors
(:func:`volcal.standards.volumetric.vector_range_pair`) is found without a convex hull where
one pair is clearly the longest, and the straightness lines of all draws are fitted in one
call (:func:`volcal.standards.linefit.line_fits`). Nothing volcal prints may change: the
same pair of points (the same indices, in the same order, ties broken as the hull broke
them), the same floats to the last bit. Each check compares against the definition: the
convex hull's pair (:func:`volcal.standards.volumetric._hull_pair`, the code of main
before the change) and ``numpy.polyfit`` column by column; the last one runs the draw-by-
draw loop of main before the change on an identified model with a systematic part.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from volcal.standards import volumetric as vol
from volcal.standards.linefit import line_fits

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "identify"))


def _same_pairs(clouds):
    """vector_range_pairs of the stack against the hull's pair of each cloud."""
    clouds = np.asarray(clouds, dtype=float)
    got = vol.vector_range_pairs(clouds)
    want = np.array([vol._hull_pair(c) for c in clouds]).reshape(-1, 2)
    np.testing.assert_array_equal(got, want)
    for c, (i, j) in zip(clouds, want, strict=True):
        assert vol.vector_range_pair(c) == (i, j)
        assert vol.vector_range(c) == float(np.linalg.norm(c[i] - c[j]))  # the same float
    values = vol.vector_ranges(clouds)
    assert [float(v) for v in values] == [vol.vector_range(c) for c in clouds]
    return vol._clear_pairs(clouds.transpose(1, 2, 0))[:, 0] >= 0  # the fast path


def _grid_fields(rng, k, n=6):
    """Smooth error fields over an n x n x n grid with random draws added, (k, n**3, 3)."""
    g = np.stack(np.meshgrid(*[np.linspace(0, 1, n)] * 3, indexing="ij"), -1).reshape(-1, 3)
    base = (np.sin(3 * g) * [20, -7, 4] + g[:, [1, 2, 0]] ** 2 * [5, 9, -3]
            + g[:, [2, 0, 1]] * [1, -2, 6])
    slopes = rng.standard_normal((k, 3, 3)) * 3
    bows = rng.standard_normal((k, 1, 3)) * 2
    return base[None] + g[None] @ slopes + bows * np.sin(np.pi * g[None, :, :1])


def test_random_clouds_take_the_fast_path_and_give_the_hulls_pair():
    rng = np.random.default_rng(31)
    clouds = [rng.standard_normal((40, 300, 3)),
              rng.uniform(-1, 1, (40, 300, 3)) * [50, 2, 0.5],   # long and flat, still thick
              rng.standard_normal((20, 60, 3)) * 1e-9 + 1e3,     # far from the origin, tiny
              _grid_fields(rng, 60)]
    fast = np.concatenate([_same_pairs(c) for c in clouds])
    assert fast.mean() > 0.9  # the check is on the fast path, not on the hull again


def test_ties_duplicates_and_degenerate_clouds_give_the_hulls_pair():
    rng = np.random.default_rng(7)
    cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    octa = np.vstack([np.eye(3), -np.eye(3)])
    inner = rng.uniform(0.2, 0.8, (30, 3))
    cases = {
        "cube corners (four equal diagonals)": np.vstack([cube, inner]),
        "cube shuffled": rng.permutation(np.vstack([inner, cube])),
        "octahedron (three equal diagonals)": np.vstack([octa, 0.3 * inner]),
        "collinear": np.outer(rng.uniform(-1, 1, 25), [1.0, 2.0, -0.5]),
        "coplanar": np.c_[rng.standard_normal((30, 2)), np.zeros(30)] @ rng.standard_normal(
            (3, 3)),
        "nearly flat (1e-5 thick)": rng.standard_normal((40, 3)) * [1, 1, 1e-5],
        "all the same point": np.ones((12, 3)),
        "one point": np.array([[1.0, 2.0, 3.0]]),
        "two points": np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]),
        "three points": rng.standard_normal((3, 3)),
        "four points": rng.standard_normal((4, 3)),
        "zeros and one other": np.vstack([np.zeros((6, 3)), [[1.0, 0.0, 0.0]]]),
    }
    base = rng.standard_normal((50, 3))
    i, j = vol._hull_pair(base)
    cases["an end of the longest pair twice"] = np.vstack([base, base[[j]]])
    cases["an end of the longest pair twice, first"] = np.vstack([base[[i]], base])
    cases["a near tie (1e-9)"] = np.vstack([base, base[j] + 1e-9 * (base[j] - base[i])])
    cases["the whole cloud twice"] = np.vstack([base, base])
    for k in range(20):  # points of a small lattice: many exactly equal distances
        cases[f"lattice {k}"] = rng.integers(0, 4, (int(rng.integers(5, 80)), 3)).astype(float)
    for name, c in cases.items():
        got = vol.vector_range_pair(c)
        assert got == vol._hull_pair(c), name
        assert vol.vector_range(c) == float(np.linalg.norm(c[got[0]] - c[got[1]])), name
    # ties among the stacked draws: each left to the hull (ties are not clear pairs)
    stack = np.stack([np.vstack([cube, inner]), rng.permutation(np.vstack([cube, inner]))])
    assert not _same_pairs(stack).any()


def test_near_ties_and_nearly_flat_clouds_give_the_hulls_pair():
    """Where the hull itself decides by rounding: an end of the longest pair doubled a
    hair away (the hull keeps one of the two as its vertex), a cloud 1e-13 thick (the hull
    merges facets and drops vertices). Without the margin and the thickness test
    (``CLEAR_MARGIN``, ``THIN_RATIO``) the search without the hull picks another point in
    some of these; with them it leaves them to the hull."""
    rng = np.random.default_rng(11)
    for _ in range(300):
        c = rng.standard_normal((int(rng.integers(5, 60)), 3)) * rng.uniform(0.1, 10, 3)
        i, j = vol._hull_pair(c)
        eps = 10.0 ** rng.uniform(-17, -3)
        c = np.vstack([c, c[rng.choice([i, j])] + eps * rng.standard_normal(3)])
        c = rng.permutation(c) if rng.random() < 0.5 else c
        assert vol.vector_range_pair(c) == vol._hull_pair(c), eps
    rot = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    for thick in (1e-13, 1e-13, 1e-9, 1e-5):
        for _ in range(50):
            c = (rng.standard_normal((int(rng.integers(5, 150)), 3)) * [1, 1, thick] @ rot * 10
                 + rng.standard_normal(3) * 100)
            assert vol.vector_range_pair(c) == vol._hull_pair(c), thick


def _all_vertex_pairs(e):
    """The hull's pair by its definition: every pair of the hull's vertices."""
    idx = vol._hull_points(e)
    pts = e[idx]
    d = np.sqrt(((pts[:, None, :] - pts[None, :, :]) ** 2).sum(axis=2))
    i, j = np.unravel_index(int(np.argmax(d)), d.shape)
    return int(idx[i]), int(idx[j])


def test_the_hulls_pair_from_the_vertices_that_can_reach_it():
    """``_hull_pair`` measures only the vertices that can reach the largest distance (a
    thin cloud, the field of a session of one measured axis, has thousands of hull
    vertices: the report's model U of such a session took 38 s instead of 5): the same
    pair, in the same order, as every pair of the vertices, on thin, flat, spherical,
    rounded (ties) and nearly doubled clouds."""
    rng = np.random.default_rng(12)
    for t in range(600):
        e = rng.normal(size=(int(rng.integers(2, 300)), 3))
        kind = t % 5
        if kind == 1:
            e[:, 1:] *= 1e-4
        elif kind == 2:
            e[:, 2] = 0.0
        elif kind == 3:
            e /= np.linalg.norm(e, axis=1, keepdims=True)
        elif kind == 4:
            e = np.vstack([np.round(e, 1), e[:3] + 1e-13])
        assert vol._hull_pair(e) == _all_vertex_pairs(e), t


def test_not_finite_is_left_to_the_hull():
    c = np.random.default_rng(3).standard_normal((20, 3))
    c[4, 1] = np.nan
    with np.errstate(invalid="ignore"):
        assert vol.vector_range_pair(c) == vol._hull_pair(c)


def test_line_fits_are_polyfit_bit_for_bit():
    rng = np.random.default_rng(5)
    for n, k, lo, hi in ((101, 300, -250.0, 730.0), (101, 1, 0.0, 800.0), (7, 40, 5.0, 6.0)):
        s = np.linspace(lo, hi, n)
        d = rng.standard_normal((n, k)) * 3 + rng.standard_normal(k) * 0.02 * s[:, None]
        slope, icpt = line_fits(s, d)
        want = np.array([np.polyfit(s, d[:, j], 1) for j in range(k)])
        np.testing.assert_array_equal(np.c_[slope, icpt], want)


def _old_draws(result, n, draws, seed):
    """The volumetric indices and straightness of every draw, as main computed them before
    (one draw at a time: the hull's pair, numpy.polyfit)."""
    from volcal.model.errorfunctions import interp_weights
    from volcal.model.kinematics import pose_jacobian
    from volcal.standards.model_uncertainty import _full_factor, straightness_functions

    rng = np.random.default_rng(seed)
    theta = np.asarray(result.theta, dtype=float)
    gn, gs = _full_factor(result, "noise"), _full_factor(result, "sys")
    dn = gn @ rng.standard_normal((gn.shape[1], draws))
    ds = gs @ rng.standard_normal((gs.shape[1], draws))
    q = vol.work_zone_grid(result.errors.travel, n)
    Je, _ = pose_jacobian(result.errors.chain_obj.order, result.layout.nodes, q, np.zeros(3))
    e0 = (Je @ theta).reshape(-1, 3)
    En, Es = np.asarray(Je @ dn), np.asarray(Je @ ds)

    def indices(e):
        i, j = vol._hull_pair(e)
        ptp = np.ptp(e, axis=0)
        return [ptp[0], ptp[1], ptp[2], float(np.linalg.norm(e, axis=1).max()),
                float(np.linalg.norm(e[i] - e[j]))]

    out = {"tot": [indices(e0 + (En[:, j] + Es[:, j]).reshape(-1, 3)) for j in range(draws)],
           "non": [indices(e0 + En[:, j].reshape(-1, 3)) for j in range(draws)],
           "sys": [indices(e0 + Es[:, j].reshape(-1, 3)) for j in range(draws)],
           "e0": e0}

    def straight(d, s):
        slope, icpt = np.polyfit(s, d, 1)
        return float(np.ptp(d - (icpt + slope * s)))

    for k, c, name in straightness_functions():
        s = np.linspace(*result.errors.travel[k], 101)
        i0, i1, w = interp_weights(result.layout.nodes[k], s)
        idx = result.layout.indices(k, c)

        def along(v, i0=i0, i1=i1, w=w, idx=idx):
            v = v[idx]
            return (1 - w)[:, None] * v[i0] + w[:, None] * v[i1] if v.ndim == 2 else \
                (1 - w) * v[i0] + w * v[i1]

        d0, dN, dS = along(theta), along(dn), along(ds)
        out[name] = (straight(d0, s),
                     [straight(d0 + dN[:, j] + dS[:, j], s) for j in range(draws)],
                     [straight(d0 + dN[:, j], s) for j in range(draws)],
                     [straight(d0 + dS[:, j], s) for j in range(draws)])
    return out


@pytest.fixture(scope="module")
def identified():
    """A small identified model with a systematic part (the seeds' tests, 6 steps)."""
    from identify_helpers import TRAVEL, exact_fill, seeds_session

    from volcal.identify import identify
    from volcal.identify.systematic import attach_systematic
    from volcal.measure.virtual import random_machine
    from volcal.uncertainty.budget import parse_budget

    s = seeds_session(steps=6)
    exact_fill(s, random_machine(TRAVEL, "XYFZ", 1), 3, noise_um=0.3)
    r = identify(s)
    budget = parse_budget({
        "laser": {"u_wavelength_ppm": 1.0},
        "air": {"temperature_c": 20.0, "pressure_pa": 101325.0, "humidity_pct": 50.0,
                "u_temperature_k": 0.1, "u_pressure_pa": 20.0, "u_humidity_pct": 5.0},
        "material": {"temperature_c": 20.5, "u_temperature_k": 0.2,
                     "expansion_ppm_per_k": 11.5, "u_expansion_ppm_per_k": 1.0},
        "setup": {"u_misalignment_urad": 0.0, "dead_path_mm": 0.0}})
    attach_systematic(r, budget, "b.toml")
    return r


def test_model_uncertainty_is_the_draw_by_draw_result(identified):
    from volcal.standards.model_uncertainty import _summary, model_uncertainty

    r = identified
    draws, n = 60, 7
    mu = model_uncertainty(r, n=n, draws=draws, seed=4)
    old = _old_draws(r, n, draws, seed=4)
    tot, non, sys_ = (np.array(old[key]) for key in ("tot", "non", "sys"))
    for i, key in enumerate(("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range")):
        got = mu.volumetric[key]
        want = _summary(got.value, tot[:, i], non[:, i], sys_[:, i], got.u_linear)
        assert got == want, key  # every float the same, to the last bit
    assert vol.vector_range_pair(old["e0"]) == vol._hull_pair(old["e0"])  # u_linear's pair
    for name, got in mu.straightness.items():
        value, st, sn, ss = old[name]
        assert got == _summary(value, np.array(st), np.array(sn), np.array(ss),
                               got.u_linear), name


@pytest.mark.parametrize("shape", [(3,), (2, 5, 2), (1, 0, 3)])
def test_bad_shapes_are_refused(shape):
    from volcal.errors import VolcalInputError

    with pytest.raises(VolcalInputError, match="shape"):
        vol.vector_range_pairs(np.zeros(shape))


def test_predict_gives_the_uncertainty_of_the_one_block_sum(identified):
    """``predict``'s u sums the factor's rows in blocks of points (in the cache): the
    floats of the one-block sum of before, for any block size."""
    from volcal.model.kinematics import volumetric_error

    r = identified
    q = vol.work_zone_grid(r.errors.travel, 9)
    t = np.zeros_like(q)
    L = r._full_factor(r._factor(True))
    want = np.empty_like(q)
    for c, terms in enumerate(r._error_rows(q, t)):
        G = np.zeros((q.shape[0], L.shape[1]))
        for cols, vals in terms:
            G += vals[:, None] * L[cols]
        want[:, c] = np.sqrt(np.einsum("mr,mr->m", G, G) + r.nugget_variance(c, q[:, c]))
    for chunk in (20000, 100, 7):
        e, u = r.predict(q, chunk=chunk)
        assert u.tobytes() == want.tobytes()
        assert e.tobytes() == volumetric_error(r.errors, q, t).tobytes()
