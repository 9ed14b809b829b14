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
