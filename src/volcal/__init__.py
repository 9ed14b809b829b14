"""volcal: open laser-interferometer calibration of machine tools and CMMs.

The package follows one direction of flow::

    plan -> program -> measure/simulate -> identify -> evaluate -> compensate -> report

The kinematic model (:mod:`volcal.model`) is the shared core. Plotting lives in
:mod:`volcal.plot` and is never imported by the analysis code.

The flow from Python (``docs/python.md``): :class:`Calibration` chains the steps;
:func:`evaluate_session` evaluates a session to the standards; :func:`read_session`,
:func:`identify` and :func:`load_model` are the building blocks. They are imported on
first use, so ``import volcal`` stays light (no numpy-heavy estimator, no matplotlib).
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from volcal.errors import VolcalInputError

__version__ = "0.1.0"

_LAZY = {
    "Calibration": "volcal.flow",
    "evaluate_session": "volcal.standards.session",
    "SessionEvaluation": "volcal.standards.session",
    "identify": "volcal.identify",
    "load_model": "volcal.identify",
    "IdentificationResult": "volcal.identify",
    "read_session": "volcal.session.format",
    "History": "volcal.history.api",
}

__all__ = ["VolcalInputError", "__version__", *sorted(_LAZY)]


def __getattr__(name: str) -> Any:
    """Import the public names on first use (PEP 562)."""
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'volcal' has no attribute {name!r}")


def __dir__() -> list[str]:
    """Public names, including the lazily imported ones."""
    return sorted(set(globals()) | set(_LAZY))
