"""locate's sentence on the linear model names the functions the model hardly measures."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from volcal.identify.location_linear import LinearPrior, linear_prior_note, undetermined


def _prior(under: list[str]) -> LinearPrior:
    return LinearPrior("model with covariance", np.full((6, 2), 1.5), np.zeros(6), 40,
                       undetermined=under)


def test_undetermined_functions_are_named():
    """Session 20: a model of X's lines alone, given to locate, moved five of eight location
    errors 3.4-5.6 standard uncertainties from the virtual machine's (its Y and Z functions
    at the identification's prior, narrower than that machine's); nothing said so."""
    model = SimpleNamespace(report={"determined_fraction": {"EXX": 1.0, "EAX": 0.02,
                                                            "EYY": 0.3, "EC0Y": 0.5}})
    under = undetermined(model)
    assert under == ["EAX", "EYY"]
    prior = _prior(under)
    text = linear_prior_note(prior, model)
    assert "determine less than half of the prior variance of EAX, EYY:" in text
    assert "volcal advise" in text
    assert prior.to_json()["undetermined"] == ["EAX", "EYY"]


def test_a_model_that_measures_everything_says_nothing_more():
    model = SimpleNamespace(report=SimpleNamespace(determined_fraction={"EXX": 0.99}))
    assert undetermined(model) == [] and undetermined(object()) == []
    assert "determine less" not in linear_prior_note(_prior([]), model)


def test_the_share_of_u_the_undetermined_functions_carry():
    """Session 21: locate said which functions were undetermined, not how much of each
    location error's U rested on them. With X's lines alone (every function of Y and Z,
    X's straightness and roll, the squareness undetermined) and with the seeds' full set
    (X's roll undetermined), one machine: the U with those functions taken as known lies
    between the noise's alone and the full U, much of the variance is theirs, and locate
    says how much."""
    from volcal.measure.simulate import SimulationOptions, simulate_session
    from volcal.measure.virtual import random_machine
    from volcal.plan.planner import plan_session
    from volcal.session.format import Session
    from volcal.steps.identify import identify
    from volcal.steps.locate import locate

    travel = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
    s = plan_session(travel, "XYFZ", steps=4, tests=("linear:x", "r_test"), runs=2)
    simulate_session(s, random_machine(travel, "XYFZ", seed=0), SimulationOptions(seed=1000))
    lines = Session(s.name, s.chain, s.travel, [m for m in s.measurements
                                                if m.kind != "r_test"], s.meta)
    out = locate(s, model=identify(lines).result)
    r = out.result
    assert "EZX" in r.linear.undetermined and "EC0Y" in r.linear.undetermined
    ud, u0 = r.u_without_undetermined, r.u_without_linear
    assert ud is not None and u0 is not None and set(ud) == set(r.names)
    for n in r.names:
        assert u0[n] <= ud[n] * (1 + 1e-9) and ud[n] <= r.u[n] * (1 + 1e-9), n
    share = {n: 1 - (ud[n] / r.u[n]) ** 2 for n in r.names}
    worst = max(share, key=lambda n: share[n])
    assert share[worst] > 0.9  # X's lines say nearly nothing of what the R-test's poses move
    (msg,) = [m for m in out.messages if m.startswith("The undetermined functions' prior")]
    assert f"up to {100 * share[worst]:.0f} % of a location error's variance ({worst}: " in msg
    assert out.to_json()["u_without_undetermined"] == ud
    # an error table carries no covariance: nothing to split
    assert locate(s, model=random_machine(travel, "XYFZ", seed=0)).result \
        .u_without_undetermined is None
