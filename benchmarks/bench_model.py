"""Benchmarks of the kinematic model and the session simulator (issue 2)."""

from __future__ import annotations

import time

import numpy as np

from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.kinematics import volumetric_error, volumetric_error_exact
from volcal.plan.planner import plan_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def best_of(fn, repeat: int = 3) -> float:
    """Best wall time of ``repeat`` calls [s] (after one warm-up call)."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def run() -> list[dict]:
    """Volumetric error map at 10^6 points, exact model at 10^5, full session simulation."""
    m = random_machine(TRAVEL, "XYFZ", seed=1)
    q = np.random.default_rng(0).uniform(TRAVEL[:, 0], TRAVEL[:, 1], (1_000_000, 3))
    t = np.array([0.0, 0.0, 150.0])
    rows = [{"benchmark": "volumetric_error (first order, one call)", "size": "10^6 points",
             "seconds": best_of(lambda: volumetric_error(m, q, t)), "target_s": 1.0}]
    q5 = q[:100_000]
    rows.append({"benchmark": "volumetric_error_exact", "size": "10^5 points",
                 "seconds": best_of(lambda: volumetric_error_exact(m, q5, t))})

    def simulate():
        s = plan_session(TRAVEL, "XYFZ", steps=100, tests=("step-diagonal", "diagonal",
                                                            "linear"), runs=5)
        simulate_session(s, m, SimulationOptions(seed=0))
        return s

    s = simulate()
    n = sum(ms.n for ms in s.measurements)
    rows.append({"benchmark": "plan + simulate_session (exact readings)",
                 "size": f"{len(s.measurements)} tests, {n} readings",
                 "seconds": best_of(simulate),
                 "note": "4 step diag., 4 diag., 9 lines x 5 bidir. runs, 100 increments"})
    return rows
