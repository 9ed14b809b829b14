"""The change test on a design of few increments and runs (issue 26, finding 1).

Before the fix, unchanged pairs at 6 increments and 2 runs were flagged in 6 of 20 (seeds
500-519 of ``random_machine``): the chi-square was taken with ``C - CQC`` over every
direction, including the prior's shrinkage, which moves with the hyperparameters each
calibration chooses.
"""

from __future__ import annotations

import hashlib
import pickle

import numpy as np
import pytest
from scipy.stats import binom

from volcal.history.compare import _determined_statistic, compare_models

TRAVEL = [[0, 800], [0, 600], [0, 500]]
LEVEL = 0.05


_FITS: dict = {}
"""The identifications of this module by machine, seed and design: pair 3's first
calibration (machine 503, seed 37) is both tests' (compare_models only reads them)."""


def _model(machine, seed: int, steps: int = 6, runs: int = 2):
    from volcal.flow import Calibration

    key = (hashlib.sha256(pickle.dumps(machine)).hexdigest(), seed, steps, runs)
    if key not in _FITS:
        c = Calibration.plan(TRAVEL, steps=steps, runs=runs)
        c.simulate(machine=machine, seed=seed)
        _FITS[key] = c.identify()
    return _FITS[key]


def test_determined_statistic_by_hand():
    """Only the combinations the readings determine (fraction >= 0.5) are tested."""
    C = np.diag([4.0, 1.0])           # posterior variances
    Cn = np.diag([4.0, 0.1])          # the readings' part: 100 % and 10 %
    dof, stat = _determined_statistic(np.array([3.0, 40.0]), C, Cn)
    assert dof == 1 and stat == pytest.approx(9.0 / 4.0)
    dof, stat = _determined_statistic(np.array([3.0, 4.0]), C, None)
    assert dof == 2 and stat == pytest.approx(9.0 / 4.0 + 16.0)


def _unchanged_pairs_flagged(pairs) -> int:
    """Of the unchanged pairs ``pairs`` (machine seed ``500 + k``, readings' seeds ``10 k + 7``
    and ``10 k + 8``), how many have any function flagged at the 5 % family-wise level."""
    from volcal.measure.virtual import random_machine

    flagged = 0
    for k in pairs:
        m = random_machine(TRAVEL, "XYFZ", seed=500 + k)
        entries = compare_models(_model(m, 10 * k + 7), _model(m, 10 * k + 8), LEVEL)
        assert len(entries) == 21
        flagged += any(e.changed for e in entries)
    return flagged


def test_unchanged_pairs_flagged_before_the_fix_are_not():
    """The three unchanged pairs at 6 increments, 2 runs that were flagged before the fix
    (pairs 3, 6 and 9): at most binom.ppf(0.95, 3, 0.05) = 1 flagged (these seeds: 0). The
    ten pairs' rate is :func:`test_unchanged_pairs_few_increments_within_band` (make study)."""
    limit = int(binom.ppf(0.95, 3, LEVEL))
    assert limit == 1
    assert _unchanged_pairs_flagged((3, 6, 9)) <= limit


@pytest.mark.slow  # 20 identifications: make study; make test keeps the three pairs above
def test_unchanged_pairs_few_increments_within_band():
    """10 unchanged pairs at 6 increments, 2 runs: at most binom.ppf(0.95, 10, 0.05) = 2
    pair with any function flagged at the 5 % family-wise level (these seeds: 0; before
    the fix 3, pairs 3, 6 and 9)."""
    n = 10
    limit = int(binom.ppf(0.95, n, LEVEL))
    assert limit == 2
    assert _unchanged_pairs_flagged(range(n)) <= limit


def test_scale_change_detected_few_increments():
    """X scale +10 um/m (8 um over 800 mm) at 6 increments, 2 runs: EXX flagged, alone."""
    from volcal.measure.virtual import random_machine

    m = random_machine(TRAVEL, "XYFZ", seed=503)
    m2 = m.copy()
    m2.values[0][:, 0] += 0.010 * m2.nodes[0]
    entries = {e.name: e for e in compare_models(_model(m, 37), _model(m2, 38), LEVEL)}
    assert [n for n, e in entries.items() if e.changed] == ["EXX"]
    assert entries["EXX"].difference == pytest.approx(8.0, abs=entries["EXX"].U)


