"""Identification: one least-squares engine for any combination of tests.

``identify(session)`` returns an :class:`IdentificationResult` with the error functions,
their uncertainties, an identifiability report in plain words and fit statistics.
"""

from volcal.identify.api import IdentifyOptions, advise, identify, monte_carlo
from volcal.identify.modelfile import load_model, load_model_errors
from volcal.identify.result import IdentificationResult

__all__ = [
    "IdentificationResult",
    "IdentifyOptions",
    "advise",
    "identify",
    "load_model",
    "load_model_errors",
    "monte_carlo",
]
