"""Study of the R-test fused with the laser model of the same machine (issue 28, item 3).

For each of ``--machines`` virtual machines (linear errors of
:func:`volcal.measure.virtual.random_machine`, hidden location errors within +-2 mm and
+-200 urad, the sphere within +-1 mm): one session with the laser tests (step diagonals,
diagonals, linear) and the R-test of ``volcal plan --tests r_test`` (trunnion ``CAXYFZ``,
noise 0.5 um), simulated; ``volcal identify`` on the laser tests gives the linear model with
its covariance; ``locate`` runs without a linear model, with the model as a prior
(``model=``), and with the machine's true linear errors (the limit: the linear axes known
exactly). The reference of each determined error is what the R-test determines of the
hidden machine (the fit to its exact readings with its true linear errors).

Figures per variant: coverage of the 2u interval, largest |z|, mean z^2 (the mean squared
error over volcal's stated variance: 1 when the stated U is right), and the mean U over the
U with the true linear errors (what the linear model's uncertainty costs).

Run: ``python benchmarks/fiveaxis_fusion_study.py --machines 20`` (``make study``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from volcal.identify.location import identify_location  # noqa: E402
from volcal.kinds import kind_of  # noqa: E402
from volcal.kinds.probe_sphere import five_axis_machine  # noqa: E402
from volcal.kinds.r_test import rtest_readings_block  # noqa: E402
from volcal.measure.simulate import SimulationOptions, simulate_session  # noqa: E402
from volcal.measure.virtual import random_machine  # noqa: E402
from volcal.plan.planner import plan_session  # noqa: E402
from volcal.session.format import Measurement, Session  # noqa: E402
from volcal.steps.identify import identify  # noqa: E402
from volcal.steps.locate import locate  # noqa: E402

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
LASER = ("step-diagonal", "diagonal", "linear")
"""The laser tests of the default design (``--laser`` replaces them)."""


def _reference(m, machine, setup) -> dict[str, float]:
    exact = kind_of("r_test").exact(machine, m, setup)
    c = Measurement(m.id, m.kind, m.target, m.positions, np.linalg.norm(exact, axis=1),
                    m.beam_direction, m.tool_offset, m.file,
                    {**m.columns, "dx_um": exact[:, 0], "dy_um": exact[:, 1],
                     "dz_um": exact[:, 2]}, m.meta)
    return identify_location(five_axis_machine(c, machine), [rtest_readings_block(c)]).estimate


def run(machines: int, seed: int = 0, laser: tuple[str, ...] = LASER
        ) -> list[dict[str, object]]:
    """The study's rows: one per variant (no linear model, the model, the true errors)."""
    z: dict[str, list[float]] = {"none": [], "model": [], "truth": []}
    u: dict[str, list[float]] = {"none": [], "model": [], "truth": []}
    for i in range(machines):
        s = plan_session(TRAVEL, "XYFZ", steps=4, tests=laser + ("r_test",), runs=2)
        machine = random_machine(TRAVEL, "XYFZ", seed=seed + i)
        setups = simulate_session(s, machine, SimulationOptions(seed=1000 + seed + i))
        tests = Session(s.name, s.chain, s.travel,
                        [m for m in s.measurements if m.kind != "r_test"], s.meta)
        model = identify(tests).result
        m = next(m for m in s.measurements if m.kind == "r_test")
        ref = _reference(m, machine, setups["r_test"])
        for key, lin in (("none", None), ("model", model), ("truth", machine)):
            r = locate(s, model=lin).result
            z[key] += [(r.estimate[n] - ref[n]) / r.u[n] for n in r.names]
            u[key] += [r.u[n] for n in r.names]
    rows = []
    ut = np.array(u["truth"])
    for key, label in (("none", "no linear model (perfect axes)"),
                       ("model", "laser model with its covariance"),
                       ("truth", "true linear errors (the limit)")):
        za = np.abs(np.array(z[key]))
        rows.append({"variant": label, "machines": machines, "errors": za.size,
                     "coverage_2u": float(np.mean(za < 2.0)), "max_abs_z": float(za.max()),
                     "mean_z2": float(np.mean(za**2)),
                     "u_over_limit": float(np.mean(np.array(u[key]) / ut))})
    return rows


def main(argv: list[str] | None = None) -> int:
    """Run the study and print its table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--machines", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--laser", default=",".join(LASER),
                    help="the laser tests of volcal plan --tests (add direct: the rolls)")
    args = ap.parse_args(argv)
    print("| linear axes | machines | errors | within 2u | max abs z | mean z^2 | U / U(true "
          "linear) |")
    print("|---|---|---|---|---|---|---|")
    for r in run(args.machines, args.seed, tuple(args.laser.split(","))):
        print(f"| {r['variant']} | {r['machines']} | {r['errors']} | {r['coverage_2u']:.3f} | "
              f"{r['max_abs_z']:.2f} | {r['mean_z2']:.2f} | {r['u_over_limit']:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
