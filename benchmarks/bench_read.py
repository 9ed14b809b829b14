"""Reading a session from its files: ``read_session`` of the seeds' full test set.

The session is planned and simulated at 100 and 1000 increments per test (5 bidirectional
runs, ``volcal plan``'s default), written as ``volcal simulate`` writes it, and read back
as every command does: the CSV tables cell by cell checked (file, row and column of any
mistake), the session's checks and the plausibility warnings. Session 21 read the cells
column-wise (``volcal.io.table``), the row-wise reading kept to name a mistake.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def run() -> list[dict]:
    """Time ``read_session`` (best of 3) per size."""
    rows = []
    for steps in (100, 1000):
        s = plan_session(TRAVEL, "XYFZ", steps)
        simulate_session(s, random_machine(TRAVEL, "XYFZ", seed=1),
                         SimulationOptions(noise_um=0.5, seed=2))
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp) / "S"
            write_session(s, folder)
            times = []
            for _ in range(3):
                t0 = time.perf_counter()
                back = read_session(folder)
                times.append(time.perf_counter() - t0)
        n = sum(m.n for m in back.measurements)
        dt = min(times)
        rows.append({"benchmark": "read_session (seeds' full test set, from its files)",
                     "size": f"{steps} incr, {n} readings", "seconds": dt,
                     "note": f"{1e6 * dt / n:.1f} us/reading"})
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
