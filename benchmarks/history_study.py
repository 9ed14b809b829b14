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
    .venv/bin/python benchmarks/history_study.py --detectability   # what the test sees
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


TRUE_SIZE = {"EXX": 8.0, "EC0Y": 20.0, "EYX": 5.0}
"""Largest true change of each case [um, urad] (:func:`changed`; EXX at x = 800 mm)."""


def signal(m1, m2, m3, name: str) -> dict:
    """What the change test sees of a change: the identifiability of the difference.

    ``m1``, ``m2`` an unchanged pair, ``m3`` the later calibration of the changed machine
    with ``m2``'s noise and set-up: ``m3 - m2`` is the change as the estimator sees it
    (the noise cancels). Returned: ``seen`` (its largest size at the nodes over the true
    one: the share the design and prior let through), ``r`` and ``lambda`` (the tested
    combinations and the noncentrality of the test statistic over them,
    :func:`volcal.history.compare._split_statistic` of the signal), ``threshold`` (the
    test's, from the unchanged pair) and ``power`` (the probability that the test flags
    it: non-central chi-square over ``threshold``).
    """
    from scipy.stats import ncx2

    from volcal.history.compare import (
        _full_cov,
        _interp_matrix,
        _split_statistic,
        compare_models,
        noise_covariance,
    )
    from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

    c1, c2 = noise_covariance(m1), noise_covariance(m2)
    if name in SQUARENESS_NAMES:
        j = SQUARENESS_NAMES.index(name)
        s1, s2 = m1.layout.squareness_indices(), m2.layout.squareness_indices()
        d = np.array([m3.theta[s2[j]] - m2.theta[s2[j]]])
        C = _full_cov(m1, s1[j:j + 1]) + _full_cov(m2, s2[j:j + 1])
        Cn = _full_cov(m1, s1[j:j + 1], c1) + _full_cov(m2, s2[j:j + 1], c2)
    else:
        k, c = divmod(COMPONENT_NAMES.index(name), 6)
        n1, n2 = m1.layout.nodes[k], m2.layout.nodes[k]
        q = n1[(n1 >= max(n1[0], n2[0]) - 1e-9) & (n1 <= min(n1[-1], n2[-1]) + 1e-9)]
        P1, P2 = _interp_matrix(n1, q), _interp_matrix(n2, q)
        i1, i2 = m1.layout.indices(k, c), m2.layout.indices(k, c)
        d = P2 @ (m3.theta[i2] - m2.theta[i2])
        C = P1 @ _full_cov(m1, i1) @ P1.T + P2 @ _full_cov(m2, i2) @ P2.T
        Cn = P1 @ _full_cov(m1, i1, c1) @ P1.T + P2 @ _full_cov(m2, i2, c2) @ P2.T
    r, lam, r_rest, lam_rest = _split_statistic(d, C, Cn)
    e = next(x for x in compare_models(m1, m2, LEVEL) if x.name == name)
    thr = e.threshold
    power = float(ncx2.sf(thr, r, max(lam, 1e-12))) if r and thr is not None else 0.0
    return {"seen": float(np.abs(d).max()) / TRUE_SIZE[name], "r": r, "lambda": lam,
            "r_rest": r_rest, "lambda_rest": lam_rest, "threshold": thr, "power": power,
            "U": e.U, "verdict_unchanged_pair": e.verdict}


def detectability(steps=STEPS, runs=RUNS, generator: str = "volcal", seed: int = 500
                  ) -> list[dict]:
    """:func:`signal` of each change on each design (one machine of ``generator``)."""
    rows = []
    gi = GENERATORS.index(generator)
    m = machine(generator, seed + 10_000 * gi)
    print("| increments | runs | change | seen of the true size | tested combinations | "
          "noncentrality | threshold | power | U of the difference (k=2) | "
          "noncentrality in the combinations not determined |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for st in steps:
        for ru in runs:
            s = 2 * (100_000 * gi + 1000 * st + 100 * ru)
            first, second = identify(m, st, ru, s), identify(m, st, ru, s + 1)
            for case, target in CHANGES.items():
                row = {"steps": st, "runs": ru, "case": case,
                       **signal(first, second, identify(changed(m, target), st, ru, s + 1),
                                target)}
                rows.append(row)
                print(f"| {st} | {ru} | {case} | {row['seen']:.2f} | {row['r']} | "
                      f"{row['lambda']:.1f} | {row['threshold']:.1f} | {row['power']:.2f} | "
                      f"{row['U']:.2f} | {row['lambda_rest']:.1f} over {row['r_rest']} |",
                      flush=True)
    return rows


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
    ap.add_argument("--detectability", action="store_true",
                    help="what the test sees of each change on each design (one machine)")
    a = ap.parse_args(argv)
    if a.detectability:
        detectability(tuple(int(x) for x in a.steps.split(",")),
                      tuple(int(x) for x in a.runs.split(",")))
        return 0
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
