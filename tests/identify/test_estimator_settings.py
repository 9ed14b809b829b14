"""The estimator's settings: one frozen object, reached through the identify options.

Issue 25 (item 7) moved the module-level switches and tuning constants of
``volcal/identify/`` into :class:`volcal.identify.settings.EstimatorSettings`. The
defaults are the constants identify used before, and the fit of a fixed session is the
one volcal computed before the move (figures recorded from volcal at commit 427f26d; a
before/after comparison over 13 identifications, full set, multilateration, direct optics,
step diagonals, a missed reading, with and without a budget, found them equal bit for bit).
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
from pathlib import Path

import numpy as np
import pytest
from identify_helpers import TRAVEL, exact_fill, seeds_session

from volcal.errors import VolcalInputError
from volcal.identify import EstimatorSettings, IdentifyOptions, identify
from volcal.measure.virtual import random_machine

# the module-level constants of volcal/identify before issue 25 (commit 427f26d), by the
# setting that replaced each
BEFORE = {
    "typical_scales": (10.0, 5.0, 15.0, 15.0),  # solver.DEFAULT_SCALES
    "hyper_centre": (10.0, 2.0, 15.0, 15.0),  # solver.HYPER_CENTRE (log), without kappa
    "kappa_centre": 6.0,  # solver.HYPER_CENTRE[-1] (log)
    "hyper_spread": 30.0,  # solver.HYPER_SPREAD = log(30)
    "tilt_centre_urad": 50.0,  # solver.TILT_CENTRE_URAD
    "tilt_spread": 2.0,  # solver.TILT_SPREAD = log(2)
    "trend_centre_um": 20.0,  # solver.TREND_CENTRE_UM
    "trend_spread": 3.0,  # solver.TREND_SPREAD = log(3)
    "nugget": True,  # solver.NUGGET
    "nugget_centre_um": 0.2,  # solver.NUGGET_CENTRE_UM
    "nugget_spread": 10.0,  # solver.NUGGET_SPREAD = log(10)
    "roll_factor": 1.5,  # solver.ROLL_FACTOR
    "roll_mixture_absent": 0.5,  # solver.ROLL_MIXTURE_ABSENT
    "roll_mixture_covariance": "roll",  # solver.ROLL_MIXTURE_COVARIANCE
    "group_kappa": (1.0, 1.0, 0.6, 1.0),  # prior.GROUP_KAPPA
    "boundary": "difference",  # prior.BOUNDARY
    "evidence_tol": 0.05,  # solver.EVIDENCE_TOL
    "sigma_fixed_point_steps": 2,  # solver.SIGMA_FIXED_POINT_STEPS
    "dense_qr_limit": 2000,  # solver.DENSE_QR_LIMIT
    "dense_qr_entries": 2_000_000,  # solver.DENSE_QR_ENTRIES
    "dense_covariance_limit": 6000,  # solver.DENSE_COVARIANCE_LIMIT
    "nodes_at_readings": True,  # design.NODES_AT_READINGS
    "visited_nodes_factor": 1.5,  # design.VISITED_NODES_FACTOR
    "hyper_max_nodes": 21,  # api.HYPER_MAX_NODES
    "analysis_max_nodes": 41,  # api.ANALYSIS_MAX_NODES
    "robust_iterations": 5,  # api.ROBUST_ITERATIONS
    "default_repeatability_um": 0.5,  # api.DEFAULT_REPEATABILITY_UM
    "no_roll_note_factor": 100.0,  # api.NO_ROLL_NOTE_FACTOR
}


# issue 30 (the estimator on long machines) changed or added these defaults; the others are
# BEFORE's
ISSUE_30 = {
    "hyper_spread": 3.0,  # 30 before: the scales' hyperprior a factor 3
    "trend_per_metre": True,  # the positioning trend a scale error per metre of travel
    "trend_centre_um_per_m": 25.0,
    "tilt_trend_centre_urad": 15.0,  # the tilts' linear part with a scale of its own
    "tilt_trend_spread": 3.0,
    "axis_kappa_spread": 6.0,  # each axis' curvature factor chosen by the evidence (3 in round 1)
    "axis_scale_spread": 0.0,
    # each axis' amplitudes grow with its travel, the exponents chosen by the evidence
    # (session 11): one for the linear errors, one for the angular ones
    "travel_exponent_spread": 1.0,
    "travel_exponent_centre": 0.0,
    "travel_exponent_groups": ((0, 1), (2, 3)),
    # the angular exponent (rolls and tilts) bounded below at 0 (session 12)
    "travel_exponent_bounds": ((-1.0, 2.0), (0.0, 2.0)),
    # each axis' curvature factor (L_k / L_mean)^gamma, one exponent chosen by the evidence
    # (session 12), instead of the free factors of axis_kappa_spread
    "kappa_travel_exponent_spread": 1.0,
    "kappa_travel_exponent_bounds": (-2.0, 4.0),
    # the nodes between the readings: the prior's conditional variance times 1 + this
    # (session 14), the estimate unchanged
    "between_readings_factor": 2.0,
    # the rolls' uncertainty dropped where the readings are decisive against rolls
    # (session 16), the estimate unchanged
    "roll_mixture_covariance": "cautious",
    "roll_covariance_absent": 0.01,
}
# the estimator of volcal before issue 30, through the settings
OLD = {"hyper_spread": 30.0, "trend_per_metre": False, "tilt_trend_centre_urad": 0.0,
       "axis_kappa_spread": 0.0, "travel_exponent_spread": 0.0,
       "kappa_travel_exponent_spread": 0.0, "between_readings_factor": 0.0,
       "roll_mixture_covariance": "roll"}


@pytest.fixture(scope="module")
def small():
    s = seeds_session("XYFZ", steps=4)
    exact_fill(s, random_machine(TRAVEL, "XYFZ", seed=3), seed=4)
    return s


@pytest.fixture(scope="module")
def default_fit(small):
    """The fit of the estimator before issue 30 (its settings, :data:`OLD`)."""
    return identify(small, IdentifyOptions(suggest=False, settings=EstimatorSettings(**OLD)))


def test_settings_are_frozen_and_their_defaults_are_the_old_constants():
    st = EstimatorSettings()
    with pytest.raises(dataclasses.FrozenInstanceError):
        st.roll_factor = 2.0  # type: ignore[misc]
    assert {f.name for f in dataclasses.fields(st)} == set(BEFORE) | set(ISSUE_30)
    for name, value in {**BEFORE, **ISSUE_30}.items():
        assert getattr(st, name) == value, name
    assert IdentifyOptions().settings == st
    changed = dataclasses.replace(st, roll_factor=2.0)
    assert changed.roll_factor == 2.0 and st.roll_factor == 1.5


def test_the_default_fit_is_the_one_volcal_computed_before(default_fit):
    """Figures of volcal at commit 427f26d (before the settings object) on this session,
    with the settings of the estimator before issue 30 (:data:`OLD`): the old estimator is
    still reached, bit for bit."""
    fit = default_fit.fit
    assert fit["log_evidence"] == pytest.approx(-637.0768523757879, rel=1e-7)
    assert fit["sigma_um"] == pytest.approx(0.47468807931912965, rel=1e-7)
    assert fit["dof"] == pytest.approx(159.1981972267104, rel=1e-7)
    want = {"positioning_um": 0.9751545172207767, "straightness_um": 2.8817652726256777,
            "roll_urad": 7.381617596998594, "tilt_urad": 4.921078397999063,
            "kappa": 18.743554241801917, "positioning_trend_um": 9.986665118759307,
            "positioning_nugget_um": 0.2558568187126094, "setup_tilt_urad": 17.587935336540372}
    assert {k: fit["prior_scales"][k] for k in want} == pytest.approx(want, rel=1e-7)
    # the hyperparameters issue 30 added are absent from the old estimator's fit
    assert all(fit["prior_scales"][k] is None
               for k in ("positioning_trend_um_per_m", "tilt_trend_urad", "kappa_axis",
                         "kappa_travel_exponent"))
    rp = fit["roll_presence"]
    assert rp["log_bayes_factor"] == pytest.approx(-1.8115754311829022, rel=1e-7)
    assert rp["probability"] == pytest.approx(0.1404478284047197, rel=1e-7)
    assert rp["prior_probability_absent"] == 0.5
    x = np.linspace(0.0, 800.0, 5)
    np.testing.assert_allclose(default_fit.errors.function("EBX", x),
                               [0.0, 1.6389010574745588, 8.49693303004179, 12.523678581696165,
                                27.546751900299345], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(default_fit.errors.function("EAX", x),
                               [0.0, 0.3364401151007743, 0.11083657008435566,
                                -0.41009271260923574, -0.7078623851876378], rtol=1e-7,
                               atol=1e-9)


def test_a_setting_given_through_the_options_changes_the_fit(small, default_fit):
    """The rolls' factor over the tilts' scale is applied after the evidence: twice the
    factor, twice the rolls' prior scale, the other scales as they were."""
    r = identify(small, IdentifyOptions(suggest=False,
                                        settings=EstimatorSettings(**OLD, roll_factor=3.0)))
    a, b = default_fit.fit["prior_scales"], r.fit["prior_scales"]
    assert b["roll_urad"] == pytest.approx(2.0 * a["roll_urad"], rel=1e-9)
    for key in ("positioning_um", "straightness_um", "tilt_urad", "kappa"):
        assert b[key] == pytest.approx(a[key], rel=1e-9), key
    x = np.linspace(0.0, 800.0, 5)
    assert np.abs(r.errors.function("EAX", x) - default_fit.errors.function("EAX", x)).max() \
        > 1e-3


