"""Identification: one least-squares engine for any combination of tests.

``identify(session)`` returns an :class:`IdentificationResult` with the error functions,
their uncertainties, an identifiability report in plain words and fit statistics.
The names are imported on first use (PEP 562): ``load_model`` does not import the
estimator (scipy), so reading a model file stays fast.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_LAZY = {
    "EstimatorSettings": "volcal.identify.settings",
    "IdentificationResult": "volcal.identify.result",
    "IdentifyOptions": "volcal.identify.api",
    "advise": "volcal.identify.api",
    "identify": "volcal.identify.api",
    "load_model": "volcal.identify.modelfile",
    "load_model_errors": "volcal.identify.modelfile",
    "monte_carlo": "volcal.identify.api",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    """Import the public names on first use (PEP 562)."""
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'volcal.identify' has no attribute {name!r}")


def __dir__() -> list[str]:
    """Public names, including the lazily imported ones."""
    return sorted(set(globals()) | set(_LAZY))
