"""Identification time and peak memory at 10, 100 and 1000 increments per test.

The session is the seeds' full test set (4 step diagonals with a flat mirror, 4 body
diagonals, 3 lines per axis with 2 bidirectional runs), simulated with 0.5 um noise.
Past ~40 increments the node grid is capped (``IdentifyOptions.max_nodes``, 41 per
axis), so the parameter count stops growing and the cost is dominated by the evidence
search (dense Cholesky of the ~800 x 800 posterior precision per evaluation) and by terms
linear in the number of readings (assembling ``A``, ``A^T A``, residuals, leverages).
Targets (issue 10): 1 s at 100 increments, 2 s at 1000, 300 MB peak; issue 30: 3 s on a
6000 x 1000 x 800 mm machine at 30 increments per test.
"""

from __future__ import annotations

import time
import tracemalloc

import numpy as np

from volcal.identify import IdentifyOptions, identify
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
LONG = np.array([[0.0, 6000.0], [0.0, 1000.0], [0.0, 800.0]])


def _session(steps: int):
    s = plan_session(TRAVEL, "XYFZ", steps, runs=2)
    simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=1),
                     SimulationOptions(noise_um=0.5, seed=2))
    return s


def run() -> list[dict]:
    """Time ``identify`` (with the identifiability report) per size."""
    rows = []
    for steps in (10, 100, 1000):
        s = _session(steps)
        n = sum(m.n for m in s.measurements)
        t0 = time.perf_counter()
        r = identify(s, IdentifyOptions())
        dt = time.perf_counter() - t0
        # memory in a second run: tracemalloc slows numpy down, so it is not timed
        tracemalloc.start()
        identify(s, IdentifyOptions())
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        rows.append({"benchmark": "identify (seeds' full test set)",
                     "size": f"{steps} incr, {n} readings, {r.fit['n_parameters']} par",
                     "seconds": dt,
                     **({"target_s": {100: 1.0, 1000: 2.0}[steps]} if steps in (100, 1000)
                        else {}),
                     "note": f"peak {peak / 2**20:.0f} MiB, {1e6 * dt / n:.0f} us/reading"})
    # a long machine (issue 30): 6 m of X travel, 30 increments per test
    s = plan_session(LONG, "FXYZ", 30, runs=2)
    simulate_session(s, random_machine(LONG, "FXYZ", seed=1),
                     SimulationOptions(noise_um=0.5, seed=2))
    n = sum(m.n for m in s.measurements)
    t0 = time.perf_counter()
    r = identify(s, IdentifyOptions())
    dt = time.perf_counter() - t0
    rows.append({"benchmark": "identify (seeds' full test set, 6000 x 1000 x 800 mm)",
                 "size": f"30 incr, {n} readings, {r.fit['n_parameters']} par",
                 "seconds": dt, "target_s": 3.0,
                 "note": f"{1e6 * dt / n:.0f} us/reading"})
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
