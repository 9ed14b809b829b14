"""The estimator on long machines (issue 30): what the prior assumes scales with the travel.

* ``benchmarks/exact_sim.py`` is a simulator written apart from volcal's (its own
  kinematics with :class:`scipy.spatial.transform.Rotation`, its own reading models): its
  readings must agree with volcal's exact simulator on the same machine, or the study of
  ``benchmarks/travel_study.py`` would measure a disagreement between two simulators;
* the positioning trend is a scale error per metre of travel (one evidence-chosen scale
  in um/m, each axis' trend at the end of its travel that scale times its length);
* each axis' curvature factor (``EstimatorSettings.axis_kappa_spread``) has the exact
  evidence gradient; as one exponent of the travels (``kappa_travel_exponent_spread``)
  it tells errors kept per millimetre from errors kept relative to the travel;
* a round trip on a 3000 x 800 x 600 mm machine of the study's family whose functions keep
  their shape relative to the travel (machine 0 of ``travel_study.cases``, read by
  ``exact_sim``, seeds' full test set, 10 increments, 2 runs per line): never worse than
  minimum-norm least squares, its 95 % intervals covering 90-99 % of the grid;
* step diagonals alone on a machine without roll (family ``rel0``, 800 mm): 90-99 %
  coverage, where the estimator before issue 30 covered 0.71;
* the unseen roll of a long axis keeps at least its group's prior scale (the angular
  travel exponent bounded below at 0).

Runtime: about 7 s of CPU (one Bayesian and one minimum-norm identification of the long
machine, one of step diagonals alone, the rest small).
"""

from __future__ import annotations

import numpy as np
import pytest
from identify_helpers import TRAVEL, exact_fill, load_benchmark, seeds_session

from volcal.identify.design import build_design, choose_nodes
from volcal.identify.prior import TREND_FUNCTIONS, PriorStructure
from volcal.identify.settings import EstimatorSettings
from volcal.measure.readings import SetupErrors, reading_exact
from volcal.measure.virtual import random_machine

exact_sim = load_benchmark("exact_sim")
travel_study = load_benchmark("travel_study")

LONG = np.array([[0.0, 3000.0], [0.0, 800.0], [0.0, 600.0]])


@pytest.mark.parametrize("chain", ["XYFZ", "FXYZ", "YFXZ"])
def test_independent_simulator_agrees_with_volcals_exact_readings(chain):
    """Flat mirror (step diagonals, with mirror and beam tilts), retroreflector (body
    diagonals, Abbe lines): the two simulators' readings of one tabulated machine agree to
    1e-6 um (volcal interpolates its table linearly; the analytic functions here are the
    table's own interpolant)."""
    m = random_machine(LONG, chain, seed=11)
    fs = {6 * k + c: (lambda x, k=k, c=c: m.component(k, x)[:, c])
          for k in range(3) for c in range(6)}
    sim = exact_sim.SimMachine(chain, LONG, fs, m.squareness.copy())
    s = travel_study.session_for(LONG, chain, "full", steps=6, runs=1)
    rng = np.random.default_rng(3)
    targets = set()
    for meas in s.measurements:
        mt = rng.normal(size=3) * 20.0
        bt = rng.normal(size=3) * 20.0
        mt -= (mt @ meas.beam_direction) * meas.beam_direction
        bt -= (bt @ meas.beam_direction) * meas.beam_direction
        if meas.target != "flat_mirror":
            mt = np.zeros(3)
        got = exact_sim.readings(sim, meas.positions, meas.beam_direction, meas.target,
                                 meas.tool_offset, mt, bt)
        want = reading_exact(m, meas, SetupErrors(mt, bt))
        np.testing.assert_allclose(got, want, atol=1e-6)
        targets.add(meas.target)
        assert np.ptp(want) > 1.0  # the machine is seen
    assert targets == {"flat_mirror", "retroreflector"}


