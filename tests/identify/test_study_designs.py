"""Issue 10's acceptance checks per test design, on random machines (benchmarks/study.py).

The machines are the first :data:`N_MACHINES` of the study's fixed sequence
(``study.cases``: chains and seeds drawn by a fixed generator, not chosen), simulated with
the exact simulator (0.5 um noise, 20 urad mirror and beam misalignment) at the study's
plan with 10 increments per test but 2 bidirectional runs per line instead of 5 (to save
time; the figures of machines 0-7 are within a few per cent of the 5-run study's). Each
design is identified with the default estimator and with minimum-norm least squares; the
checks are issue 10's:

* the volumetric residual is never worse than minimum-norm least squares on the same data;
* the 95 % intervals of the predicted volumetric error cover 90-99 % of the grid points and
  components, pooled over the machines;
* the roll (EAX, EBY, ECZ) is recovered where the estimate claims it well, and its 95 %
  intervals cover the truth (pooled).

A check the estimator does not meet would carry an ``xfail`` mark with the measured
numbers (:data:`RATIO_XFAIL`...; none at present). Runtime: about 40 s on an idle 2-core box
(80 Bayesian and 80 minimum-norm identifications), 170 s of ``make test``'s time on a loaded
one: the three checks are marked ``slow`` and run in ``make study`` (``pytest -m slow``).
``make test`` keeps the per-machine check that is not a pooled statistic, on the step
diagonals alone (the design it once failed) and the first two machines:
:func:`test_step_diagonals_never_worse_than_minimum_norm_on_two_machines`.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from identify_helpers import load_benchmark

from volcal.identify import IdentifyOptions, identify

study = load_benchmark("study")

N_MACHINES = 8
STEPS, RUNS, GRID = 10, 2, 9

RATIO_SLACK = 1.01
"""Allowed ratio of the residuals (default / minimum norm).

The residuals compared are those of what the design sees (``rms_seen_um``): a squareness
error no reading of the design sees (Abbe lines only: all three, up to 40 urad, ~30 um
over the travel) is held at zero by both estimators and is taken out of the truth. Left
in, it dominated the residual and decided the comparison by chance: on machine 7 (abbe)
the default estimate was better on every function the lines determine (EXX error 0.15 um
against 4.68 um for minimum norm, EBX 0.67 against 14.3 urad) and 5.5 um against 7.1 um
without the squareness, yet 10.1 against 9.7 um with it, because the minimum-norm errors
happened to offset part of the unseen squareness. One per cent is far below the 1.05-2.5x
failures this check exists to catch.
"""


@functools.cache
def _results(design: str):
    return study.run_design(design, N_MACHINES, STEPS, RUNS, GRID)


def _xfail(reason: str):
    return pytest.mark.xfail(reason=f"issue 10: {reason}", strict=False)


def _params(marks: dict[str, str]):
    return [pytest.param(d, marks=_xfail(marks[d])) if d in marks else d
            for d in study.DESIGNS]


RATIO_XFAIL: dict[str, str] = {
    "step": "issue 30: machines 4 and 5 at 1.07 / 1.18 x minimum norm (0.97 / 0.95 before "
            "433c263; benchmarks/README.md, lab notebook kappa_travel_exponent_spread)",
}
"""Ratio checks not met. Step diagonals alone were 1.34x (median, up to 2.54x) worse than
minimum-norm least squares until the set-up tilts got a prior of their own (scale chosen
by the evidence), the beam alignment to the actual motion was modelled and the positioning
errors got a linear trend of their own (volcal.identify.solver): 0.83 (median, max
1.004, inside the 1 % slack) on machines 0-7; 0.78 (max 0.96) since the prior's difference
form at the gauge zeros (issue 19, volcal.identify.prior.BOUNDARY).

