"""Shared builders for the identification tests (not named conftest: other test folders
import their own conftest by name)."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType

import numpy as np

from volcal.measure.readings import reading_first_order
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.model.names import info
from volcal.plan.planner import plan_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def seeds_session(chain: str = "XYFZ", steps: int = 10, tests=("step-diagonal", "diagonal",
                                                                 "linear"), runs: int = 2):
    """The seeds' full test set, planned."""
    # the equally spaced step grid reaching the travel ends, where the gauge pins every
    # function: the estimator's exactness is tested there (the ISO 230-2 default plan keeps
    # 5 mm for the overrun, so nothing between the travel start and the first target is
    # observed and no function is "fully determined")
    return plan_session(TRAVEL, chain, steps, tests, runs=runs, iso_spacing=False,
                        linear_margin_mm=0.0)


def first_order_fill(session, machine, seed: int = 0, tilt_urad: float = 20.0) -> None:
    """Fill deviations with the first-order reading model and random set-up tilts, no noise."""
    rng = np.random.default_rng(seed)
    for m in session.measurements:
        m.deviation = reading_first_order(machine, m, rng.normal(0.0, tilt_urad, 2))


def exact_fill(session, machine, seed: int, noise_um: float = 0.5, mirror_urad: float = 20.0):
    """Fill deviations with the exact simulator (beam alignment, mirror misalignment, noise)."""
    simulate_session(session, machine, SimulationOptions(noise_um=noise_um,
                                                         mirror_misalignment_urad=mirror_urad,
                                                         seed=seed))


def grid(nodes, stride: int = 2):
    """Grid over the measured positions."""
    return np.stack(np.meshgrid(*[n[::stride] for n in nodes], indexing="ij"), -1).reshape(-1, 3)



LABEL = re.compile(r"\b(E[XYZABC]0?[XYZ]) \(([^)]*)\)")
"""An ISO 230-1 name followed by its meaning in parentheses: ``EBY (roll of Y)``."""


def assert_labels_match_table(text: str) -> int:
    """Each ``NAME (meaning)`` in ``text`` carries the ISO 230-1 table's meaning; returns
    how many there are."""
    found = LABEL.findall(text)
    for name, meaning in found:
        assert meaning == info(name).label, (name, meaning)
    return len(found)


def load_benchmark(name: str) -> ModuleType:
    """A module of benchmarks/ (``'study'``, ``'families'``), imported once per process as
    ``volcal_<name>`` (registered before it runs: dataclasses look their module up by
    name)."""
    key = f"volcal_{name}"
    if key in sys.modules:
        return sys.modules[key]
    path = Path(__file__).resolve().parents[2] / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(key, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[key] = mod
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    return mod
