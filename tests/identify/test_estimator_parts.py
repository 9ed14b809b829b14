"""Unit tests of the estimator's parts on small problems with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from identify_helpers import TRAVEL, exact_fill, seeds_session

from volcal.identify import IdentifyOptions, identify
from volcal.identify.design import build_design, choose_nodes
from volcal.identify.identifiability import (
    analyse,
    grid_points,
    information,
    null_space_covariance,
    rigid_projector,
)
from volcal.identify.prior import PriorStructure
from volcal.identify.settings import EstimatorSettings
from volcal.identify.solver import solve_bayes
from volcal.measure.virtual import random_machine
from volcal.model.kinematics import pose_jacobian


@pytest.fixture(scope="module")
def small():
    s = seeds_session("XYFZ", steps=4)
    exact_fill(s, random_machine(TRAVEL, "XYFZ", seed=3), seed=4)
    nodes = choose_nodes(s, refine=1, max_nodes=41)
    design = build_design(s, nodes, {})
    return s, design, PriorStructure.build(design.layout, design.free, 6.0)


@pytest.fixture
def rolls_rescaled(small, monkeypatch):
    """The small design at fixed scales and noise, with proper nuisance priors (so that
    the full evidence is well defined), and two functions of a factor ``r`` on the scales
    of some functions (default the three rolls): ``fit(r)`` -> (estimate, covariance) and
    ``log_evidence(r)``. Returns ``(design, prior, fscales, fit, log_evidence)``."""
    import volcal.identify.evidence as evidence
    from volcal.identify import solver
    from volcal.identify.prior import function_scales

    _, design, prior = small
    monkeypatch.setattr(evidence, "NUISANCE_PRECISION",
                        {k: 1e-2 for k in evidence.NUISANCE_PRECISION})
    ev = evidence._Evidence(design, prior, 100.0)
    fs = function_scales(np.array([8.0, 4.0, 12.0, 20.0]))
    sigma = 0.4

    def scaled(r, functions):
        g = fs.copy()
        g[list(functions)] *= r
        return g

    def fit(r=1.0, functions=solver.ROLL_FUNCTIONS):
        return solver._final_solve(ev, design, scaled(r, functions), sigma, True)[3:]

    def log_evidence(r, functions=solver.ROLL_FUNCTIONS):
        return -0.5 * ev.neg2(scaled(r, functions), sigma)

    return design, prior, fs, fit, log_evidence


def test_posterior_covariance_is_the_dense_inverse_of_the_precision(small):
    """The linear posterior (the two-model average over the rolls' presence off; that
    average is checked in :func:`test_roll_mixture_equals_the_fit_without_roll`)."""
    _, design, prior = small
    sol = solve_bayes(design, prior, np.array([10.0, 5.0, 15.0, 15.0]), 0.5,
                      settings=EstimatorSettings(roll_mixture_absent=0.0))
    ev_h = (design.A.T @ design.A).toarray() / 0.5**2
    from volcal.identify.evidence import _nuisance_precision

    Q = prior.precision(np.array([10.0, 5.0, 15.0, 15.0]), 100.0, ev_h.shape[0],
                        _nuisance_precision(design)).toarray()
    H = ev_h + Q
    np.testing.assert_allclose(sol.covariance, np.linalg.inv(H), rtol=1e-6,
                               atol=1e-9 * np.abs(sol.covariance).max())
    # the estimate is the posterior mean H^-1 A^T y / sigma^2
    np.testing.assert_allclose(sol.x, np.linalg.solve(H, design.A.T @ design.y / 0.25),
                               rtol=1e-6, atol=1e-9 * np.abs(sol.x).max())


def test_evidence_optimiser_converges_and_is_reported(small):
    s, _, _ = small
    r = identify(s, IdentifyOptions(suggest=False))
    conv = r.fit["convergence"]
    assert conv["optimiser"].startswith("L-BFGS-B") and conv["converged"], conv
    assert 0 < conv["evaluations"] < 400
    # stated noise: no optimisation of sigma, and it is used as stated
    r2 = identify(s, IdentifyOptions(noise_um=0.7, scales=(10.0, 5.0, 15.0, 15.0), suggest=False))
    assert r2.fit["sigma_um"] == 0.7
    assert r2.fit["convergence"]["evaluations"] == 1


def test_noise_um_is_honoured_without_prior(small):
    s, _, _ = small
    r = identify(s, IdentifyOptions(prior="none", noise_um=2.0, suggest=False))
    assert r.fit["sigma_um"] == 2.0
    r1 = identify(s, IdentifyOptions(prior="none", noise_um=1.0, suggest=False))
    # covariance scales with the stated noise squared: std doubles
    np.testing.assert_allclose(r.std[0], 2.0 * r1.std[0], rtol=1e-9, atol=1e-12)


def test_candidate_ambiguity_equals_the_full_null_space_computation(small):
    s, design, prior = small
    from volcal.identify.api import candidate_designs

    nodes = design.layout.nodes
    cands = candidate_designs(s, nodes, {})
    scales = np.array([10.0, 5.0, 15.0, 15.0])
    rep = analyse(design, prior, scales, 100.0, cands)
    # independent: full eigendecomposition of F + Fc for every candidate
    nf = design.n_free
    Qp = prior.precision(scales, 100.0, nf, np.zeros(0)).toarray()
    sc = np.sqrt(np.diag(Qp))
    F = information(design)
    from volcal.identify.identifiability import _order

    q = grid_points(design)
    Je, _ = pose_jacobian(_order(design), nodes, q, None)
    GP = rigid_projector(q) @ Je[:, design.free].toarray()
    expected = []
    for label, cd in cands.items():
        cov, _ = null_space_covariance((F + information(cd)) / np.outer(sc, sc),
                                       Qp / np.outer(sc, sc))
        cov = cov / np.outer(sc, sc)
        rms = float(np.sqrt(np.mean(np.clip(np.sum((GP @ cov) * GP, axis=1), 0, None))))
        expected.append((rms, label))
    expected.sort()
    got = [s_ for s_ in rep.suggestions]
    want = [f"{label}: volumetric ambiguity {rep.ambiguity_rms_um:.2f} -> {rms:.2f} um RMS"
            for rms, label in expected[:3] if rms < 0.9 * rep.ambiguity_rms_um]
    assert got and got == want


@pytest.mark.parametrize("extra", [False, True])
def test_evidence_gradient_equals_central_differences(small, extra):
    """The analytic gradient of -2 log evidence in log(scales, kappa, sigma) against
    central differences of the value (step 1e-5 in log space), with the block-diagonal
    prior (traces from the blocks) and with an extra precision (a known function given
    with its uncertainty: traces from the dense Q^-1)."""
    from volcal.identify.evidence import _Evidence

    s, design, prior = small
    if extra:
        x = np.linspace(0.0, 800.0, 5)
        design = build_design(s, design.layout.nodes, {"EXX": (x, 0.01 * x, 0.5)})
        prior = PriorStructure.build(design.layout, design.free, 6.0)
        assert design.extra_precision is not None and np.any(design.extra_precision)
    ev = _Evidence(design, prior, 100.0)
    p0 = np.log([8.0, 4.0, 12.0, 20.0, 7.0, 0.4])  # 4 scales, kappa, sigma

    def f(p):
        return ev.neg2(np.exp(p[:4]), float(np.exp(p[5])), float(np.exp(p[4])))

    val, grad = ev.neg2_grad(np.exp(p0[:4]), float(np.exp(p0[5])), float(np.exp(p0[4])))
    assert val == pytest.approx(f(p0), rel=1e-12)
    h = 1e-5
    fd = np.array([(f(p0 + h * e) - f(p0 - h * e)) / (2 * h) for e in np.eye(6)])
    np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=1e-5 * np.abs(fd).max())
    assert np.abs(grad).min() > 1e-3  # every component is exercised


@pytest.mark.parametrize("lam", [1e-5, 1e-4, 1e-3])
def test_prior_reproduces_the_cubic_smoothing_spline(lam):
    """Observations at every node of one function, noise sigma: the posterior mean with the
    prior's curvature part (amplitude part made negligible by a large scale ``a``,
    ``kappa`` set so that ``sigma^2 / (a kappa)^2`` is the spline's ``lam``) is scipy's
    cubic smoothing spline (Reinsch) to within 1e-2 um, against 0.3 um of smoothing."""
    from scipy.interpolate import make_smoothing_spline

    from volcal.identify.prior import unit_precision

    rng = np.random.default_rng(1)
    x = np.linspace(0.0, 800.0, 201)
    s = x / 800.0
    y = 5 * np.sin(2.5 * s) + 3 * s**2 + rng.normal(0, 0.5, x.size)
    sigma, a = 0.5, 1e4
    kappa = sigma / (a * np.sqrt(lam))
    Q = unit_precision(x, kappa) / a**2
    f = np.linalg.solve(np.eye(x.size) / sigma**2 + Q, y / sigma**2)
    g = make_smoothing_spline(s, y, lam=lam)(s)
    assert np.abs(f - g).max() < 1e-2
    assert np.std(g - y) > 0.25  # the spline does smooth


def test_evidence_equals_the_gaussian_marginal_likelihood(small, monkeypatch):
    """-2 log evidence against the dense Gaussian marginal of the readings,
    ``y ~ N(0, sigma^2 I + A Q^-1 A^T)`` (the integral over the parameters in closed
    form), with proper nuisance priors (precision 1e-2) so that the dense covariance is
    well conditioned."""
    import volcal.identify.evidence as evidence

    _, design, prior = small
    monkeypatch.setattr(evidence, "NUISANCE_PRECISION",
                        {k: 1e-2 for k in evidence.NUISANCE_PRECISION})
    ev = evidence._Evidence(design, prior, 100.0)
    scales, sigma, kappa = np.array([8.0, 4.0, 12.0, 20.0]), 0.4, 7.0
    got = ev.neg2(scales, sigma, kappa)
    Q = ev.prior_dense(scales, kappa)
    A = design.A.toarray()
    K = sigma**2 * np.eye(A.shape[0]) + A @ np.linalg.solve(Q, A.T)
    sign, logdet = np.linalg.slogdet(K)
    want = design.y @ np.linalg.solve(K, design.y) + logdet + design.y.size * np.log(2 * np.pi)
    assert sign > 0
    assert got == pytest.approx(want, rel=1e-9, abs=1e-6)


def test_evidence_gradient_in_every_hyperparameter(small):
    """The per-function gradient (18 function scales, kappa, sigma, the set-up tilts'
    scale, the positioning trend) against central differences, with the trend in the prior
    and a finite tilt prior (the seeds' set has step diagonals, hence tilts)."""
    from volcal.identify.evidence import _Evidence
    from volcal.identify.prior import TREND_FUNCTIONS

    _, design, prior = small
    ev = _Evidence(design, prior.with_trend(12.0), 100.0)
    assert ev.has_tilts
    rng = np.random.default_rng(5)
    f0 = rng.uniform(3.0, 20.0, 18)
    p0 = np.log(np.concatenate([f0, [7.0, 0.4, 30.0, 12.0]]))

    def f(p):
        ev.set_tilt_std(float(np.exp(p[20])))
        ev.prior = ev.prior.with_trend(float(np.exp(p[21])))
        return ev.neg2(np.exp(p[:18]), float(np.exp(p[19])), float(np.exp(p[18])))

    val = f(p0)
    val_g, grad = ev.neg2_grad_functions(np.exp(p0[:18]), float(np.exp(p0[19])),
                                         float(np.exp(p0[18])))
    assert val_g == pytest.approx(val, rel=1e-12)
    h = 1e-5
    fd = np.array([(f(p0 + h * e) - f(p0 - h * e)) / (2 * h) for e in np.eye(22)])
    f(p0)
    np.testing.assert_allclose(grad[:22], fd, rtol=1e-5, atol=1e-5 * np.abs(fd).max())
    assert abs(grad[21]) > 1e-3 and abs(grad[20]) > 1e-3  # trend and tilts are exercised
    assert all(abs(grad[f]) > 1e-6 for f in TREND_FUNCTIONS)


@pytest.mark.parametrize("nugget", [0.0, 0.3])
def test_evidence_shared_and_kept_parts_change_no_bit(small, nugget):
    """Blocks with the same precision (an axis' two straightness errors and its two tilts
    at their group's scale) share their parts in an evaluation, and the prior's parts and
    the posterior's factor are kept for the next evaluation at the same hyperparameters:
    the value and the gradient equal, bit for bit, those with every block on its own and
    nothing kept."""
    from dataclasses import replace

    from volcal.identify.evidence import _Evidence
    from volcal.identify.prior import function_scales

    _, design, prior = small
    prior = prior.with_trend(12.0).with_tilt_trend(5.0).with_nugget(nugget)
    assert len(set(prior.shapes)) < len(prior.blocks)  # some blocks do share
    fs = function_scales(np.array([8.0, 3.0, 12.0, 20.0]))
    ev = _Evidence(design, prior, 100.0)
    value, grad = ev.neg2_grad_functions(fs, 0.4, 7.0)
    again = ev.neg2_grad_functions(fs, 0.4, 7.0)  # the kept parts
    alone = _Evidence(design, replace(prior, shapes=[], _unit={}), 100.0)
    for v, g in (again, alone.neg2_grad_functions(fs, 0.4, 7.0)):
        assert v == value and g.tobytes() == grad.tobytes()
    H, Q, cf = ev.factor(fs, 0.4, 7.0)
    H1, Q1, cf1 = alone.factor(fs, 0.4, 7.0)
    assert H.tobytes() == H1.tobytes() and cf[0].tobytes() == cf1[0].tobytes()


def test_coarse_search_without_the_linear_solve(small):
    """``solve_bayes(estimate=False)`` (the coarse grid's search, whose estimate is not
    kept) finds the same hyperparameters, bit for bit, and leaves the estimate out."""
    _, design, prior = small
    full = solve_bayes(design, prior, roll_presence=False)
    hyper = solve_bayes(design, prior, roll_presence=False, estimate=False)
    for name in ("function_scales", "scales"):
        assert getattr(hyper, name).tobytes() == getattr(full, name).tobytes()
    assert (hyper.sigma_um, hyper.kappa, hyper.tilt_std_urad, hyper.trend_um,
            hyper.log_evidence, hyper.convergence) == (
        full.sigma_um, full.kappa, full.tilt_std_urad, full.trend_um, full.log_evidence,
        full.convergence)
    assert hyper.x.size == 0 and hyper.covariance is None and np.isnan(hyper.dof)


def test_evidence_gradient_with_the_nugget(small):
    """With the short-wavelength (nugget) part of the positioning prior, the gradient in
    every hyperparameter (function scales, kappa, sigma, tilts, trend and the nugget,
    index 26) against central differences; the nugget block's precision is the inverse of
    ``a^2 P^-1 + t^2 s s' + n^2 (I + 1 1')`` (difference form)."""
    from volcal.identify.evidence import N_HYPER, _Evidence
    from volcal.identify.prior import TREND_FUNCTIONS

    _, design, prior = small
    ev = _Evidence(design, prior.with_trend(12.0).with_nugget(0.7), 100.0)
    rng = np.random.default_rng(6)
    f0 = rng.uniform(3.0, 20.0, 18)
    p0 = np.log(np.concatenate([f0, [7.0, 0.4, 30.0, 12.0, 0.7]]))

    def f(p):
        ev.set_tilt_std(float(np.exp(p[20])))
        ev.prior = ev.prior.with_trend(float(np.exp(p[21]))).with_nugget(float(np.exp(p[22])))
        return ev.neg2(np.exp(p[:18]), float(np.exp(p[19])), float(np.exp(p[18])))

    val = f(p0)
    val_g, grad = ev.neg2_grad_functions(np.exp(p0[:18]), float(np.exp(p0[19])),
                                         float(np.exp(p0[18])))
    assert grad.size == N_HYPER
    assert val_g == pytest.approx(val, rel=1e-12)
    h = 1e-5
    fd = np.array([(f(p0 + h * e) - f(p0 - h * e)) / (2 * h) for e in np.eye(23)])
    f(p0)
    got = np.append(grad[:22], grad[26])
    np.testing.assert_allclose(got, fd, rtol=1e-5, atol=1e-5 * np.abs(fd).max())
    assert abs(grad[26]) > 1e-3
    b = next(i for i, blk in enumerate(ev.prior.blocks) if blk[4] == TREND_FUNCTIONS[0])
    fs = np.exp(p0[:18])
    Pinv = np.linalg.inv(ev.prior.unit_block(b)[0])
    s = ev.prior.coords[b]
    n = s.size
    t = 12.0 * ev.prior.trend_length[0]  # um/m times the X travel [m] (issue 30)
    S = fs[0] ** 2 * Pinv + t**2 * np.outer(s, s) + 0.49 * (np.eye(n) + np.ones((n, n)))
    np.testing.assert_allclose(ev.prior.block_precision(b, fs), np.linalg.inv(S),
                               rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("boundary", ["conditional", "difference"])
def test_trend_prior_is_the_covariance_of_wiggles_plus_a_slope(small, boundary):
    """A positioning block's precision with the trend is the inverse of
    ``a^2 P^-1 + t^2 s s'`` (dense inverse), and the prior's log determinant the sum of the
    blocks'. ``P`` is the smoothness precision conditioned on the gauge zero (``C / kappa^2
    + W`` on the free nodes, ``EstimatorSettings.boundary = 'conditional'``) or, by
    default, the precision of the differences ``f_i - f_0`` of a function drawn on all the
    nodes (``(D (C_full / kappa^2 + W_full)^-1 D')^-1``; for a straightness the end-point
    line is removed)."""
    import volcal.identify.prior as prior_mod

    _, design, _ = small
    p = (PriorStructure.build(design.layout, design.free, 6.0,
                              settings=EstimatorSettings(boundary=boundary))
         .with_trend(15.0).with_kappa(5.0))
    fs = np.full(18, 4.0)
    nodes = design.layout.nodes[0]
    Cf, Wf = prior_mod.unit_parts(nodes)
    n = nodes.size
    sfull = (nodes - nodes[0]) / np.ptp(nodes)

    def base_cov(b):
        _, C, W, _, f = p.blocks[b]
        if boundary == "conditional":
            return np.linalg.inv(C / 25.0 + W)
        D = np.eye(n)[1:]
        D[:, 0] = -1.0
        if f in (1, 2):  # a straightness of X: the end-point line removed
            D = np.eye(n)[1:-1]
            D[:, 0] -= 1.0 - sfull[1:-1]
            D[:, -1] -= sfull[1:-1]
        return D @ np.linalg.inv(Cf / 25.0 + Wf) @ D.T

    b = next(i for i, blk in enumerate(p.blocks) if blk[4] == 0)  # EXX
    s = p.coords[b]
    t = 15.0 * p.trend_length[0]  # um/m times the X travel [m] (issue 30)
    cov = 16.0 * base_cov(b) + t**2 * np.outer(s, s)
    np.testing.assert_allclose(p.block_precision(b, fs), np.linalg.inv(cov), rtol=1e-8,
                               atol=1e-10 * np.abs(np.linalg.inv(cov)).max())
    assert s[-1] == pytest.approx(1.0) and np.all(np.diff(s) > 0)
    # the other blocks keep the smoothness prior without trend
    c = next(i for i, blk in enumerate(p.blocks) if blk[4] == 1)  # EYX
    want = np.linalg.inv(16.0 * base_cov(c))
    np.testing.assert_allclose(p.block_precision(c, fs), want, rtol=1e-8,
                               atol=1e-10 * np.abs(want).max())
    if boundary == "conditional":  # banded
        _, C1, W1, _, _ = p.blocks[c]
        np.testing.assert_allclose(p.block_precision(c, fs), (C1 / 25.0 + W1) / 16.0)
    else:  # the far end is as free as f(1) - f(0): twice the variance of f(1) alone
        v = np.diag(base_cov(b))
        assert v[-1] > 1.5 * np.diag(np.linalg.inv(p.blocks[b][1] / 25.0 + p.blocks[b][2]))[-1]
    total = sum(np.linalg.slogdet(p.block_precision(i, fs))[1] for i in range(len(p.blocks)))
    expect = total - 2 * p.squareness.size * np.log(100.0)
    assert p.logdet(fs, 100.0, np.zeros(0)) == pytest.approx(expect, rel=1e-12)


def test_aligned_beam_readings_are_reproduced_by_the_design():
    """Exact readings of step diagonals whose beam is aligned to the machine's actual
    motion (perfect mirror, no noise) equal the design's rows times the true parameters to
    second order (1 nm against readings of ~10 um), because the design carries the
    alignment; without it they differ by micrometres (the tilt columns' share)."""
    from volcal.identify import design as D
    from volcal.measure.readings import SetupErrors, reading_exact

    truth = random_machine(TRAVEL, "XFYZ", seed=11)
    s = seeds_session("XFYZ", steps=6, tests=("step-diagonal",))
    for m in s.measurements:
        m.deviation = reading_exact(truth, m, SetupErrors.none())
    d = build_design(s, truth.nodes)
    x = np.zeros(d.layout.size)
    for k in range(3):
        for c in range(6):
            x[d.layout.indices(k, c)] = truth.values[k][:, c]
    x[d.layout.squareness_indices()] = truth.squareness
    pred = d.A[:, :d.n_free] @ x[d.free]
    for m in s.measurements:
        r = d.y[d.rows[m.id]] - pred[d.rows[m.id]]
        assert np.abs(r - r[0]).max() < 2e-3, m.id  # the offset column takes r[0]
        assert np.sqrt(np.mean(m.deviation**2)) > 2.0
    # the alignment rows are what makes it so
    m = s.measurements[0]
    T, visible = D._visible_tilts(m)
    assert visible == [0, 1]
    Je, _ = pose_jacobian(truth.chain_obj.order, truth.nodes, m.positions, m.tool_offset)
    al = D._alignment_rows(Je, m, T, visible)
    assert np.abs(al @ x).max() > 0.5


def test_coarsened_design_equals_the_design_built_on_the_coarse_nodes():
    """The hyperparameters are chosen on a coarser grid whose observation matrix is the
    fine one times the interpolation matrix (no second pass over the readings): equal to
    the matrix built from the readings on the coarse nodes (a subset of the fine ones),
    nuisance columns included; not offered when known errors are held fixed."""
    from volcal.identify.design import coarsen

    s = seeds_session("FXYZ", steps=8)
    exact_fill(s, random_machine(TRAVEL, "FXYZ", seed=21), seed=22)
    fine = choose_nodes(s, refine=2, max_nodes=41)
    coarse = choose_nodes(s, refine=2, max_nodes=21)
    assert all(np.all(np.isin(c, f)) for c, f in zip(coarse, fine, strict=True))
    d_f = build_design(s, fine, {})
    d_c = build_design(s, coarse, {})
    got = coarsen(d_f, coarse)
    assert got is not None and np.array_equal(got.free, d_c.free)
    assert got.nuisance_names == d_c.nuisance_names
    diff = abs(got.A - d_c.A).max()
    assert diff < 1e-9 * abs(d_c.A).max(), diff
    np.testing.assert_array_equal(got.y, d_c.y)
    x = np.linspace(0.0, 800.0, 5)
    assert coarsen(build_design(s, fine, {"EXX": (x, 0.01 * x)}), coarse) is None


def test_roll_scale_evidence_in_closed_form_equals_the_evidence(rolls_rescaled):
    """:func:`volcal.identify.solver._roll_log_likelihood` on the whitened information of
    one roll (:func:`volcal.identify.solver._roll_whitened`) writes the evidence of a
    rescaled roll from one posterior: ``l(rho) = -1/2 sum log(1 + rho^2 k) + 1/2 sum rho^2
    b^2 / (1 + rho^2 k)``. Checked against the full evidence ``-2 log p(y)`` recomputed
    with the roll's scale multiplied by rho (differences between rho values; constants
    cancel), written out here and as the solver computes it."""
    from volcal.identify import solver

    _, prior, fs, fit, log_evidence = rolls_rescaled
    x, cov = fit()
    f = 3  # EAX
    b = next(i for i, blk in enumerate(prior.blocks) if blk[4] == f)
    idx = prior.blocks[b][0]
    Lp = np.linalg.cholesky(prior.unit_block(b)[0])
    u = Lp.T @ x[idx] / fs[f]
    Su = Lp.T @ cov[np.ix_(idx, idx)] @ Lp / fs[f] ** 2
    sv, V = np.linalg.eigh((Su + Su.T) / 2)
    k = 1.0 / sv - 1.0
    b2 = (V.T @ u / sv) ** 2

    def closed(rho):
        q = 1.0 + rho**2 * k
        return -0.5 * np.sum(np.log(q)) + 0.5 * np.sum(rho**2 * b2 / q)

    def full(rho):
        return log_evidence(rho, (f,))

    kb = solver._roll_whitened(prior, fs, x, cov, (f,))
    rhos = [0.1, 0.5, 2.0, 5.0]
    got = [closed(r) - closed(1.0) for r in rhos]
    want = [full(r) - full(1.0) for r in rhos]
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6)
    mine = [solver._roll_log_likelihood(*kb, r**2) - solver._roll_log_likelihood(*kb, 1.0)
            for r in rhos]
    np.testing.assert_allclose(mine, want, rtol=1e-6, atol=1e-6)
    assert max(abs(w) for w in want) > 0.1  # the readings inform this roll: a real check


def test_roll_bayes_factor_equals_the_evidence(rolls_rescaled):
    """:func:`volcal.identify.solver.roll_log_bayes_factor`: the log Bayes factor of
    "rolls at their scale" over "no roll" from the three rolls' whitened information
    equals the difference of the full evidence with the three roll scales as they are and
    multiplied by 1e-6."""
    from volcal.identify import solver

    _, prior, fs, fit, full = rolls_rescaled
    x, cov = fit()
    L = full(1.0) - full(1e-6)
    assert abs(L) > 0.1  # not a trivial factor
    assert solver.roll_log_bayes_factor(prior, fs, x, cov) == pytest.approx(L, rel=1e-6,
                                                                            abs=1e-6)


def test_roll_mixture_equals_the_fit_without_roll(rolls_rescaled):
    """:func:`volcal.identify.solver._roll_mixture` (default,
    ``EstimatorSettings.roll_mixture_absent``): the second model (the fit with rolls
    conditioned on no roll) equals a full refit with the three roll scales multiplied by
    1e-6; the weight is ``P(roll | y)`` from the full evidence's Bayes factor; the
    mean is ``P x + (1 - P) x0``; the covariance the fit's plus ``(1 - P)^2 d d'``
    (``'roll'``), the mixture's own ``P C + (1 - P) C0 + P (1 - P) d d'`` (``'mixture'``)
    or the mean square error of that mean over the two models weighted at another prior
    probability of no roll, ``P' (C + (1 - P)^2 d d') + (1 - P') (C0 + P^2 d d')``
    (``'cautious'``, default), which is ``'mixture'`` at the estimate's prior probability
    and ``'roll'`` at none."""
    from volcal.identify import solver

    _, prior, fs, fit, log_evidence = rolls_rescaled
    x, cov = fit()
    x0, c0 = fit(1e-6)
    l1, l0 = log_evidence(1.0), log_evidence(1e-6)
    p = 0.4
    L = l1 - l0
    P = (1 - p) * np.exp(L) / ((1 - p) * np.exp(L) + p)
    assert 0.01 < P < 0.99, P  # both models weigh: a real check
    lbf = solver.roll_log_bayes_factor(prior, fs, x, cov)
    assert lbf == pytest.approx(L, abs=1e-5)
    pc_abs = 0.05  # the cautious weight's prior probability of no roll
    Pc = (1 - pc_abs) * np.exp(L) / ((1 - pc_abs) * np.exp(L) + pc_abs)
    assert Pc - P > 0.15, (P, Pc)  # the cautious weight differs: a real check
    d = x - x0
    dd = np.outer(d, d)
    cases = {"roll": cov + (1 - P) ** 2 * dd,
             "mixture": P * cov + (1 - P) * c0 + P * (1 - P) * dd,
             "cautious": Pc * (cov + (1 - P) ** 2 * dd) + (1 - Pc) * (c0 + P**2 * dd)}
    for mode, want in cases.items():
        xm, cm, shrink, p_roll = solver._roll_mixture(prior, fs, x, cov, lbf, p,
                                                      covariance=mode, p_absent_cov=pc_abs)
        assert p_roll == pytest.approx(P, rel=1e-5)
        scale = np.abs(x).max()
        np.testing.assert_allclose(xm, P * x + (1 - P) * x0, rtol=1e-6, atol=1e-6 * scale)
        np.testing.assert_allclose(shrink(x), xm, rtol=1e-9, atol=1e-9 * scale)
        np.testing.assert_allclose(cm, want, rtol=1e-5, atol=1e-6 * np.abs(want).max())
        assert solver.covariance_roll_weight(mode, lbf, p_roll, pc_abs) == pytest.approx(
            {"roll": 1.0, "mixture": P, "cautious": Pc}[mode], rel=1e-5)
    assert np.abs(d).max() > 0.05 * scale  # the two fits differ
    # 'cautious' at the estimate's own prior probability is 'mixture', at none 'roll'
    for pc_abs, mode in ((p, "mixture"), (0.0, "roll")):
        got = solver._roll_mixture(prior, fs, x, cov, lbf, p, covariance="cautious",
                                   p_absent_cov=pc_abs)[1]
        np.testing.assert_allclose(got, cases[mode], rtol=1e-5,
                                   atol=1e-6 * np.abs(cases[mode]).max())


def test_every_reading_sits_on_a_node_when_the_visited_positions_fit(monkeypatch):
    """The seeds' full set at 10 increments (ISO 230-2 spacing on the lines, uniform on
    the diagonals) visits about 22 positions per axis: refined by 2 that exceeds 41 nodes,
    and the grid used to fall back to 41 uniform nodes between which the lines read. Now
    every visited position is a node, the other nodes split the longest intervals, and
    the hyperparameters' grid holds the visited positions too."""
    from volcal.identify import api
    from volcal.identify.design import _fill_intervals, visited_positions
    from volcal.plan.planner import plan_session

    s = plan_session(TRAVEL, "XYFZ", 10, ("step-diagonal", "diagonal", "linear"), runs=1)
    nodes = choose_nodes(s, refine=2, max_nodes=41)
    visited = choose_nodes(s, refine=1, max_nodes=10**9)
    assert [v.size for v in visited] == visited_positions(s)
    for k in range(3):
        assert 2 * visited[k].size - 1 > 41 >= visited[k].size  # the case in question
        assert nodes[k].size == 41
        assert np.all(np.isin(np.round(visited[k], 6), np.round(nodes[k], 6))), k
        assert np.all(np.diff(nodes[k]) > 0)
    # the longest intervals are split first, evenly
    w = _fill_intervals(np.array([0.0, 10.0, 100.0]), 6)
    np.testing.assert_allclose(w, [0.0, 10.0, 32.5, 55.0, 77.5, 100.0])
    # the hyperparameters' grid: the visited positions (more than hyper_max_nodes)
    exact_fill(s, random_machine(TRAVEL, "XYFZ", seed=3), seed=4)
    grids = []

    def spy(design, *a, **k):
        grids.append([np.asarray(n) for n in design.layout.nodes])
        return solve_bayes(design, *a, **k)

    monkeypatch.setattr(api, "solve_bayes", spy)
    identify(s, IdentifyOptions(suggest=False))
    hyper = grids[0]  # the first solve chooses the hyperparameters
    for k in range(3):
        np.testing.assert_allclose(hyper[k], visited[k])
    assert EstimatorSettings().hyper_max_nodes < min(v.size for v in visited)


@pytest.mark.parametrize("seed", [6, 8])
def test_identify_says_when_the_readings_look_like_a_machine_without_roll(seed):
    """The same random machine with its three rolls and without them (values zeroed), the
    seeds' full set with 5 runs: with the rolls the log Bayes factor of "rolls of the
    prior's size" over "no roll" is large and positive and nothing is said; without them
    it is below -log(100) and the report advises ``--roll zero`` or a level. The factor
    is the closed form of :func:`volcal.identify.solver.roll_log_bayes_factor`, checked
    against the full evidence in :func:`test_roll_bayes_factor_equals_the_evidence`.
    (Over benchmarks/families.py the note names 9 of 20 machines without roll and none of
    80 with: the seeds' designs see a roll only in one or two directions. Seeds 5 and 7
    without roll come to -4.7 and -3.0, at or above the threshold's -4.6: the note is not
    certain on every machine without roll; these two seeds are clear of it, -7.7 and
    -11.3, and +23.9 / +71.0 with their rolls.)"""
    no_roll_note_factor = EstimatorSettings().no_roll_note_factor

    with_roll = random_machine(TRAVEL, "XYFZ", seed=seed)
    without = with_roll.copy()
    for k in range(3):
        without.values[k][:, 3 + k] = 0.0
    out = {}
    for name, m in (("with", with_roll), ("without", without)):
        s = seeds_session("XYFZ", steps=10, runs=5)
        exact_fill(s, m, seed=seed)
        r = identify(s, IdentifyOptions(suggest=False))
        note = [t for t in r.report.messages if "without roll errors" in t]
        out[name] = (r.solution.roll_log_bayes_factor, note)
        if name == "without":  # the two-model average against the rolls always kept
            from volcal.model.kinematics import volumetric_error
            from volcal.model.rigid import remove_rigid_body
            from volcal.standards.volumetric import work_zone_grid

            q = work_zone_grid(s.travel, 5)

            def err(res, q=q, m=m):
                d = remove_rigid_body(q, res.predict(q)[0] - volumetric_error(m, q))
                return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))

            kept = identify(s, IdentifyOptions(
                suggest=False, settings=EstimatorSettings(roll_mixture_absent=0.0)))
            errors = (err(r), err(kept))
            p_roll = r.fit["roll_presence"]["probability"]
    lbf, note = out["with"]
    assert lbf > 10.0 and not note, out["with"]
    lbf, note = out["without"]
    assert -lbf > np.log(no_roll_note_factor) and len(note) == 1, out["without"]
    assert "--roll zero" in note[0] and "level" in note[0]
    # the average leans to the fit without roll and is closer to the truth
    assert p_roll < 0.01 and f"weighted {p_roll:.2g}" in note[0]
    # seed 6: 0.74, seed 8: 0.95 (0.67 and 0.85 before the travel exponents of issue 30,
    # which improved the fit with rolls kept more, 1.81 -> 1.59 and 1.37 -> 1.24 um, than
    # the average, 1.20 -> 1.18 and 1.22 -> 1.18 um: the margin measured the reference)
    assert errors[0] < 0.97 * errors[1], errors


