"""The rolls' two-model average with either covariance, per machine (issue 30 notebook).

For each machine of ``travel_study``'s families (``exact_sim``, the seeds' full set at 10
increments): the coverage of ``predict`` against the truth with
``EstimatorSettings.roll_mixture_covariance`` ``'roll'`` (volcal's default) and
``'mixture'``, the volumetric residual, and the rolls' log Bayes factor. One JSON line per
machine on standard output.

Usage::

    python benchmarks/roll_covariance_study.py rel0,mm0,rel,mm t800,t3000 10 > out.jsonl
"""

from __future__ import annotations

import json
import sys
import time

import families
import numpy as np
import travel_study as T

from volcal.identify.api import IdentifyOptions, identify
from volcal.identify.settings import EstimatorSettings


def main(argv: list[str]) -> None:
    """Run the families (comma-separated), travels (comma-separated), machines 0..n-1."""
    fam_keys, travels, n = argv[0].split(","), argv[1].split(","), int(argv[2])
    for fk in fam_keys:
        fam = T.FAMILIES[fk]
        for tk in travels:
            travel = np.array(T.TRAVELS[tk])
            for case in T.cases(n):
                am = fam.draw(np.random.default_rng(case.machine_seed), travel, case.chain)
                session = T.session_for(travel, case.chain, "full", 10, 5)
                T.exact_sim.simulate(session, T.to_sim(am), case.sim_seed)
                truth_g = families.gauge_map(am.tabulate())
                q = T.work_zone_grid(travel, 9)
                row: dict = {"family": fk, "travel": tk, "machine": case.machine_seed}
                for cov in ("roll", "mixture"):
                    o = IdentifyOptions(suggest=False, settings=EstimatorSettings(
                        roll_mixture_covariance=cov))
                    t0 = time.perf_counter()
                    r = identify(session, o)
                    ev = families.evaluate(r, truth_g, q)
                    fit = r.fit.to_dict() if hasattr(r.fit, "to_dict") else dict(r.fit)
                    row[cov] = {"coverage": ev["coverage"], "rms": ev["rms_um"],
                                "s": time.perf_counter() - t0}
                    row["roll_presence"] = fit.get("roll_presence")
                print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