def test_trend_is_a_scale_error_per_metre_of_travel():
    """With ``trend_per_metre`` (default) each axis' trend at the end of its travel is the
    scale [um/m] times its travel [m]: on 3000 / 800 / 600 mm the X trend is 3.75 and 5
    times those of Y and Z; without it (volcal <= issue 29) one trend for every axis."""
    s = travel_study.session_for(LONG, "FXYZ", "full", steps=4, runs=1)
    for m in s.measurements:
        m.deviation = np.zeros(m.n)
    design = build_design(s, choose_nodes(s, refine=1, max_nodes=41), {})
    fs = np.full(18, 2.0)
    for per_metre, want in ((True, (30.0, 8.0, 6.0)), (False, (10.0, 10.0, 10.0))):
        p0 = PriorStructure.build(design.layout, design.free, 6.0,
                                  settings=EstimatorSettings(trend_per_metre=per_metre,
                                                             nugget=False))
        p = p0.with_trend(10.0)
        for f, w in zip(TREND_FUNCTIONS, want, strict=True):
            b = next(i for i, blk in enumerate(p.blocks) if blk[4] == f)
            added = (np.linalg.inv(p.block_precision(b, fs))
                     - np.linalg.inv(p0.block_precision(b, fs)))
            s_b = p.coords[b]
            np.testing.assert_allclose(added, w**2 * np.outer(s_b, s_b), rtol=1e-6,
                                       atol=1e-6 * w**2)
            assert p.block_trend(b) == pytest.approx(w)