def test_identify_says_when_the_readings_leave_the_rolls_open(small, tmp_path):
    """Prior odds of no roll set so that the posterior weight of "roll" is one half: the
    report says the question is open with the weights, the model records them
    (``fit.roll_presence``), and the estimate lies halfway between the fit with rolls
    (odds 0) and the fit without."""
    def odds(p):  # the prior probability of no roll
        return IdentifyOptions(suggest=False, settings=EstimatorSettings(roll_mixture_absent=p))

    s, _, _ = small
    kept = identify(s, odds(0.0))
    lbf = kept.fit["roll_presence"]["log_bayes_factor"]
    assert kept.fit["roll_presence"]["probability"] is None
    p = float(np.exp(lbf) / (1.0 + np.exp(lbf)))  # prior odds p / (1 - p) = e^lbf
    half = identify(s, odds(p))
    rp = half.fit["roll_presence"]
    assert rp["probability"] == pytest.approx(0.5, abs=1e-6)
    assert rp["log_bayes_factor"] == pytest.approx(lbf, rel=1e-9)
    assert rp["prior_probability_absent"] == pytest.approx(p)
    note = [t for t in half.report.messages if "do not settle" in t]
    assert len(note) == 1 and "weighted 0.5 / 0.5" in note[0], half.report.messages
    from volcal.identify.modelfile import load_model, write_model

    write_model(half, tmp_path / "m.json")  # the model file keeps them
    assert load_model(tmp_path / "m.json").fit["roll_presence"] == pytest.approx(rp)
    gone = identify(s, odds(1.0 - 1e-12))  # P(roll) ~ 0: the fit without
    x = np.linspace(*TRAVEL[0], 7)
    for name in ("EXX", "EBX", "EYX"):
        a, b, c = (r.errors.function(name, x) for r in (kept, half, gone))
        np.testing.assert_allclose(b, (a + c) / 2, atol=1e-6 * np.abs(a).max())
    assert np.abs(a - c).max() > 0.01 * np.abs(a).max()  # the two fits differ


