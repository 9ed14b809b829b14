"""Direct optics on random machines with roll: the direct set, the seeds, the seeds + optics.

For each machine (``random_machine``, every angular error drawn, rolls included) and each
design, simulate exactly (set-up errors and noise of ``volcal.measure.optics_simulate``),
identify, and record the volumetric residual (RMS over the measured grid, rigid-body
motion removed) and the coverage of the 95 % intervals of the three rolls (20 points per
roll, the gauge start excluded) and of the squareness. Run::

    .venv/bin/python benchmarks/optics_study.py --machines 20 --chain XYFZ

Designs: ``direct`` (``plan --tests direct``), ``seeds`` (4 step diagonals, 4 body
diagonals, 3 lines per axis, 2 runs), ``fused`` (seeds + a level on X and on Y + Z's
straightness along X at two tool offsets in one reference group).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from volcal.identify import IdentifyOptions, identify
from volcal.identify.design import choose_nodes
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.kinematics import volumetric_error
from volcal.model.rigid import remove_rigid_body
from volcal.plan.planner import plan_session
from volcal.session.format import Session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
ROLLS = ("EAX", "EBY", "ECZ")


def design(name: str, chain: str) -> Session:
    """The planned session of a design."""
    kw = {"iso_spacing": False, "linear_margin_mm": 0.0}
    direct = plan_session(TRAVEL, chain, 10, ("direct",), runs=1, **kw)
    if name == "direct":
        return direct
    seeds = plan_session(TRAVEL, chain, 10, ("step-diagonal", "diagonal", "linear"), runs=2, **kw)
    if name == "seeds":
        return seeds
    extra = [m for m in direct.measurements
             if m.id in ("lev-xa", "lev-yb", "str-zx", "str-zx-roll")]
    for m in extra:
        if m.kind == "straightness":
            m.meta["reference"] = "z-roll"
    return Session(seeds.name, chain, TRAVEL, seeds.measurements + extra)


def one(name: str, chain: str, seed: int) -> dict:
    """Identify one design on one machine."""
    truth = random_machine(TRAVEL, chain, seed=900 + seed)
    s = design(name, chain)
    simulate_session(s, truth, SimulationOptions(seed=seed))
    t0 = time.perf_counter()
    r = identify(s, IdentifyOptions(suggest=False))
    dt = time.perf_counter() - t0
    nodes = choose_nodes(s, refine=1)
    q = np.stack(np.meshgrid(*[n[::2] for n in nodes], indexing="ij"), -1).reshape(-1, 3)
    e, _ = r.predict(q)
    rms = float(np.sqrt(np.mean(remove_rigid_body(q, e - volumetric_error(truth, q)) ** 2)))
    hits, u = [], []
    for nm in ROLLS:
        k = "XYZ".index(nm[2])
        x = np.linspace(*TRAVEL[k], 21)[1:]
        sd = r.function_std(nm, x)
        hits.append(np.abs(r.errors.function(nm, x) - truth.function(nm, x)) <= 1.96 * sd)
        u.append(float(np.sqrt(np.mean(sd ** 2))))
    sq = [abs(r.errors.squareness[j] - truth.squareness[j])
          <= 1.96 * float(r.function_std(n, [0.0])[0])
          for j, n in enumerate(("EC0Y", "EB0Z", "EA0Z"))]
    return {"rms": rms, "roll_hits": np.concatenate(hits), "roll_u": u, "sq_hits": sq,
            "seconds": dt, "readings": int(sum(m.n for m in s.measurements))}


def main() -> None:
    """Run the study and print a markdown table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--machines", type=int, default=20)
    p.add_argument("--chain", default="XYFZ")
    a = p.parse_args()
    res = {d: [one(d, a.chain, i) for i in range(a.machines)]
           for d in ("seeds", "direct", "fused")}
    print(f"chain {a.chain}, {a.machines} machines\n")
    print("| design | readings | volumetric residual RMS [um] (median, max) | fused/seeds "
          "(median, max) | roll 95 % coverage | roll u RMS EAX, EBY, ECZ [urad] | "
          "squareness coverage | identify [s] (median) |")
    print("|---|---|---|---|---|---|---|---|")
    base = np.array([r["rms"] for r in res["seeds"]])
    for d, rs in res.items():
        rms = np.array([r["rms"] for r in rs])
        ratio = rms / base
        cov = np.mean(np.concatenate([r["roll_hits"] for r in rs]))
        u = np.mean([r["roll_u"] for r in rs], axis=0)
        sq = np.mean([h for r in rs for h in r["sq_hits"]])
        print(f"| {d} | {rs[0]['readings']} | {np.median(rms):.2f}, {rms.max():.2f} | "
              f"{np.median(ratio):.2f}, {ratio.max():.2f} | {cov:.3f} | "
              f"{u[0]:.1f}, {u[1]:.1f}, {u[2]:.1f} | {sq:.2f} | "
              f"{np.median([r['seconds'] for r in rs]):.2f} |")
    for d in ("direct", "fused"):
        ratio = np.array([r["rms"] for r in res[d]]) / base
        print(f"\n{d}: at most 0.8x the seeds' residual on {int(np.sum(ratio <= 0.8))} of "
              f"{ratio.size} machines (ratios above: "
              f"{', '.join(f'{v:.2f}' for v in np.sort(ratio[ratio > 0.8]))})")


if __name__ == "__main__":
    main()
