"""Study of the 5-axis location-error identification (issue 28): coverage and the limit.

For each chain type (trunnion AC ``CAFXYZ`` and BC ``CBFXYZ``, table-head ``CFXYZB``,
head-head ``FXYZCA``) and each design (probe-on-sphere and R-test on the 6 x 5 pose grid;
the R-test's paths of ``volcal plan --tests r_test``, ``rtest_paths``), ``--machines``
virtual machines with random location errors (positions of the axis lines within +-2 mm,
orientations and zeros within +-200 urad), a sphere placed 1 mm off its nominal centre and
1 um of probe noise on every reading component. For each machine:

* the estimate of each determined error is compared with what the design determines of
  the truth (the fit to the same machine's exact readings): coverage of the 2u interval;
* the limit: the Cramér-Rao bound of the gauge-fixed problem (the inverse Fisher
  information at the truth, which for Gaussian noise and flat priors is what no unbiased
  estimator beats); volcal's ratio is the mean over errors and machines of the squared
  error over the bound (1 = efficient);
* what the identifiability report names undetermined is checked against the truth: the
  first-order combinations it names reproduce the exact fit (largest difference, from the
  second-order terms of 2 mm x 200 urad).

Run: ``python benchmarks/fiveaxis_study.py --machines 20 --markdown`` (``make study``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from volcal.identify.location import design_jacobian, identify_location  # noqa: E402
from volcal.measure.fiveaxis_virtual import nominal_machine, pose_grid, random_location  # noqa: E402
from volcal.measure.spheres import SphereReadings, probe_centres, simulate_blocks  # noqa: E402
from volcal.model.fiveaxis import location_parameter_names  # noqa: E402

MACHINES = {
    "CAFXYZ": ({"C": [0, 0, 0], "A": [0, 0, -120]}, [150.0, 0.0, 40.0], [0.0, 0.0, 0.0]),
    "CBFXYZ": ({"C": [0, 0, 0], "B": [0, 0, -120]}, [0.0, 150.0, 40.0], [0.0, 0.0, 0.0]),
    "CFXYZB": ({"C": [0, 0, 0], "B": [0, 0, 300]}, [150.0, 0.0, 40.0], [0.0, 0.0, 0.0]),
    "FXYZCA": ({"C": [0, 0, 450], "A": [0, 0, 300]}, [100.0, 50.0, 0.0], [0.0, 0.0, 0.0]),
}
"""Chain -> nominal pivots [mm], nominal sphere centre [mm], probe tip offset [mm]."""


def design(code: str, kind: str, noise_um: float = 1.0):
    """The nominal machine and the design's readings (values to be simulated).

    ``kind``: ``probe`` or ``rtest`` on the pose grid; ``rtest_paths`` the R-test's paths
    of ``volcal plan --tests r_test`` (C turning a full circle in 30 deg steps at the other
    axis' 0, -45 and -90 deg, then the other axis sweeping -90..90 deg at C = 0; ISO
    10791-6, Ibaraki et al. 2010); ``rtest_c`` C turning at the other axis' 0 only.
    """
    from volcal.kinds.r_test import rtest_paths

    pivots, sphere, tool = MACHINES[code]
    nominal = nominal_machine(code, pivots)
    if kind.startswith("rtest_"):
        other = next(r for r in nominal.chain_obj.rotary if r != "C")
        ang = rtest_paths("c" + other.lower())
        if kind == "rtest_c":
            ang = {r: a[:12] for r, a in ang.items()}
    else:
        ang = pose_grid(code)
    m = ang[next(iter(ang))].size
    reading = "probe" if kind == "probe" else "rtest"
    q = probe_centres(nominal, ang, sphere, tool) if reading == "rtest" else None
    return nominal, [SphereReadings("m1", reading, ang, np.zeros((m, 3)), "S1", np.array(sphere),
                                    np.array(tool), q, noise_um)]


def run(code: str, kind: str, machines: int, seed: int = 0) -> dict[str, object]:
    """Study one chain and kind; the figures of one row of the table."""
    rng = np.random.default_rng(seed)
    nominal, blocks = design(code, kind)
    names = location_parameter_names(code)
    z, ratio, gauge_gap = [], [], 0.0
    fixed: tuple[str, ...] = ()
    for _ in range(machines):
        truth = random_location(code, rng)
        true_m = nominal.with_location([truth[n] for n in names])
        sphere = np.array(MACHINES[code][1]) + rng.uniform(-1, 1, 3)
        res = identify_location(nominal, simulate_blocks(true_m, blocks, {"S1": sphere}, rng))
        exact = identify_location(nominal, simulate_blocks(true_m, blocks, {"S1": sphere}, rng,
                                                           noise_scale=0.0))
        ident = res.identifiability
        fixed = ident.fixed
        lin = ident.gauge_truth(truth)
        gauge_gap = max([gauge_gap] + [abs(exact.estimate[n] - lin[n]) for n in res.names])
        # Cramér-Rao bound at the truth (gauge fixed: the determined errors and nuisances)
        m_true = exact.machine
        Jx, Jn, _, _, _ = design_jacobian(m_true, blocks, exact.nuisances)
        free = [names.index(n) for n in ident.free]
        scale = np.array([1e3 if ":s" in k else 1.0 for k in exact.nuisances])
        A = np.column_stack([Jx[:, free], Jn / scale])
        crb = np.diag(np.linalg.pinv(A.T @ A, hermitian=True))[:len(free)]
        for i, n in enumerate(res.names):
            err = res.estimate[n] - exact.estimate[n]
            z.append(err / res.u[n])
            ratio.append(err**2 / crb[i])
    za = np.abs(np.array(z))
    nan = float("nan")  # a design that determines nothing
    return {"chain": code, "kind": kind, "machines": machines, "determined": len(res.names),
            "undetermined": ", ".join(fixed),
            "coverage_2u": float(np.mean(za < 2.0)) if za.size else nan,
            "max_abs_z": float(za.max()) if za.size else nan,
            "mse_over_crb": float(np.mean(ratio)) if ratio else nan, "gauge_gap": gauge_gap}


def main(argv: list[str] | None = None) -> int:
    """Run the study and print its table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--machines", type=int, default=20)
    ap.add_argument("--kinds", default="probe,rtest,rtest_paths")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    rows = [run(code, kind, args.machines, seed=i)
            for kind in args.kinds.split(",") for i, code in enumerate(MACHINES)]
    head = ("| chain | readings | machines | determined | held at zero (redundant) | "
            "within 2u | max abs z | MSE / CRB | first-order gap |")
    print(head)
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['chain']} | {r['kind']} | {r['machines']} | {r['determined']} | "
              f"{r['undetermined']} | {r['coverage_2u']:.3f} | {r['max_abs_z']:.2f} | "
              f"{r['mse_over_crb']:.2f} | {r['gauge_gap']:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