def test_projected_information_equals_the_projection_of_the_full_matrix(small):
    """``projected_information(d, P) = P^T information(d) P`` (the identifiability
    report's candidates, projected without forming the full matrix), on the seeds' design
    and on a candidate with an optical square's certificate as nuisance precision."""
    from volcal.identify.api import candidate_designs
    from volcal.identify.identifiability import projected_information
    from volcal.plan.planner import plan_session
    from volcal.session.format import Session

    s, design, _ = small
    rng = np.random.default_rng(0)
    cands = candidate_designs(s, design.layout.nodes, {})
    direct = plan_session(TRAVEL, "XYFZ", 4, ("direct",), runs=1)
    for m in direct.measurements:
        m.deviation = np.zeros(m.n)  # the information does not depend on the readings
    direct = Session("d", "XYFZ", TRAVEL, direct.measurements,
                     references={"xy": {"square_deviation_urad": 1.0, "u_square_urad": 2.5}})
    sq = build_design(direct, choose_nodes(direct, refine=1), {})
    assert np.any(sq.extra_precision[sq.n_free:])  # the optical square's certificate
    for d in [design, *list(cands.values())[:4], sq]:
        P = rng.normal(size=(d.n_free, 7))
        want = P.T @ information(d) @ P
        np.testing.assert_allclose(projected_information(d, P), want, rtol=1e-9,
                                   atol=1e-9 * np.abs(want).max())


