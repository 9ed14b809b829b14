"""The outlier check and the robust fit (issue 10, deliverable 6).

Clean sessions are simulated with the exact simulator on random machines of the study's
sequence (0.5 um noise, 20 urad mirror and beam misalignment, a thermal drift of 2 um/h,
bidirectional runs); on them the standardised residuals must be N(0, 1) in the tails the
check uses, so that the default threshold keeps its stated false-alarm rate (at most 1 % of
sessions; issue 10 asks <= 2 %). A 20 um fault on one reading must be flagged with its
measurement and CSV row, and the robust fit must down-weight it and recover the machine as
if the fault were not there.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.special import ndtr
from test_study_designs import study

from volcal.identify import IdentifyOptions, identify
from volcal.identify.api import default_outlier_threshold, standardised_residuals
from volcal.model.kinematics import volumetric_error
from volcal.model.rigid import remove_rigid_body
from volcal.standards.volumetric import work_zone_grid

N_CLEAN = 6
DRIFT_UM_PER_H = 2.0


def _session(case, design="abbe+diag", runs=2):
    return study.simulate(study.DESIGNS[design], case, 8, runs, DRIFT_UM_PER_H)


@functools.cache
def _clean():
    out = []
    for case in study.cases(N_CLEAN, master_seed=2026):
        s, truth = _session(case)
        r = identify(s, IdentifyOptions(suggest=False))
        out.append((s, truth, r, np.concatenate(list(standardised_residuals(r).values()))))
    return out


def test_standardised_residuals_are_unit_normal_in_the_tails():
    """Pooled over the clean sessions (~2600 readings), the fractions beyond 2 and 3 are
    those of N(0, 1) within their binomial spread (4 standard deviations): a leverage or a
    noise estimate off by 20 % would move the fraction beyond 3 by a factor 2-3."""
    z = np.concatenate([c[3] for c in _clean()])
    n = z.size
    assert n > 2000
    for t in (2.0, 3.0):
        p = 2 * ndtr(-t)
        got = np.mean(np.abs(z) > t)
        assert abs(got - p) < 4 * np.sqrt(p * (1 - p) / n) + 1.0 / n, (t, got, p)
    assert 0.9 < np.std(z) < 1.1


def test_clean_sessions_are_flagged_at_the_stated_rate():
    """The default threshold is the two-sided Bonferroni bound: on clean data with normal
    noise at most 1 % of sessions have a reading beyond it. Of these 6 sessions at most one
    may be flagged (two or more has a probability of 0.15 % at a 1 % rate, 2 % at a 5 %
    rate), and a flagged reading is a tail event of the noise, not a misfit: its |z| is
    within 1 of the threshold."""
    flagged = [c[2].outliers for c in _clean() if c[2].outliers]
    assert len(flagged) <= 1, flagged
    for c in _clean():
        thr = default_outlier_threshold(c[3].size)
        assert np.abs(c[3]).max() < thr + 1.0
    n = _clean()[0][3].size
    assert n * 2 * ndtr(-default_outlier_threshold(n)) == pytest.approx(min(
        0.01, n * 2 * ndtr(-4.0)), rel=1e-6)


def _rms_error(r, truth, s):
    q = work_zone_grid(s.travel, 5)
    e, _ = r.predict(q)
    return float(np.sqrt(np.mean(remove_rigid_body(q, e - volumetric_error(truth, q)) ** 2)))


def test_a_20_um_fault_is_flagged_and_the_robust_fit_ignores_it():
    s, truth, clean, _ = _clean()[0]
    m = s.get("linear-y2")
    m.deviation = m.deviation.copy()
    m.deviation[5] += 20.0  # a bumped reflector on one reading
    try:
        r = identify(s, IdentifyOptions(suggest=False))
        assert [(o["measurement"], o["row"]) for o in r.outliers] == [("linear-y2", 7)]
        rr = identify(s, IdentifyOptions(suggest=False, robust=True))
    finally:
        m.deviation[5] -= 20.0
    assert [(o["measurement"], o["row"]) for o in rr.outliers] == [("linear-y2", 7)]
    w = rr.outliers[0]["weight"]
    assert w < 0.01  # its noise taken as > 10 times the others'
    assert rr.fit["robust"]["downweighted"] == 1
    assert any("Robust fit: 1 reading(s) down-weighted" in t for t in rr.report.messages)
    # the residual of the faulty reading is kept (about the 20 um it was bumped by)
    assert rr.residuals["linear-y2"][5] == pytest.approx(20.0, abs=1.5)
    # the robust estimate is as good as the estimate from the clean data, the plain one
    # is pulled by the fault. The pull is measured from the clean data's estimate (0.90 um
    # against 0.007 for the robust fit): against the truth (2.13 / 2.14 um, 2.15 clean)
    # the estimator's own error, of the same size either way, hides it (the earlier
    # assertion e_plain > e_rob held by 0.02 um and flipped when the default came to
    # average the fits with and without rolls, whose weight the fault moved)
    e_clean, e_plain, e_rob = (_rms_error(x, truth, s) for x in (clean, r, rr))
    assert e_rob < 1.15 * e_clean + 0.02, (e_clean, e_plain, e_rob)
    q = work_zone_grid(s.travel, 5)
    pull, pull_rob = (float(np.sqrt(np.mean(remove_rigid_body(
        q, x.predict(q)[0] - clean.predict(q)[0]) ** 2))) for x in (r, rr))
    assert pull > 0.3 and pull_rob < 0.05 * pull, (pull, pull_rob)


def test_robust_fit_of_clean_data_changes_nothing():
    s, _, clean, _ = _clean()[1]
    r = identify(s, IdentifyOptions(suggest=False, robust=True))
    assert not r.outliers and "robust" not in r.fit
    q = work_zone_grid(s.travel, 5)
    np.testing.assert_allclose(r.predict(q)[0], clean.predict(q)[0], atol=1e-9)


def test_a_fault_on_a_diagonal_is_flagged_there_and_only_there_when_robust():
    """A 20 um fault on a diagonal reading: the plain fit leans towards it and may flag
    its neighbours too (the smooth functions follow the fault a little); the robust fit
    flags the faulty reading alone."""
    s, _, _, _ = _clean()[2]
    m = next(x for x in s.measurements if x.kind == "diagonal")
    m.deviation = m.deviation.copy()
    m.deviation[3] -= 20.0
    try:
        r = identify(s, IdentifyOptions(suggest=False))
        rr = identify(s, IdentifyOptions(suggest=False, robust=True))
    finally:
        m.deviation[3] += 20.0
    worst = min(r.outliers, key=lambda o: o["standardised"])
    assert (worst["measurement"], worst["row"]) == (m.id, 5)
    assert [(o["measurement"], o["row"]) for o in rr.outliers] == [(m.id, 5)]
    assert rr.residuals[m.id][3] == pytest.approx(-20.0, abs=1.5)
