"""Identification time of the direct set and of the seeds fused with direct optics.

Each against the seeds' full test set of about the same size (readings): the target is
2x the seeds' time (issue 16). Sizes: 100 increments per line; the seeds with 2 runs per
linear line, the direct set (18 lines) with 2 bidirectional runs.
"""

from __future__ import annotations

import time

import numpy as np

from volcal.identify import IdentifyOptions, identify
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import Session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])


def _sessions(steps: int = 100) -> dict[str, Session]:
    seeds = plan_session(TRAVEL, "XYFZ", steps, runs=2)
    direct = plan_session(TRAVEL, "XYFZ", steps, ("direct",), runs=2)
    extra = [m for m in plan_session(TRAVEL, "XYFZ", steps, ("direct",), runs=1).measurements
             if m.id in ("lev-xa", "lev-yb", "str-zx", "str-zx-roll")]
    fused = Session("fused", "XYFZ", TRAVEL,
                    plan_session(TRAVEL, "XYFZ", steps, runs=2).measurements + extra)
    out = {"seeds' full set": seeds, "direct set": direct, "seeds + direct optics": fused}
    truth = random_machine(TRAVEL, "XYFZ", seed=1)
    for s in out.values():
        simulate_session(s, truth, SimulationOptions(noise_um=0.5, seed=2))
    return out


def _time(s: Session) -> float:
    best = np.inf
    identify(s, IdentifyOptions())  # warm-up
    for _ in range(3):
        t0 = time.perf_counter()
        identify(s, IdentifyOptions())
        best = min(best, time.perf_counter() - t0)
    return float(best)


def run() -> list[dict]:
    """Time ``identify`` on the three designs."""
    rows = []
    base = None
    for name, s in _sessions().items():
        dt = _time(s)
        n = sum(m.n for m in s.measurements)
        if base is None:
            base = (dt, n)
        row = {"benchmark": f"identify ({name})", "size": f"{n} readings", "seconds": dt}
        if name != "seeds' full set":
            row["target_s"] = 2.0 * base[0] * max(1.0, n / base[1])
            row["note"] = f"target 2x the seeds' {base[0]:.2f} s (scaled by readings if more)"
        rows.append(row)
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