def test_twenty_increments_keep_the_readings_on_nodes():
    """At 20 increments the seeds' full set visits 42 positions per axis, one more than
    the 41 nodes: the visited positions alone are the nodes (visited_nodes_factor), so
    that minimum-norm least squares, whose nodes are the visited positions, stays sound:
    on the uniform fallback it returned 57-6300 um on the families' 7-15 um machines, and
    84.6 um on this 11.0 um machine (17.2 um with the visited positions: minimum norm sets
    what the design does not see, e.g. squareness, to zero in volcal's gauge, so it may
    exceed the machine's own error, but not by a factor 8). The default estimator is well
    below both."""
    from volcal.identify.design import visited_positions
    from volcal.model.kinematics import volumetric_error
    from volcal.model.rigid import remove_rigid_body
    from volcal.plan.planner import plan_session

    s = plan_session(TRAVEL, "XYFZ", 20, ("step-diagonal", "diagonal", "linear"), runs=1)
    v = visited_positions(s)
    assert all(41 < n <= EstimatorSettings().visited_nodes_factor * 41 for n in v), v
    visited = choose_nodes(s, refine=1, max_nodes=10**9)
    for k, n in enumerate(choose_nodes(s, refine=2, max_nodes=41)):
        np.testing.assert_array_equal(n, visited[k])
    truth = random_machine(TRAVEL, "XYFZ", seed=3)
    exact_fill(s, truth, seed=4)
    q = np.stack(np.meshgrid(*[np.linspace(*t, 5) for t in TRAVEL], indexing="ij"),
                 -1).reshape(-1, 3)
    e_true = volumetric_error(truth, q)

    def rms(r):
        d = remove_rigid_body(q, r.predict(q)[0] - e_true)
        return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))

    scale = float(np.sqrt(np.mean(np.sum(remove_rigid_body(q, e_true) ** 2, axis=1))))
    ls = rms(identify(s, IdentifyOptions(prior="none", suggest=False)))
    bayes = rms(identify(s, IdentifyOptions(suggest=False)))
    # bayes: 2.55 um. The bound was 0.2 * scale (1.41 um then; 1.46 with the smoother
    # rolls) when the rolls were always kept; this machine's roll of X (8.9 urad RMS) is
    # not seen by these readings (log Bayes factor -5.1) and the default's average over
    # the rolls' presence
    # (EstimatorSettings.roll_mixture_absent, issue 19's family without roll) takes the fit without
    # roll, at the cost of about 1 um here.
    assert ls < 2.0 * scale and bayes < 0.25 * scale, (scale, ls, bayes)