def test_cli_says_joint_test_decided(tmp_path, monkeypatch):
    """An entry flagged with |difference| <= U says that the joint test decided it; one
    with |difference| > U does not need to."""
    from typer.testing import CliRunner

    import volcal.history.compare as cm
    from volcal.cli import app
    from volcal.history.api import History

    db = str(tmp_path / "h.sqlite")
    History(db).close()
    entries = [cm.Entry("EXX", -0.53, 0.61, True, "um", "chi-square", 49.7, 42.3, 19),
               cm.Entry("EYY", 3.0, 0.61, True, "um", "chi-square", 49.7, 42.3, 19)]
    monkeypatch.setattr(cm, "compare", lambda *a, **k: entries)
    monkeypatch.setattr(cm, "pair_notes", lambda *a, **k: [])  # no records C1, C2 here
    res = CliRunner().invoke(app, ["history", "compare", "C1", "C2", "--db", db])
    assert res.exit_code == 0, res.output
    lines = {ln.split("\t")[0]: ln for ln in res.output.splitlines()}
    assert lines["EXX"].endswith("chi-square chi2 49.7 > 42.3 (decided by the joint test "
                                 "over 19 determined combinations; |difference| <= U at "
                                 "the node shown)")
    assert lines["EYY"].endswith("chi-square chi2 49.7 > 42.3")


def test_compare_rebuilds_the_prior_with_the_travel_exponents(tmp_path):
    """The prior ``history compare`` rebuilds from a model file is the fit's own: its group
    scales, curvature factors and, since session 11 of issue 30, the travel exponents,
    which scale each axis' functions by ``(L_k / L_mean)^beta``. On 800 x 600 x 500 mm the
    evidence sets them away from zero (this machine: 0.80 and 0.11), so a rebuild
    that left them out would give each axis the group's scale (checked: the precision then
    differs by more than 5 %)."""
    import scipy.sparse as sp

    from volcal.history.compare import prior_precision
    from volcal.identify.modelfile import load_model
    from volcal.identify.modelwrite import write_model
    from volcal.identify.prior import PriorStructure
    from volcal.identify.settings import EstimatorSettings
    from volcal.measure.virtual import random_machine

    r = _model(random_machine(TRAVEL, "XYFZ", seed=11), seed=12, steps=6, runs=2)
    hyp = r.fit.hyperparameters
    assert hyp["travel_exponent"] and max(abs(v) for v in hyp["travel_exponent"]) > 0.05
    model = load_model(write_model(r, tmp_path / "m.json"))
    got = prior_precision(model)
    sol = r.solution
    prior = (PriorStructure.build(model.layout, model.free, sol.kappa,
                                  settings=EstimatorSettings())
             .with_trend(sol.trend_um).with_tilt_trend(sol.tilt_trend_urad)
             .with_axis_kappa(sol.axis_kappa).with_nugget(sol.nugget_um))
    want = prior.precision(sol.function_scales, 100.0, int(model.free.size), np.zeros(0))
    g, w = sp.csr_matrix(got).toarray(), sp.csr_matrix(want).toarray()
    np.testing.assert_allclose(g, w, rtol=1e-6, atol=1e-9 * np.abs(w).max())
    flat = prior.precision(sol.scales, 100.0, int(model.free.size), np.zeros(0))
    assert np.abs(sp.csr_matrix(flat).toarray() - w).max() > 0.05 * np.abs(w).max()


def test_compare_rebuilds_the_prior_with_the_recorded_settings(tmp_path):
    """A model identified with other estimator settings (``--estimator-settings``: the
    rolls as rough as the tilts, ``group_kappa``) records them (``fit.estimator_settings``),
    and the prior ``history compare`` rebuilds from its file is that fit's, not the
    defaults' (checked: the defaults' precision differs by more than 5 %)."""
    import scipy.sparse as sp

    from volcal.flow import Calibration
    from volcal.history.compare import prior_precision
    from volcal.identify.modelfile import load_model
    from volcal.identify.modelwrite import write_model
    from volcal.identify.prior import PriorStructure
    from volcal.identify.settings import EstimatorSettings
    from volcal.identify.settings_file import recorded_settings
    from volcal.measure.virtual import random_machine

    st = EstimatorSettings(group_kappa=(1.0, 1.0, 1.0, 1.0))
    c = Calibration.plan(TRAVEL, steps=6, runs=2)
    c.simulate(machine=random_machine(TRAVEL, "XYFZ", seed=11), seed=12)
    r = c.identify(settings=st)
    model = load_model(write_model(r, tmp_path / "m.json"))
    assert model.fit["estimator_settings"] == {"group_kappa": [1.0, 1.0, 1.0, 1.0]}
    assert recorded_settings(model) == st
    got = sp.csr_matrix(prior_precision(model)).toarray()
    sol = r.solution
    want, default = (
        sp.csr_matrix(PriorStructure.build(model.layout, model.free, sol.kappa, settings=s)
                      .with_trend(sol.trend_um).with_tilt_trend(sol.tilt_trend_urad)
                      .with_axis_kappa(sol.axis_kappa).with_nugget(sol.nugget_um)
                      .precision(sol.function_scales, 100.0, int(model.free.size),
                                 np.zeros(0))).toarray()
        for s in (st, EstimatorSettings()))
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9 * np.abs(want).max())
    assert np.abs(default - want).max() > 0.05 * np.abs(want).max()
    model.fit["estimator_settings"] = {"group_kappa": [1.0, 1.0], "from_a_later_volcal": 1}
    assert recorded_settings(model) == EstimatorSettings()  # refused values: the defaults
