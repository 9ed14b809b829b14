"""Shared helpers of the foundation tests: random machines, chains and measurements."""

from __future__ import annotations

import itertools
import os

import numpy as np
import pytest
from hypothesis import settings

from volcal.measure.virtual import random_machine
from volcal.model.errorfunctions import MachineErrors
from volcal.session.format import Measurement

# CI runs the property tests on a fixed set of examples (a failure is reproducible and does
# not come and go between runs); HYPOTHESIS_PROFILE=explore draws new examples each run.
settings.register_profile("ci", derandomize=True, deadline=None)
settings.register_profile("explore", deadline=None)
# the slow fuzz run of session files (tests/session/test_fuzz_sessions.py, README): new examples
settings.register_profile("fuzz", deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])

ALL_CHAINS: tuple[str, ...] = tuple(
    "".join(p) for p in itertools.permutations("FXYZ")
)
"""All 24 chain codes."""


def machine(chain: str = "XYFZ", seed: int = 0, scale: float = 1.0,
            travel=TRAVEL, n_nodes: int = 41) -> MachineErrors:
    """A random realistic machine, all errors multiplied by ``scale``."""
    return random_machine(travel, chain, seed, n_nodes=n_nodes).scaled(scale)


def only(m: MachineErrors, names: dict[str, float | np.ndarray]) -> MachineErrors:
    """Copy of ``m`` with every error zero except the named ones.

    Values are constants or arrays on the axis' nodes; squareness values are constants.
    """
    out = m.scaled(0.0)
    for name, val in names.items():
        from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

        if name in SQUARENESS_NAMES:
            out.squareness[SQUARENESS_NAMES.index(name)] = val
        else:
            idx = COMPONENT_NAMES.index(name)
            out.values[idx // 6][:, idx % 6] = val
    return out


def meas(positions, target="retroreflector", beam=None, tool_offset=(0, 0, 0),
         kind="step_diagonal") -> Measurement:
    """A measurement skeleton at the given positions."""
    p = np.asarray(positions, dtype=float)
    if beam is None:
        d = p[-1] - p[0]
        beam = d / np.linalg.norm(d)
    return Measurement("m", kind, target, p, None, beam, np.asarray(tool_offset, float))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
