"""Where volcal's excess over the limit lies, function by function (issue 30, session 23).

For each machine of a :mod:`travel_study` family, travel and the full test set: volcal's
estimate, the limit's (:func:`travel_study.exact_limit`) and the gauge-mapped truth, all
tabulated on the truth's fine nodes. Per function (the 18 component errors and the three
squareness errors):

``swap``
    the squared volumetric error [um^2] volcal loses against the limit in that function
    alone: ``RMS^2(volcal) - RMS^2(volcal with that function replaced by the limit's)``
    (rigid-body motion removed, the study's 9 x 9 x 9 grid, or ``--grid 11``: the
    readings' positions); positive: the limit does better on it. Summed over the
    functions it need not equal the total excess (cross terms), which is printed beside
    it.
``err``
    RMS of volcal's and the limit's function error over the nodes [um, urad];
``z``
    RMS of volcal's error over its standard uncertainty at the interior nodes (about 1
    for honest uncertainties, 0.5: intervals twice too wide).

With ``--cut-modes``, also the limits of priors whose modes stop elsewhere
(:func:`cut_limit`). Also each machine's hyperparameters (group scales, kappa, travel
exponents, the rolls' log Bayes factor and probability). Command line::

    python benchmarks/travel_excess.py --family len0 --travel t6000 --machines 8
    python benchmarks/travel_excess.py --family rel0 --travel t800 --cut-modes 6,10,12,16
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import exact_sim  # noqa: E402
import families  # noqa: E402
import travel_study as ts  # noqa: E402

from volcal.identify import IdentifyOptions, identify  # noqa: E402
from volcal.model.errorfunctions import COMPONENT_NAMES, SQUARENESS_NAMES, MachineErrors  # noqa: E402
from volcal.model.kinematics import volumetric_error  # noqa: E402
from volcal.model.rigid import remove_rigid_body  # noqa: E402
from volcal.standards.volumetric import work_zone_grid  # noqa: E402

NAMES = [*COMPONENT_NAMES, *SQUARENESS_NAMES]


def _on(m: MachineErrors, nodes, chain) -> MachineErrors:
    """``m`` tabulated on ``nodes`` (its own interpolation)."""
    vals = [np.column_stack([m.function(COMPONENT_NAMES[6 * k + c], nodes[k])
                             for c in range(6)]) for k in range(3)]
    return MachineErrors(chain, [n.copy() for n in nodes], vals, m.squareness.copy())


def _swap(a: MachineErrors, b: MachineErrors, name: str) -> MachineErrors:
    """``a`` with function ``name`` taken from ``b`` (same nodes)."""
    vals = [v.copy() for v in a.values]
    sq = a.squareness.copy()
    if name in SQUARENESS_NAMES:
        i = SQUARENESS_NAMES.index(name)
        sq[i] = b.squareness[i]
    else:
        j = COMPONENT_NAMES.index(name)
        vals[j // 6][:, j % 6] = b.values[j // 6][:, j % 6]
    return MachineErrors(a.chain, [n.copy() for n in a.nodes], vals, sq)


def _ms(m: MachineErrors, truth: MachineErrors, q) -> float:
    d = remove_rigid_body(q, volumetric_error(m, q) - volumetric_error(truth, q))
    return float(np.mean(np.sum(d**2, axis=1)))


def machine(fam_key: str, travel_key: str, case: ts.Case, limit, options=None,
            n_grid: int = 9, other_limits: dict | None = None) -> dict:
    """The decomposition of one machine (full test set).

    ``other_limits``: ``{J: limit}`` of priors cut after mode ``J`` (:func:`cut_limit`),
    whose RMS on the same readings is ``rms_limit_modes[J]``.
    """
    fam = ts.FAMILIES[fam_key]
    travel = np.array(ts.TRAVELS[travel_key])
    am = fam.draw(np.random.default_rng(case.machine_seed), travel, case.chain)
    session = ts.session_for(travel, case.chain, "full")
    exact_sim.simulate(session, ts.to_sim(am), case.sim_seed)
    truth = families.gauge_map(am.tabulate())
    q = work_zone_grid(travel, n_grid)
    o = options or IdentifyOptions(suggest=False)
    rb = identify(session, o)
    y = np.concatenate([m.deviation for m in session.measurements])
    nodes = truth.nodes
    est = _on(rb.errors, nodes, case.chain)
    lim = _on(limit.estimate(y), nodes, case.chain)
    ms_v, ms_l = _ms(est, truth, q), _ms(lim, truth, q)
    out = {"case": case.index, "chain": case.chain, "rms_volcal": ms_v**0.5,
           "rms_limit": ms_l**0.5, "swap": {}, "err_volcal": {}, "err_limit": {}, "z": {},
           "rms_limit_modes": {j: _ms(_on(lj.estimate(y), nodes, case.chain), truth, q) ** 0.5
                               for j, lj in (other_limits or {}).items()}}
    for name in NAMES:
        out["swap"][name] = ms_v - _ms(_swap(est, lim, name), truth, q)
        if name in SQUARENESS_NAMES:
            i = SQUARENESS_NAMES.index(name)
            ev = est.squareness[i] - truth.squareness[i]
            el = lim.squareness[i] - truth.squareness[i]
            out["err_volcal"][name], out["err_limit"][name] = abs(ev), abs(el)
            sd = float(rb.function_std(name, np.zeros(1))[0])
            out["z"][name] = abs(ev) / max(sd, 1e-12)
            continue
        k = COMPONENT_NAMES.index(name) // 6
        x = nodes[k]
        t = truth.function(name, x)
        out["err_volcal"][name] = float(np.sqrt(np.mean((est.function(name, x) - t) ** 2)))
        out["err_limit"][name] = float(np.sqrt(np.mean((lim.function(name, x) - t) ** 2)))
        xr = rb.layout.nodes[k][1:-1]
        d = rb.errors.function(name, xr) - truth.function(name, xr)
        sd = rb.function_std(name, xr)
        ok = sd > 1e-9
        out["z"][name] = float(np.sqrt(np.mean((d[ok] / sd[ok]) ** 2))) if ok.any() else np.nan
    ps = rb.fit["prior_scales"]
    rp = rb.fit["roll_presence"] or {}
    out["hyper"] = {k: ps[k] for k in ("positioning_um", "straightness_um", "roll_urad",
                                       "tilt_urad", "kappa", "travel_exponent",
                                       "kappa_travel_exponent", "positioning_trend_um_per_m",
                                       "tilt_trend_urad", "positioning_nugget_um")}
    out["hyper"].update(sigma_um=float(rb.fit["sigma_um"]),
                        roll_lbf=rp.get("log_bayes_factor"), p_roll=rp.get("probability"),
                        p_roll_cov=rp.get("uncertainty_weight"))
    return out


def cut_limit(modes: int, rolls: bool, travel, chain: str, session):
    """The best linear estimator for a prior of ``rel``'s modes cut after mode ``modes``.

    :func:`travel_study.exact_limit` of the ``fine`` family with
    :data:`travel_study.FINE_MODES` set to ``modes`` (variance ``1 / j``, no growth with
    the travel): how much the limit owes to knowing where the family's spectrum stops.
    """
    keep = ts.FINE_MODES
    ts.FINE_MODES = int(modes)
    try:
        return ts.exact_limit("fine", rolls, travel, chain, session)
    finally:
        ts.FINE_MODES = keep


def run(fam_key: str, travel_key: str, n: int, first: int = 0, options=None,
        n_grid: int = 9, cut_modes: tuple[int, ...] = ()) -> list[dict]:
    """Machines ``first .. n - 1`` (``cut_modes``: the limits of :func:`cut_limit` too)."""
    travel = np.array(ts.TRAVELS[travel_key])
    rolls = not fam_key.endswith("0")
    limits: dict = {}
    others: dict = {}
    out = []
    for case in ts.cases(n)[first:]:
        if case.chain not in limits:
            sess = ts.session_for(travel, case.chain, "full")
            limits[case.chain] = ts.exact_limit(fam_key.rstrip("0"), rolls, travel, case.chain,
                                                sess, options)
            others[case.chain] = {j: cut_limit(j, rolls, travel, case.chain, sess)
                                  for j in cut_modes}
        r = machine(fam_key, travel_key, case, limits[case.chain], options, n_grid,
                    others[case.chain])
        h = r["hyper"]
        print(f"{fam_key} {travel_key} #{case.index} {case.chain} volcal {r['rms_volcal']:.3f} "
              f"limit {r['rms_limit']:.3f} ratio {r['rms_volcal'] / r['rms_limit']:.2f} "
              f"scales {h['positioning_um']:.2f}/{h['straightness_um']:.2f}/"
              f"{h['roll_urad']:.2f}/{h['tilt_urad']:.2f} kappa {h['kappa']:.2f} "
              f"texp {h['travel_exponent']} ktexp {h['kappa_travel_exponent']} "
              f"lbf {h['roll_lbf']} P {h['p_roll']} P' {h['p_roll_cov']}", flush=True)
        out.append(r)
    return out


def table(rows: list[dict]) -> str:
    """Per function: mean swap [um^2], its share of the mean excess, errors, z."""
    excess = np.mean([r["rms_volcal"] ** 2 - r["rms_limit"] ** 2 for r in rows])
    ms_v = np.mean([r["rms_volcal"] ** 2 for r in rows])
    ms_l = np.mean([r["rms_limit"] ** 2 for r in rows])
    lines = [f"mean excess RMS^2 {excess:.3f} um^2 (volcal {ms_v:.3f}, limit {ms_l:.3f}); "
             "sum of swaps "
             f"{np.mean([sum(r['swap'].values()) for r in rows]):.3f}",
             "| function | swap [um^2] | share | err volcal | err limit | z volcal |",
             "|---|---|---|---|---|---|"]
    for j in reversed(list(rows[0]["rms_limit_modes"])):
        lines.insert(1, f"prior cut after mode {j}: median RMS "
                     f"{np.median([r['rms_limit_modes'][j] for r in rows]):.3f} um, ratio to "
                     "the limit "
                     f"{np.median([r['rms_limit_modes'][j] / r['rms_limit'] for r in rows]):.2f}")
    order = sorted(NAMES, key=lambda n: -np.mean([r["swap"][n] for r in rows]))
    for name in order:
        s = np.mean([r["swap"][name] for r in rows])
        lines.append(f"| {name} | {s:.3f} | {s / excess:.2f} | "
                     f"{np.mean([r['err_volcal'][name] for r in rows]):.2f} | "
                     f"{np.mean([r['err_limit'][name] for r in rows]):.2f} | "
                     f"{np.sqrt(np.nanmean([r['z'][name]**2 for r in rows])):.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Command line (``--help``)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--family", default="len0")
    p.add_argument("--travel", default="t6000")
    p.add_argument("--machines", type=int, default=8)
    p.add_argument("--first", type=int, default=0)
    p.add_argument("--settings", default="", help="EstimatorSettings fields as JSON")
    p.add_argument("--roll", default=None, help="IdentifyOptions.roll (e.g. zero)")
    p.add_argument("--grid", type=int, default=9,
                   help="points per axis of the grid (11: at the readings of 10 increments)")
    p.add_argument("--cut-modes", default="",
                   help="comma-separated J: also the limits of priors cut after mode J")
    p.add_argument("--json", type=Path)
    a = p.parse_args(argv)
    o = ts.with_settings(IdentifyOptions(suggest=False), a.settings)
    if a.roll:
        o = replace(o, roll=a.roll)
    cut = tuple(int(j) for j in a.cut_modes.split(",") if j)
    rows = run(a.family, a.travel, a.machines, a.first, o, a.grid, cut)
    print(table(rows))
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
