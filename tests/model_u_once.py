"""The model's U computed once per model content in a test process: the fixture
``model_u_once``, for the tests that store, show or compare a model's U, not compute it.

:func:`volcal.standards.model_uncertainty.model_uncertainty` draws the model's posterior
(400 seeded draws: about a second and a half of CPU for the small sessions of the tests).
volcal keeps the last few results by object (a report and its certificate ask for the
same model's U); every ``history add`` reads the model file again, so each add draws again,
and the history tests add the same few sessions and models many times (benchmarks/README.md,
"make test time"). The draws are seeded: the same model gives the same numbers to the last
bit, so a result kept by the model's content is the result the draws would give again.

The key is the SHA-256 of every input the function reads (the estimate, the covariance
factors, the free parameters and their layout, the error functions, the systematic
inputs' labels, and the arguments); a model differing in any bit is drawn anew. Each call
gets its own deep copy. The function itself is checked by the tests that do not ask for
this fixture: tests/standards/test_model_uncertainty.py, and
tests/history/test_uncertainty_stored.py (every stored U against the evaluation's own).
"""

from __future__ import annotations

import copy
import hashlib
import pickle
from typing import Any

import numpy as np
import pytest

__all__ = ["model_u_once", "model_u_key"]

_KEPT: dict[str, Any] = {}
"""Results by key, for the life of the test process (a few models, a few kB each)."""


def model_u_key(result: Any, tool_offset: Any = (0.0, 0.0, 0.0), n: int = 11,
                draws: int = 400, seed: int = 0) -> str:
    """SHA-256 of everything :func:`model_uncertainty` reads of ``result`` and its arguments."""
    errors = result.errors
    parts = (
        np.asarray(result.theta, dtype=float), np.asarray(result.cov_factor, dtype=float),
        None if getattr(result, "sys_factor", None) is None
        else np.asarray(result.sys_factor, dtype=float),
        np.asarray(result.free), list(getattr(result, "sys_labels", []) or []),
        result.layout, errors.chain, [np.asarray(v) for v in errors.nodes],
        [np.asarray(v) for v in errors.values], np.asarray(errors.squareness),
        np.asarray(errors.travel), getattr(errors, "reversal", None),
        np.asarray(tool_offset, dtype=float), int(n), int(draws), int(seed))
    return hashlib.sha256(pickle.dumps(parts, protocol=5)).hexdigest()


@pytest.fixture
def model_u_once(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Keep :func:`model_uncertainty`'s results by the model's content (see the module);
    returns the counts of ``drawn`` and ``kept`` results of the test."""
    import volcal.standards.model_uncertainty as mu

    real = mu.model_uncertainty
    counts = {"drawn": 0, "kept": 0}

    def model_uncertainty(result, tool_offset=(0.0, 0.0, 0.0), n=11, draws=400, seed=0):
        try:
            key = model_u_key(result, tool_offset, n, draws, seed)
        except Exception:  # not a complete model (its refusal is the real function's)
            return real(result, tool_offset, n, draws, seed)
        if key not in _KEPT:
            _KEPT[key] = real(result, tool_offset, n, draws, seed)
            counts["drawn"] += 1
        else:
            counts["kept"] += 1
        return copy.deepcopy(_KEPT[key])

    monkeypatch.setattr(mu, "model_uncertainty", model_uncertainty)
    return counts