def test_a_setting_given_to_calibration_identify_reaches_the_estimator(small, default_fit):
    """``Calibration.identify(settings=...)``: no prior probability of a machine without
    roll, so no two-model average; the readings' Bayes factor is the same."""
    from volcal.flow import Calibration

    cal = Calibration(small)
    r = cal.identify(suggest=False, settings=EstimatorSettings(**OLD, roll_mixture_absent=0.0))
    rp = r.fit["roll_presence"]
    assert rp["prior_probability_absent"] == 0.0 and rp["probability"] is None
    assert rp["log_bayes_factor"] == pytest.approx(
        default_fit.fit["roll_presence"]["log_bayes_factor"], rel=1e-6)
    x = np.linspace(0.0, 800.0, 5)
    assert np.abs(r.errors.function("EBX", x) - default_fit.errors.function("EBX", x)).max() \
        > 1e-3  # the average (P(roll) 0.14) is not the fit with rolls


def test_bad_settings_are_refused_with_the_field_named():
    with pytest.raises(VolcalInputError, match="boundary"):
        EstimatorSettings(boundary="free")
    with pytest.raises(VolcalInputError, match="roll_mixture_absent"):
        EstimatorSettings(roll_mixture_absent=1.0)
    with pytest.raises(VolcalInputError, match="group_kappa"):
        EstimatorSettings(group_kappa=(1.0, 1.0, 0.6))
    with pytest.raises(VolcalInputError, match="axis_kappa_spread"):
        EstimatorSettings(axis_kappa_spread=0.5)
    with pytest.raises(VolcalInputError, match="tilt_trend_centre_urad"):
        EstimatorSettings(tilt_trend_centre_urad=-1.0)
    with pytest.raises(VolcalInputError, match="travel_exponent_spread"):
        EstimatorSettings(travel_exponent_spread=-1.0)
    with pytest.raises(VolcalInputError, match="travel_exponent_bounds"):
        EstimatorSettings(travel_exponent_bounds=(1.0, -1.0))
    with pytest.raises(VolcalInputError, match="one such pair per set"):
        EstimatorSettings(travel_exponent_bounds=((-1.0, 2.0),))  # two sets of groups
    with pytest.raises(VolcalInputError, match="travel_exponent_bounds"):
        EstimatorSettings(travel_exponent_bounds=((-1.0, 2.0), (2.0, 0.0)))
    assert EstimatorSettings(travel_exponent_bounds=(-1.0, 2.0)).travel_exponent_bound_pairs() \
        == [(-1.0, 2.0), (-1.0, 2.0)]
    with pytest.raises(VolcalInputError, match="travel_exponent_groups"):
        EstimatorSettings(travel_exponent_groups=((0, 5),))
    with pytest.raises(VolcalInputError, match="kappa_travel_exponent_spread"):
        EstimatorSettings(kappa_travel_exponent_spread=-0.5)
    with pytest.raises(VolcalInputError, match="kappa_travel_exponent_bounds"):
        EstimatorSettings(kappa_travel_exponent_bounds=(2.0, 2.0))
    with pytest.raises(VolcalInputError, match="settings"):
        IdentifyOptions(settings={"roll_factor": 2.0})  # type: ignore[arg-type]


def test_no_function_of_the_solver_is_over_80_lines():
    from volcal.identify import solver

    tree = ast.parse(Path(inspect.getfile(solver)).read_text())
    long = {n.name: n.end_lineno - n.lineno + 1 for n in ast.walk(tree)
            if isinstance(n, ast.FunctionDef) and n.end_lineno - n.lineno + 1 > 80}
    assert not long, long
