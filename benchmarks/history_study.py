"""Honesty of the history's change test (docs/history.md): false alarms and power.

Pairs of simulated calibrations of one machine (the seeds' full set on 800 x 600 x 500
mm, XYFZ, 0.5 um noise, 20 urad mirror misalignment; the second calibration with other
noise and set-up) on designs of 4, 6, 10 and 20 increments and 1, 2 and 5 runs, with
machines of three families: volcal's own generator
(:func:`volcal.measure.virtual.random_machine`) and two generated outside it
(``benchmarks/families.py``: ``b`` polynomials without roll, ``d`` polynomials with
rolls and ball-screw cyclic errors). Per design and family:

* **unchanged**: the share of pairs with any function flagged
  (:func:`volcal.history.compare.compare_models`, family-wise level 5 %) and whether it
  lies within the binomial band (at most the 95 % quantile of Binomial(n, level));
* **changed** (the later calibration's machine altered): X scale +10 um/m (EXX),
  squareness EC0Y +20 urad, a 5 um straightness bow of Y along X (EYX, zero at both
  ends): the share of pairs where the changed function is flagged (detection rate),
  where another function is flagged, and where the changed function is left undecided
  because its difference lies in combinations the design does not determine ("cannot
  tell": the test never calls it unchanged there).

    .venv/bin/python benchmarks/history_study.py --pairs 40            # the full study
    .venv/bin/python benchmarks/history_study.py --pairs 4 --power-pairs 4   # quick
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

TRAVEL = [[0, 800], [0, 600], [0, 500]]
STEPS = (4, 6, 10, 20)
RUNS = (1, 2, 5)
GENERATORS = ("volcal", "b", "d")
CHANGES = {"X scale +10 um/m": "EXX", "EC0Y +20 urad": "EC0Y", "EYX bow 5 um": "EYX"}
LEVEL = 0.05


def machine(generator: str, seed: int):
    """An unchanged machine of a generator (MachineErrors)."""
    if generator == "volcal":
        from volcal.measure.virtual import random_machine

        return random_machine(TRAVEL, "XYFZ", seed=seed)
    from families import FAMILIES

    am = FAMILIES[generator].draw(np.random.default_rng(seed), np.array(TRAVEL, float),
                                  "XYFZ")
    return am.tabulate()


def changed(m, target: str):
    """The machine with one change (:data:`CHANGES`)."""
    out = m.copy()
    x = out.nodes[0]
    if target == "EXX":
        out.values[0][:, 0] += 0.010 * (x - x[0])          # 10 um/m [um]
    elif target == "EC0Y":
        out.squareness[0] += 20.0                          # [urad]
    elif target == "EYX":
        s = (x - x[0]) / (x[-1] - x[0])
        out.values[0][:, 1] += 5.0 * 4.0 * s * (1.0 - s)   # 5 um bow, 0 at the ends
    return out


def identify(m, steps: int, runs: int, seed: int):
    """Plan, simulate (noise and set-up of ``seed``) and identify."""
    from volcal.flow import Calibration

    c = Calibration.plan(TRAVEL, steps=steps, runs=runs)
    c.simulate(machine=m, seed=seed)
    return c.identify()


CANNOT_TELL = "this design cannot tell"
"""The reason of an entry left undecided because its difference lies in the combinations
the design does not determine (:func:`volcal.history.compare._function_entries`)."""


def verdicts(m1, m2) -> tuple[list[str], list[str]]:
    """Functions the change test flags; functions it leaves undecided because the design
    cannot tell (never ``unchanged`` there)."""
    from volcal.history.compare import compare_models

    es = compare_models(m1, m2, LEVEL)
    return ([e.name for e in es if e.changed],
            [e.name for e in es if e.changed is None and CANNOT_TELL in e.reason])


def flagged(m1, m2) -> list[str]:
    """Functions the change test flags."""
    return verdicts(m1, m2)[0]


def band(n: int) -> int:
    """Largest count of pairs with a flag within the binomial band of the level."""
    from scipy.stats import binom

    return int(binom.ppf(0.95, n, LEVEL))


def study(pairs: int, power_pairs: int, steps=STEPS, runs=RUNS, generators=GENERATORS,
          power_designs=((6, 2), (10, 5))) -> list[dict]:
    """Rows of the study (one per design, generator and case)."""
    rows = []
    for st in steps:
        for ru in runs:
            for g in generators:
                gi = GENERATORS.index(g)  # the seeds of a generator whatever others run
                t0 = time.perf_counter()
                n_any = n_und = 0
                power = {c: [0, 0, 0] for c in CHANGES}
                n_pow = power_pairs if (st, ru) in power_designs else 0
                for k in range(max(pairs, n_pow)):
                    seed = 100_000 * gi + 1000 * st + 100 * ru + k
                    m = machine(g, 500 + k + 10_000 * gi)
                    first = identify(m, st, ru, 2 * seed)
                    if k < pairs:
                        f, und = verdicts(first, identify(m, st, ru, 2 * seed + 1))
                        n_any += bool(f)
                        n_und += bool(und)
                    if k < n_pow:
                        for case, target in CHANGES.items():
                            f, und = verdicts(first, identify(changed(m, target), st, ru,
                                                              2 * seed + 1))
                            power[case][0] += target in f
                            power[case][1] += any(x != target for x in f)
                            power[case][2] += target in und
                row = {"steps": st, "runs": ru, "generator": g, "pairs": pairs,
                       "unchanged_flagged": n_any, "unchanged_undecided": n_und,
                       "band": band(pairs),
                       "within": n_any <= band(pairs), "power_pairs": n_pow,
                       "power": power, "seconds": time.perf_counter() - t0}
                rows.append(row)
                _print(row)
    return rows


def _print(r: dict) -> None:
    s = (f"| {r['steps']} | {r['runs']} | {r['generator']} | {r['unchanged_flagged']} of "
         f"{r['pairs']} | {'yes' if r['within'] else 'NO'} (<= {r['band']}) | "
         f"{r['unchanged_undecided']} |")
    if r["power_pairs"]:
        s += " " + "; ".join(f"{c}: {h}/{r['power_pairs']} (other {o}, cannot tell {u})"
                             for c, (h, o, u) in r["power"].items())
    else:
        s += " -"
    print(s + f" | {r['seconds']:.0f} s |", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", "--machines", type=int, default=40,
                    help="unchanged pairs per design and generator (--machines: as before)")
    ap.add_argument("--power-pairs", type=int, default=20,
                    help="changed pairs per case on the power designs (6x2, 10x5)")
    ap.add_argument("--steps", default=",".join(map(str, STEPS)))
    ap.add_argument("--runs", default=",".join(map(str, RUNS)))
    ap.add_argument("--generators", default=",".join(GENERATORS))
    ap.add_argument("--power-designs", default="6x2,10x5",
                    help="designs (increments x runs) of the changed pairs")
    a = ap.parse_args(argv)
    power = tuple(tuple(int(v) for v in d.split("x")) for d in a.power_designs.split(","))
    print("| increments | runs | generator | unchanged pairs flagged | within band | "
          "unchanged pairs with an entry the design cannot tell | "
          "changed flagged (detection) | time |")
    print("|---|---|---|---|---|---|---|---|")
    study(a.pairs, a.power_pairs, tuple(int(x) for x in a.steps.split(",")),
          tuple(int(x) for x in a.runs.split(",")), tuple(a.generators.split(",")), power)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
