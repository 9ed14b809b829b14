"""Coverage of U of the model's volumetric indices, straightness and squareness.

Simulated machines whose readings carry wavelength, air (per set-up) and material (per
axis) errors drawn from a budget, identified with the budget's systematic part attached;
for every index the truth is checked against ``value +- U``
(:mod:`volcal.standards.model_uncertainty`). Prints the coverage per index family, with
and without the systematic part.

    python benchmarks/model_uncertainty_coverage.py [--machines 12] [--draws 300]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "identify"))


def main() -> None:
    """Run the study and print a markdown table."""
    from identify_helpers import TRAVEL, exact_fill, seeds_session

    from volcal.identify import IdentifyOptions, identify
    from volcal.identify.systematic import attach_systematic
    from volcal.measure.systematic import apply_systematic, draw_systematic
    from volcal.measure.virtual import random_machine
    from volcal.standards.model_uncertainty import (
        VOLUMETRIC_KEYS,
        model_uncertainty,
        straightness_functions,
    )
    from volcal.standards.straightness import straightness
    from volcal.standards.volumetric import volumetric_indices
    from volcal.uncertainty.budget import parse_budget

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--machines", type=int, default=12)
    ap.add_argument("--draws", type=int, default=300)
    a = ap.parse_args()
    b = parse_budget({
        "laser": {"u_wavelength_ppm": 1.0},
        "air": {"temperature_c": 20.0, "pressure_pa": 101325.0, "humidity_pct": 50.0,
                "u_temperature_k": 0.5, "u_pressure_pa": 100.0, "u_humidity_pct": 5.0},
        "material": {"temperature_c": 22.0, "u_temperature_k": 0.3,
                     "expansion_ppm_per_k": 11.5, "u_expansion_ppm_per_k": 1.0},
        "setup": {"u_misalignment_urad": 0.0, "dead_path_mm": 0.0}})
    s = seeds_session("XYFZ", steps=6, runs=2)
    hits: dict[str, list[bool]] = {"volumetric": [], "straightness": [], "squareness": []}
    hits_noise: dict[str, list[bool]] = {k: [] for k in hits}
    for seed in range(a.machines):
        truth = random_machine(TRAVEL, "XYFZ", seed=300 + seed)
        exact_fill(s, truth, seed=seed, noise_um=0.3)
        apply_systematic(s, draw_systematic(s, b, np.random.default_rng(seed)))
        r = attach_systematic(identify(s, IdentifyOptions(suggest=False)), b)
        mu = model_uncertainty(r, draws=a.draws)
        ti = volumetric_indices(truth)
        for k in VOLUMETRIC_KEYS:
            e = mu.volumetric[k]
            err = abs(e.value - getattr(ti, k))
            hits["volumetric"].append(err <= e.U)
            hits_noise["volumetric"].append(err <= 2 * e.u_noise)
        for k, _c, name in straightness_functions():
            x = np.linspace(*truth.travel[k], 101)
            want = straightness(x, truth.function(name, x)).straightness_um
            e = mu.straightness[name]
            hits["straightness"].append(abs(e.value - want) <= e.U)
            hits_noise["straightness"].append(abs(e.value - want) <= 2 * e.u_noise)
        for i, name in enumerate(("EC0Y", "EB0Z", "EA0Z")):
            e = mu.squareness[name]
            hits["squareness"].append(abs(e.value - truth.squareness[i]) <= e.U)
            hits_noise["squareness"].append(abs(e.value - truth.squareness[i])
                                            <= 2 * e.u_noise)
        print(f"machine {seed}: done", file=sys.stderr)
    print(f"{a.machines} machines, {a.draws} draws\n")
    print("| indices | checks | coverage of +- U | noise part only |")
    print("|---|---|---|---|")
    for k in hits:
        print(f"| {k} | {len(hits[k])} | {np.mean(hits[k]):.3f} | "
              f"{np.mean(hits_noise[k]):.3f} |")


if __name__ == "__main__":
    main()