def test_travel_columns_scale_each_axis_by_its_travel_around_the_mean():
    """The travel exponents' columns: ``log(L_k / L_mean)`` for the functions of the groups
    of each set, ``L_mean`` the geometric mean over the axes with functions (so the
    group's geometric-mean scale is unmoved); an axis without functions gets 0. 3000 / 800
    / 600 mm: X +0.98, Y -0.34, Z -0.63 (X: ``log 3 - mean(log 3, log 0.8, log 0.6)``)."""
    from dataclasses import replace

    from volcal.identify.prior import function_group

    s = travel_study.session_for(LONG, "FXYZ", "full", steps=4, runs=1)
    for m in s.measurements:
        m.deviation = np.zeros(m.n)
    design = build_design(s, choose_nodes(s, refine=1, max_nodes=41), {})
    p = PriorStructure.build(design.layout, design.free, 6.0)
    np.testing.assert_allclose(p.axis_length, (3.0, 0.8, 0.6))
    cols = p.travel_columns(((0, 1), (2, 3)))
    logl = np.log([3.0, 0.8, 0.6])
    for k in range(3):
        for c in range(6):
            lin = function_group(k, c) in (0, 1)
            want = logl[k] - logl.mean()
            assert cols[6 * k + c, 0] == pytest.approx(want if lin else 0.0)
            assert cols[6 * k + c, 1] == pytest.approx(0.0 if lin else want)
    assert cols[0, 0] == pytest.approx(0.977, abs=0.001)
    # X and Y only (no Z functions): the mean over X and Y, Z's rows zero
    xy = replace(p, blocks=[b for b in p.blocks if b[4] // 6 != 2])
    cols = xy.travel_columns(((0, 1, 2, 3),))
    np.testing.assert_allclose(cols[12:, 0], 0.0)
    assert cols[0, 0] == pytest.approx(-cols[6, 0]) and cols[0, 0] == pytest.approx(
        0.5 * np.log(3.0 / 0.8))


def test_evidence_gradient_in_each_axis_curvature_factor():
    """The gradient entries of the three axes' curvature factors
    (``evidence.AXIS_KAPPA`` ...) against central differences, with the trend and the
    nugget in the prior; the sum over the axes is the gradient in ``log kappa``."""
    from volcal.identify.evidence import AXIS_KAPPA, _Evidence

    s = seeds_session("XYFZ", steps=4)
    exact_fill(s, random_machine(TRAVEL, "XYFZ", seed=3), seed=4)
    design = build_design(s, choose_nodes(s, refine=1, max_nodes=41), {})
    prior = PriorStructure.build(design.layout, design.free, 6.0)
    ev = _Evidence(design, prior.with_trend(12.0).with_nugget(0.5), 100.0)
    fs = np.random.default_rng(5).uniform(3.0, 20.0, 18)
    a0 = np.log([1.3, 0.8, 1.1])

    def f(a):
        ev.prior = ev.prior.with_axis_kappa(np.exp(a))
        return ev.neg2(fs, 0.4, 7.0)

    f(a0)
    _, grad = ev.neg2_grad_functions(fs, 0.4, 7.0)
    h = 1e-5
    fd = np.array([(f(a0 + h * e) - f(a0 - h * e)) / (2 * h) for e in np.eye(3)])
    got = grad[AXIS_KAPPA:AXIS_KAPPA + 3]
    np.testing.assert_allclose(got, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
    assert np.all(np.abs(got) > 1e-3)
    assert got.sum() == pytest.approx(grad[18], rel=1e-10)


def test_long_machine_round_trip_beats_least_squares_and_covers():
    """Machine 0 of the study's family ``rel`` (Fourier series keeping their shape
    relative to the travel, rolls) on 3000 x 800 x 600 mm, read by the independent
    simulator: the default estimator's volumetric residual is at most that of minimum-norm
    least squares and its 95 % intervals cover 90-99.5 % of the grid (pooled components).
    Measured: ratio 0.41, coverage 0.994 (before the travel exponents 0.34, 0.987; main
    before issue 30: 0.35, 0.977).

    The upper bound was 0.99, the issue's band for a family's pooled coverage; one machine
    is not a family: over the 20 machines of ``rel`` on 3000 mm the pooled coverage is 0.990
    with the travel exponents as without them (benchmarks/README.md), its machines ranging
    0.959-0.997, this one at 0.997 with 5 runs per line. 0.995 still fails a machine whose
    bands are twice too wide (0.9999)."""
    case = travel_study.cases(1)[0]
    r = travel_study.run_case(travel_study.FAMILIES["rel"], "t3000", "full", case, None,
                              runs=2, n_grid=7)
    ratio = r.bayes["rms_um"] / r.min_norm["rms_um"]
    assert ratio <= 1.0, (r.bayes["rms_um"], r.min_norm["rms_um"])
    assert 0.90 <= r.bayes["coverage"] <= 0.995, r.bayes["coverage"]


def test_a_long_machine_without_roll_is_not_covered_twice_over():
    """Machine 0 of the study's family ``rel0`` (no roll) on 3000 x 800 x 600 mm, the
    seeds' full set, read by the independent simulator (2 runs per line, 7 x 7 x 7 grid).
    Its readings favour "no roll" decisively (log Bayes factor about -14), and the 95 %
    intervals must cover 90-99 % of the grid: measured 0.983. With the rolls' prior kept
    in the uncertainty (``roll_mixture_covariance = "roll"``, the default before session
    16) they covered 0.994, every value but the grid's exact gauge values (``u = 0``,
    counted as misses by ``families.evaluate``): the X roll's standard uncertainty 18 urad
    for a roll of 0 (benchmarks/README.md, travel study "session 16")."""
    from volcal.identify import IdentifyOptions
    from volcal.identify.settings import EstimatorSettings

    case = travel_study.cases(1)[0]
    fam = travel_study.FAMILIES["rel0"]
    r = travel_study.run_case(fam, "t3000", "full", case, None, runs=2, n_grid=7,
                              min_norm=False)
    assert 0.90 <= r.bayes["coverage"] <= 0.99, r.bayes["coverage"]
    kept = travel_study.run_case(fam, "t3000", "full", case, None, runs=2, n_grid=7,
                                 min_norm=False, options=IdentifyOptions(
                                     suggest=False, settings=EstimatorSettings(
                                         roll_mixture_covariance="roll")))
    assert kept.bayes["coverage"] > 0.993, kept.bayes  # what this guards against
    assert kept.bayes["rms_um"] == pytest.approx(r.bayes["rms_um"], rel=1e-9)


def test_long_machine_whose_straightness_grows_with_its_travel():
    """Machine 6 of the study's family ``len`` (Fourier series keeping their shape relative
    to the travel, linear errors growing with it: the 3 m X's straightness and positioning
    wiggles 3.75 times the 0.8 m Y's, the angles alike) on 3000 x 800 x 600 mm, read by the
    independent simulator. With one amplitude per group for the three axes the estimator
    stayed at 1.7-2.1 times the limit on this family (benchmarks/README.md, "travel
    exponents"); the evidence's travel exponents find the growth and the residual falls.
    Measured (2 runs per line): 5.78 um against 8.28 um without the exponents, least
    squares 13.16 um, coverage 0.991 (0.922 without). The upper bound is 0.995, as for the
    family ``rel`` above, since session 14: the variance between the readings
    (:mod:`volcal.identify.between`) took this smooth machine from 339 to 340 of the 343
    grid points (0.988 -> 0.991); the smooth families cover 0.99 pooled with the prior's
    interpolation alone (benchmarks/README.md, lab notebook ``between_readings_factor``)."""
    from dataclasses import replace

    from volcal.identify import IdentifyOptions
    from volcal.identify.settings import EstimatorSettings

    case = travel_study.cases(7)[6]
    fam = travel_study.FAMILIES["len"]
    r = travel_study.run_case(fam, "t3000", "full", case, None, runs=2, n_grid=7)
    o = IdentifyOptions(suggest=False)
    r0 = travel_study.run_case(fam, "t3000", "full", case, None, runs=2, n_grid=7,
                               min_norm=False, options=replace(o, settings=EstimatorSettings(
                                   travel_exponent_spread=0.0)))
    assert r.bayes["rms_um"] < 0.8 * r0.bayes["rms_um"], (r.bayes, r0.bayes)
    assert r.bayes["rms_um"] < 0.5 * r.min_norm["rms_um"], (r.bayes, r.min_norm)
    assert 0.90 <= r.bayes["coverage"] <= 0.995, r.bayes["coverage"]


@pytest.mark.parametrize(("family", "low", "high"), [("mm0", 1.0, 2.5), ("rel0", -0.6, 0.3)])
def test_curvature_travel_exponent_tells_errors_per_mm_from_errors_per_travel(family, low,
                                                                              high):
    """Machine 0 of ``mm0`` (errors keeping their shape per millimetre: the 3 m X undulates
    3.75 times more over its travel than the 0.8 m Y) and of ``rel0`` (the same number of
    undulations on every axis), 3000 x 800 x 600 mm, read by the independent simulator:
    the evidence's curvature exponent ``gamma`` (``EstimatorSettings.
    kappa_travel_exponent_spread``) is large for the first (measured 1.52; 2 would be the
    curvature of a per-mm function over the normalised travel) and near 0 for the second
    (measured -0.23), and each axis' curvature factor is ``(L_k / L_mean)^gamma``."""
    from volcal.identify import IdentifyOptions, identify

    case = travel_study.cases(1)[0]
    am = travel_study.FAMILIES[family].draw(np.random.default_rng(case.machine_seed), LONG,
                                            case.chain)
    s = travel_study.session_for(LONG, case.chain, "full", 10, 2)
    exact_sim.simulate(s, travel_study.to_sim(am), case.sim_seed)
    ps = identify(s, IdentifyOptions(suggest=False)).fit["prior_scales"]
    gamma = ps["kappa_travel_exponent"]
    assert low < gamma < high, gamma
    lengths = LONG[:, 1] - LONG[:, 0]
    want = (lengths / np.exp(np.mean(np.log(lengths)))) ** gamma
    np.testing.assert_allclose(ps["kappa_axis"], want, rtol=1e-9)


def test_the_unseen_roll_of_a_long_axis_does_not_shrink_with_its_tilts():
    """Machine 18 of ``families.py``'s family f (polynomials with rolls and a thermal scale
    error, FXYZ) on the long design (3000 x 800 x 600 mm, the seeds' full set): its long
    X's tilts are smaller than the short axes', and with the angular travel exponent free
    to go negative (-0.96) the X roll, which the readings hardly see, got 0.39 times the
    group's prior scale and the 95 % intervals covered 0.58 of the grid (its roll off by
    17 urad with a standard uncertainty of 5). Bounded below at 0
    (``EstimatorSettings.travel_exponent_bounds``): measured 0.885."""
    from dataclasses import replace

    from volcal.identify import IdentifyOptions

    families = load_benchmark("families")
    case = families.cases(19)[18]
    fam = families.FAMILIES["f"]
    r = families.run_case(fam, "long", case, None, least_squares=False)
    assert r.bayes["coverage"] >= 0.85, r.bayes
    o = IdentifyOptions(suggest=False)
    r0 = families.run_case(fam, "long", case, None, least_squares=False, options=replace(
        o, settings=EstimatorSettings(travel_exponent_bounds=(-1.0, 2.0))))
    assert r0.bayes["coverage"] < 0.7, r0.bayes  # the failure this guards against


def test_step_diagonals_alone_are_honest_on_a_machine_without_roll():
    """Step diagonals alone (the four of the seeds' set, 10 increments), machine 5 of the
    family ``rel0`` (Fourier series, no roll) on 800 x 600 x 500 mm: its tilts (10-15 urad
    RMS) are what step diagonals hardly see, and the 95 % intervals must still cover 90-99 %
    of the grid. Measured 0.914; the estimator before issue 30 let the tilts' scale fall to
    1.2 urad and covered 0.707 (benchmarks/README.md, the lab notebook's ``hyper_spread``
    and ``tilt_trend_centre_urad``)."""
    case = travel_study.cases(6)[5]
    r = travel_study.run_case(travel_study.FAMILIES["rel0"], "t800", "step", case, None,
                              min_norm=False)
    assert 0.90 <= r.bayes["coverage"] <= 0.99, r.bayes["coverage"]
    assert r.bayes["rms_um"] < r.truth_rms_um  # and it is a correction


def test_long_machines_of_the_family_with_the_issues_short_machine_figures():
    """Machines 0-2 of the study's family ``fine`` (16 modes keeping their shape relative to
    the travel, rolls present: on 800 mm 0.55x least squares and 1.11x the limit, the
    figures of the issue's independent generator) on 6000 x 1000 x 800 mm, the seeds' full
    set, read by the independent simulator. The issue's long machines were at 1.02x least
    squares; here each of the three stays well below (measured with 2 runs per line: 0.46,
    0.53, 0.58; the 20 machines with 5 runs: median 0.51, the worst 0.88), and the three
    cover 0.92-0.97 of the grid (mean 0.943; 0.909 before the variance between the
    readings of session 14, ``test_between_readings.py``; the 20 machines pooled 0.920
    before it, benchmarks/README.md "fine"). The lower bound 0.87 is the family's pooled
    band's edge (0.90) less what three machines scatter around it (0.03: their mean ranged
    0.88-0.97 over the 20 machines' consecutive triples with 5 runs)."""
    ratios, cover = [], []
    for case in travel_study.cases(3):
        r = travel_study.run_case(travel_study.FAMILIES["fine"], "t6000", "full", case, None,
                                  runs=2, n_grid=7)
        ratios.append(r.bayes["rms_um"] / r.min_norm["rms_um"])
        cover.append(r.bayes["coverage"])
    assert max(ratios) <= 0.7, ratios
    assert 0.87 <= float(np.mean(cover)) <= 0.99, cover
