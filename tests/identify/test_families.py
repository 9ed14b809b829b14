"""Round trips of the estimator on machines unlike volcal's own (issue 19, item 3).

The machines are drawn by the independent generators of ``benchmarks/families.py``
(physical descriptions, not ``volcal.measure.virtual``): family ``b`` (polynomial error
functions, no roll, straightness free at the ends, squareness as a linear term of the
straightness, scale errors of +-10 um/m) and family ``d`` (``b`` with rolls and a
ball-screw cyclic error of 0.5-2 um, period 5-20 mm, on each positioning error). The
first :data:`N_MACHINES` of the study's fixed sequence (chains and seeds drawn by
``families.cases``, not chosen) are simulated with the exact simulator (0.5 um noise,
20 urad mirror and beam misalignment; the seeds' full test set, 10 increments, 2
bidirectional runs per line to save time) and identified with the default estimator and
with minimum-norm least squares. Checks (issue 19's goals):

* the volumetric residual (rigid-body motion removed) is never above 1.02 times that of
  minimum-norm least squares on the same data;
* the 95 % intervals of the predicted volumetric error cover 90-99 % of the grid points
  and components, pooled, with each family's truth mapped into volcal's gauge
  (``families.gauge_map``).

A goal the estimator does not meet carries an ``xfail`` mark with the measured numbers.
Measured on these machines: ratio to least squares at most 0.23 (b) and 0.40 (d);
coverage 0.989 (b) and 0.945 (d; 0.880 before the short-wavelength part of the
positioning prior, docs/identification.md section 3; 0.925 before the nodes at the
readings and the smoother rolls).
Runtime: about 25 s of CPU (16 Bayesian and 8 minimum-norm identifications, and 8
Bayesian with the rolls kept).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from identify_helpers import load_benchmark

families = load_benchmark("families")

N_MACHINES = 4
STEPS, RUNS, GRID = 10, 2, 9
RATIO_MAX = 1.02
"""Issue 19: no machine above 1.02 times minimum-norm least squares."""

COVERAGE_XFAIL: dict[str, str] = {}
"""Families whose coverage goal is not met, with the measured numbers. Family d was here
(machines 0-3 covered 0.924, 0.941, 0.922, 0.734, pooled 0.880) until the positioning
prior got its short-wavelength (nugget) part: 0.876, 0.991, 0.997, 0.838, pooled 0.925."""


@functools.cache
def _results(family: str):
    return families.run_family(family, "full", N_MACHINES, STEPS, RUNS, GRID, limit=False)


def _mark(family: str):
    if family in COVERAGE_XFAIL:
        return pytest.param(family, marks=pytest.mark.xfail(
            reason=f"issue 19: {COVERAGE_XFAIL[family]}", strict=False))
    return family


def _study_only(family):
    """``family`` (a name or a ``pytest.param``) marked ``slow``: family ``b`` runs in ``make
    study`` only, ``make test`` keeps family ``d`` (``b`` with rolls and a cyclic error, the
    harder of the two) within its budget."""
    if isinstance(family, str):
        return pytest.param(family, marks=pytest.mark.slow)
    return pytest.param(*family.values, marks=[*family.marks, pytest.mark.slow])


@pytest.mark.parametrize("family", [_study_only("b"), "d"])
def test_never_above_least_squares(family):
    res = _results(family)
    ratios = {r.case.index: round(r.ratio_ls, 3) for r in res}
    assert all(r.ratio_ls <= RATIO_MAX for r in res), ratios
    # not vacuous: the estimate leaves far less than the machine's own error (least
    # squares does not always: machine 3 of family d, 7.2 um against 6.8 uncorrected)
    assert all(r.bayes["rms_um"] < 0.8 * r.truth_rms_um for r in res)
    assert np.median(list(ratios.values())) < 0.8


@pytest.mark.parametrize("family", [_study_only(_mark("b")), _mark("d")])
def test_95_percent_intervals_cover_90_to_99_percent(family):
    res = _results(family)
    cover = float(np.mean([r.bayes["coverage"] for r in res]))
    assert 0.90 <= cover <= 0.99, (cover, [round(r.bayes["coverage"], 3) for r in res])


def test_gauge_map_changes_no_reading():
    """A family machine and its image in volcal's gauge give the same noise-free readings
    (the exact simulator, second-order effects of ~10 nm aside), while their functions
    differ by up to tens of um or urad; the image holds the gauge's zeros."""
    from volcal.measure.simulate import SimulationOptions, simulate_session
    from volcal.plan.planner import plan_session

    travel = np.array(families.TRAVELS["full"])
    rng = np.random.default_rng(19)
    for name, chain in (("b", "XFYZ"), ("e", "FXYZ")):
        m = families.FAMILIES[name].draw(rng, travel, chain).tabulate()
        g = families.gauge_map(m)
        changed = max(np.abs(a - b).max() for a, b in zip(m.values, g.values, strict=True))
        assert changed > 1.0
        for k in range(3):
            assert np.abs(g.values[k][0]).max() < 1e-9
            assert np.abs(g.values[k][-1, [c for c in range(3) if c != k]]).max() < 1e-9
        sessions = []
        for machine in (m, g):
            s = plan_session(travel, chain, 6, families.TESTS, runs=1)
            simulate_session(s, machine, SimulationOptions(noise_um=0.0,
                                                           mirror_misalignment_urad=0.0,
                                                           seed=1))
            sessions.append(s)
        diff = max(np.abs(a.deviation - b.deviation).max()
                   for a, b in zip(*(s.measurements for s in sessions), strict=True))
        assert diff < 0.02, (name, diff)


@functools.cache
def _rolls_kept(family: str):
    """The same machines with the rolls always kept (the two-model average off); their
    minimum-norm least squares fits are :func:`_results`' (not drawn again)."""
    from volcal.identify import EstimatorSettings, IdentifyOptions

    kept = IdentifyOptions(suggest=False, settings=EstimatorSettings(roll_mixture_absent=0.0))
    return families.run_family(family, "full", N_MACHINES, STEPS, RUNS, GRID, limit=False,
                               options=kept, least_squares=False)


@pytest.mark.slow  # 16 identifications more: make study (make test's budget)
def test_the_average_over_the_rolls_presence_serves_machines_with_and_without_roll():
    """The default estimate averages the fits with and without rolls by the readings'
    Bayes factor (``EstimatorSettings.roll_mixture_absent``). On family b (no roll) it is closer to
    the truth on every machine than the fit with the rolls kept (measured 0.32-0.82 of
    its residual); on family d, whose rolls the readings see, it is the fit with rolls
    (the weight of "no roll" below 1e-8: the same numbers to 1e-6)."""
    checks = (("b", lambda a, k: a < 0.9 * k), ("d", lambda a, k: abs(a - k) <= 1e-6 * k))
    for family, check in checks:
        avg = [r.bayes["rms_um"] for r in _results(family)]
        kept = [r.bayes["rms_um"] for r in _rolls_kept(family)]
        assert all(check(a, k) for a, k in zip(avg, kept, strict=True)), (family, avg, kept)