Not met again since issue 30's round 1 (433c263: the scales' hyperprior a factor 3, the
trend per metre, the tilts' linear part, each axis' curvature factor): machines 4 and 5
at 1.12 / 1.29 x, found in session 11; 1.07 / 1.18 x since the curvature factors are one
exponent of the travels and the angular travel exponent is bounded below at 0 (session
12). On 20 machines the median is unchanged (0.82 -> 0.80) and the coverage better
(0.960 -> 0.962, the worst machine 0.77 -> 0.78); machine
5's estimate trades the squareness EB0Z (-48 urad for -26) against EBX and EXX, with
one optimum of the evidence (six starts). Each of round 1's settings set back alone
leaves it above 1.01 (the lab notebook)."""
COVERAGE_XFAIL: dict[str, str] = {}
"""Coverage checks not met. Step diagonals alone covered 0.875 pooled (0.50 on machine 6:
the positioning slope / mirror tilt confound was not in the uncertainty); now 0.95."""
ROLL_XFAIL: dict[str, str] = {
    "long": "the rolls' pooled coverage 0.897 (bound 0.90): ECZ of machines 0, 1, 3, 5, 7 "
            "covers 0.38-0.86; a bias of the prior, not of the noise part "
            "(benchmarks/README.md, lab notebook, ECZ on the long machine)",
}
"""Roll checks not met. None from the time they judged a roll by its reported uncertainty
until the long machine's pooled roll coverage fell to 0.889-0.897 (issue 30's travel
exponents, session 11; found in session 14, when ``make study`` was run in full). The
misses are ECZ, the short Z's roll on the 3000 x 800 x 600 mm machine, which only the step
diagonals see (without them its posterior is its prior). Ten noise draws of machine 3: the
estimate's spread 1.7-3.7 urad is within the reported 3.9-5.0 (the noise part is honest);
its mean is off by 4-6.5 urad over the first half of the travel in every draw, and with
0.01 um of noise it is recovered to 0.2-0.6 urad (the model is right). Machine 3's ECZ is
19 urad RMS against the rolls' prior scale of 8-9 urad (the tilts' times ``roll_factor``);
a larger ``roll_factor`` or rolls as rough as the tilts fix machines 1, 3 and 5 and not 0
and 7 (session 14), and cost accuracy on the families (lab notebook, ``roll_factor``)."""


def test_step_diagonals_never_worse_than_minimum_norm_on_two_machines():
    """The first check of :func:`test_never_worse_than_minimum_norm_least_squares` (a
    per-machine bound, the same slack) on the study's first two machines, step diagonals
    alone: the smaller check that stays in ``make test``."""
    res = study.run_design("step", 2, STEPS, RUNS, GRID)
    ratios = {r.case.index: round(r.ratio, 3) for r in res}
    assert all(r.bayes["rms_seen_um"] <= RATIO_SLACK * r.min_norm["rms_seen_um"]
               for r in res), ratios
    assert all(r.min_norm["rms_um"] < r.truth_rms_um for r in res)


@pytest.mark.slow
@pytest.mark.parametrize("design", _params(RATIO_XFAIL))
def test_never_worse_than_minimum_norm_least_squares(design):
    res = _results(design)
    ratios = {r.case.index: round(r.ratio, 3) for r in res}
    assert all(r.bayes["rms_seen_um"] <= RATIO_SLACK * r.min_norm["rms_seen_um"]
               for r in res), ratios
    # the comparison is not vacuous: the truth is far from what either estimate leaves
    assert all(r.min_norm["rms_um"] < r.truth_rms_um for r in res)


@pytest.mark.slow
@pytest.mark.parametrize("design", _params(COVERAGE_XFAIL))
def test_95_percent_intervals_cover_90_to_99_percent(design):
    res = _results(design)
    cover = float(np.mean([r.bayes["coverage"] for r in res]))
    per_machine = [round(r.bayes["coverage"], 2) for r in res]
    assert 0.90 <= cover <= 0.99, (cover, per_machine)


@pytest.mark.slow
@pytest.mark.parametrize("design", _params(ROLL_XFAIL))
def test_roll_recovered_where_identifiable(design):
    """Where the estimate claims a roll well (posterior RMS standard deviation at most a
    quarter of the roll's true RMS), its RMS error is at most half its true RMS plus
    2 urad (0.5 um of noise over a lever arm of 250 mm); everywhere, its 95 % intervals
    cover the truth at >= 90 % of the positions, pooled.

    The report's determined fraction is not the criterion: it is the noise-free share of
    the prior uncertainty the design removes (ECZ of machine 0, full set: 0.97), while
    with 0.5 um of noise the same roll keeps a posterior standard deviation of 6 urad
    (measured: error 3.9 urad, true RMS 4.9); a roll that is identifiable in principle
    but poorly measured must be judged by its uncertainty. With these designs a roll is
    rarely claimed that well (2 of the 120 machine-roll pairs, both on the long machine):
    what this mostly checks is that the uncertainty of the rolls is honest (coverage).
    Rolls measured well are tested with multilateration
    (tests/identify/test_multilateration_roundtrip.py)."""
    res = _results(design)
    bad, cover = [], []
    for r in res:
        for name, f in r.bayes["roll"].items():
            cover.append(f["coverage"])
            if f["rms_sd_urad"] <= 0.25 * f["rms_true_urad"] and (
                    f["rms_err_urad"] > 0.5 * f["rms_true_urad"] + 2.0):
                bad.append((r.case.index, name, round(f["rms_err_urad"], 1),
                            round(f["rms_true_urad"], 1), round(f["rms_sd_urad"], 1)))
    assert not bad, bad
    assert np.mean(cover) >= 0.90, np.mean(cover)
    if design == "abbe":
        # linear lines cannot see a roll: the report must not claim it
        assert all(f["determined"] < 0.5 for r in res for f in r.bayes["roll"].values())


def test_roll_zero_holds_exactly_the_three_rolls():
    """``roll='zero'`` holds EAX, EBY, ECZ (each axis about its own direction) at exactly
    zero with no uncertainty, and estimates the tilts EAY, EAZ (issue 10)."""
    case = study.cases(1)[0]
    session, _ = study.simulate(study.DESIGNS["full"], case, steps=6, runs=2)
    r = identify(session, IdentifyOptions(roll="zero", suggest=False))
    for k, name in enumerate(("EAX", "EBY", "ECZ")):
        pos = np.linspace(*session.travel[k], 13)
        assert np.all(r.errors.function(name, pos) == 0.0), name
        assert np.all(r.function_std(name, pos) == 0.0), name
    # the tilts of Y and Z are estimated, not held
    for k, name in ((1, "EAY"), (2, "EAZ")):
        pos = np.linspace(*session.travel[k], 13)
        assert np.abs(r.function_std(name, pos)).max() > 0, name
