"""The estimator on short and long machines, read by an independent simulator (issue 30).

Families of machines whose error functions are random Fourier series
(:func:`exact_sim.fourier_function`), on three travels (:data:`TRAVELS`: 800 x 600 x 500,
3000 x 800 x 600 and 6000 x 1000 x 800 mm), read exactly by :mod:`exact_sim` (not by
volcal's simulator) and identified with the default estimator, minimum-norm least squares
(``prior='none'``) and the limit (the best linear estimator knowing the family's generator,
on volcal's own design matrix, with the family's exact prior covariance: :func:`exact_limit`).

Families (:data:`FAMILIES`; the first mode's standard deviation ``A``):

``rel`` / ``rel0``
    shape relative to the travel: modes of wavelength ``2 L / j``, ``j = 1..8`` (up to
    four undulations over the travel ``L``), standard deviation ``A / sqrt(j)``; the same
    functions in normalised position on every travel. ``rel0``: no roll.
``mm`` / ``mm0``
    shape per millimetre: the modes of wavelength ``2 L / j`` down to 1600 / 8 = 200 mm,
    standard deviation ``A sqrt(min(1, lambda / 1600 mm))``; on an 800 mm axis the law of ``rel``,
    on 6000 mm 60 modes (30 undulations). ``mm0``: no roll.
``fine``
    as ``rel`` with 16 modes (wavelengths ``2 L / j``, ``j = 1..16``: at 10 increments the
    shortest eight alias between the readings), rolls present: the short machines of the
    issue's independent generator in figures (0.52x least squares, 1.11x the limit on
    800 mm; benchmarks/README.md, session 13).
``len`` / ``len0``
    the modes of ``rel``, with the linear errors (positioning wiggles, straightness)
    growing with the axis' travel: ``A`` times ``L / 800 mm`` (a straightness is the
    integral of its guideway's slope: the same slopes over a 3 m X give 3.75 times the
    deviation of an 800 mm axis); the angles as in ``rel``. ``len0``: no roll.

``A``: positioning 3 um on a scale error of +-10 um/m (uniform), straightness 3 um, pitch
and yaw 8 urad, rolls 8 urad, squareness +-50 urad (uniform). Seeds' full test set (4 step
diagonals with a flat mirror, 4 body diagonals, 3 Abbe lines per axis), 10 increments,
0.5 um noise, 20 urad of mirror and 20 urad of beam misalignment; chains and seeds from
:data:`MASTER_SEED`.

Command line::

    nice -n 15 python benchmarks/travel_study.py --machines 20 --design full,step \\
        --json travel.json --markdown
    python benchmarks/travel_study.py --from-json travel.json --markdown
    python benchmarks/travel_study.py --family mm0 --travel t6000 --design full \
        --settings '{"between_readings_factor": 0}'   # another EstimatorSettings
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import exact_sim  # noqa: E402
import families  # noqa: E402

from volcal.identify import IdentifyOptions, identify  # noqa: E402
from volcal.model.kinematics import volumetric_error  # noqa: E402
from volcal.model.rigid import remove_rigid_body  # noqa: E402
from volcal.plan.planner import plan_session  # noqa: E402
from volcal.standards.volumetric import work_zone_grid  # noqa: E402

MASTER_SEED = 20261126
"""Seed of the study's machine sequence (chains, machine and simulation seeds)."""
TRAVELS = {"t800": ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0)),
           "t3000": ((0.0, 3000.0), (0.0, 800.0), (0.0, 600.0)),
           "t6000": ((0.0, 6000.0), (0.0, 1000.0), (0.0, 800.0))}
DESIGNS = {"full": ("step-diagonal", "diagonal", "linear"), "step": ("step-diagonal",)}
"""The seeds' full test set, and the step diagonals alone."""
AMPLITUDE = {"positioning": 3.0, "straightness": 3.0, "tilt": 8.0, "roll": 8.0}
SCALE_UM_PER_M = 10.0
SQUARENESS_URAD = 50.0
MODES = 8
FINE_MODES = 16
"""Modes of the ``fine`` family (``MODES`` for ``rel`` and ``len``)."""
REF_MM = 800.0
N_DRAWS = 2000


def _wavelengths(span: float, shape: str) -> tuple[np.ndarray, np.ndarray]:
    """Wavelengths [mm] and relative standard deviations of the modes of one function."""
    if shape in ("rel", "len", "fine"):
        j = np.arange(1, (FINE_MODES if shape == "fine" else MODES) + 1)
        return 2.0 * span / j, 1.0 / np.sqrt(j)
    shortest = 2.0 * REF_MM / MODES
    j = np.arange(1, int(np.floor(2.0 * span / shortest + 1e-9)) + 1)
    lam = 2.0 * span / j
    return lam, np.sqrt(np.minimum(1.0, lam / (2.0 * REF_MM)))


def _growth(span: float, shape: str) -> float:
    """Factor on the linear errors' amplitude [1]: ``span / 800 mm`` for ``'len'``, else 1."""
    return span / REF_MM if shape == "len" else 1.0


def draw(rng: np.random.Generator, travel, chain: str, shape: str = "rel",
         rolls: bool = True) -> families.AnalyticMachine:
    """One machine of a family (analytic functions; :func:`to_sim` for the simulator).

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    travel : array_like, shape (3, 2)
        Travel [mm].
    chain : str
        Chain code.
    shape : str
        ``'rel'`` (shape relative to the travel), ``'mm'`` (per millimetre), ``'len'``
        (as ``'rel'``, the linear errors growing with the travel) or ``'fine'`` (as
        ``'rel'`` with :data:`FINE_MODES` modes).
    rolls : bool
        Draw the rolls; False: EAX = EBY = ECZ = 0.
    """
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    fs: dict = {}
    shortest = np.inf
    for k in range(3):
        lo, span = t[k, 0], t[k, 1] - t[k, 0]
        lam, rel = _wavelengths(span, shape)
        grow = _growth(span, shape)
        shortest = min(shortest, lam.min())
        for c in range(6):
            if c == k:
                a, g = AMPLITUDE["positioning"] * grow, rng.uniform(-1, 1) * SCALE_UM_PER_M * 1e-3
                f0 = exact_sim.fourier_function(rng, lo, span, lam, a * rel)
                fs[6 * k + c] = (lambda x, f0=f0, g=g, lo=lo: f0(x) + g * (np.asarray(x) - lo))
            elif c < 3:
                fs[6 * k + c] = exact_sim.fourier_function(
                    rng, lo, span, lam, AMPLITUDE["straightness"] * grow * rel)
            elif c - 3 == k:
                if rolls:
                    fs[6 * k + c] = exact_sim.fourier_function(rng, lo, span, lam,
                                                               AMPLITUDE["roll"] * rel)
            else:
                fs[6 * k + c] = exact_sim.fourier_function(rng, lo, span, lam,
                                                           AMPLITUDE["tilt"] * rel)
    sq = rng.uniform(-1, 1, 3) * SQUARENESS_URAD
    return families.AnalyticMachine(chain, t, fs, sq, spacing_mm=float(shortest / 40.0))


def _terms(travel, shape: str, rolls: bool):
    """The family's random terms: ``(function, callable, variance)`` per term.

    The Fourier modes ``c cos(2 pi s / lambda + phi)`` with ``c ~ N(0, std^2)`` and a
    uniform phase are, in their second moments, ``a cos + b sin`` with independent ``a``,
    ``b`` of variance ``std^2 / 2``; the scale error and the squareness are uniform (variance
    ``range^2 / 3``). ``function`` is ``6 * axis + component``, or ``-1 - i`` for the
    squareness ``i``.
    """
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    out = []
    for k in range(3):
        lo, span = t[k, 0], t[k, 1] - t[k, 0]
        lam, rel = _wavelengths(span, shape)
        grow = _growth(span, shape)
        for c in range(6):
            if c == k:
                a = AMPLITUDE["positioning"] * grow
                out.append((6 * k + c, lambda x, lo=lo: np.asarray(x) - lo,
                            (SCALE_UM_PER_M * 1e-3) ** 2 / 3))
            elif c < 3:
                a = AMPLITUDE["straightness"] * grow
            elif c - 3 == k:
                if not rolls:
                    continue
                a = AMPLITUDE["roll"]
            else:
                a = AMPLITUDE["tilt"]
            for lj, rj in zip(lam, rel, strict=True):
                for trig in (np.cos, np.sin):
                    out.append((6 * k + c, lambda x, lj=lj, lo=lo, trig=trig:
                                trig(2 * np.pi * (np.asarray(x) - lo) / lj),
                                (a * rj) ** 2 / 2))
    for i in range(3):
        out.append((-1 - i, None, SQUARENESS_URAD**2 / 3))
    return out


def exact_limit(shape: str, rolls: bool, travel, chain: str, session,
                options: IdentifyOptions | None = None) -> families.Limit:
    """The limit with the family's exact prior covariance (no sampling).

    On the nodes of volcal's estimate with ``options`` (default ``IdentifyOptions()``: its
    ``refine``, ``max_nodes`` and settings), so that the limit and volcal share the grid.

    :func:`families.build_limit` estimates the prior from draws, which for the Fourier
    families' ~300 random terms per machine leaves the small eigenvalues of the sample
    covariance too small (Marchenko-Pastur: with 2000 draws of 300 dimensions the
    spectrum's edges move by factors 0.4-1.9) and the "limit" worse than volcal. The
    family is linear in its random terms (:func:`_terms`) and :func:`families.gauge_map`
    is linear, so the covariance at the nodes is exact: ``S = sum_i v_i g_i g_i'``, ``g_i``
    the gauge-mapped term at the free nodes.
    """
    from copy import copy

    import scipy.linalg as sla

    from volcal.identify.design import build_design, choose_nodes

    s = copy(session)
    s.measurements = [copy(m) for m in session.measurements]
    for m in s.measurements:
        m.deviation = np.zeros(m.n)
    o = options or IdentifyOptions()
    nodes = choose_nodes(s, refine=o.refine, max_nodes=o.max_nodes, settings=o.settings)
    design = build_design(s, nodes)
    t = np.asarray(travel, dtype=float)
    G = []
    var = []
    for f, fn, v in _terms(t, shape, rolls):
        sq = np.zeros(3)
        fs = {}
        if f < 0:
            sq[-1 - f] = 1.0
        else:
            fs[f] = fn
        am = families.AnalyticMachine(chain, t, fs, sq)
        G.append(design.layout.pack(families.gauge_map(am.tabulate(nodes)))[design.free])
        var.append(v)
    G = np.array(G)
    S = (G.T * np.array(var)) @ G
    nf = design.n_free
    A = design.A.toarray()
    Af, An = A[:, :nf], A[:, nf:]
    kinds = [n.rsplit(":", 1)[1] for n in design.nuisance_names]
    tilt = np.array([k.startswith("tilt") for k in kinds])
    Aflat = An[:, ~tilt]
    qf, _ = np.linalg.qr(Aflat, mode="complete")
    U = qf[:, np.linalg.matrix_rank(Aflat):]
    At = An[:, tilt]
    C = (Af @ S @ Af.T + families.TILT_URAD**2 * (At @ At.T)
         + families.NOISE_UM**2 * np.eye(A.shape[0]))
    cf = sla.cho_factor(U.T @ C @ U)
    gain = (S @ Af.T @ U) @ sla.cho_solve(cf, U.T)
    return families.Limit(design, np.zeros(nf), gain)


def to_sim(am: families.AnalyticMachine) -> exact_sim.SimMachine:
    """The same machine for :mod:`exact_sim`."""
    return exact_sim.SimMachine(am.chain, am.travel, dict(am.functions), am.squareness.copy())


FAMILIES = {
    "rel": families.Family("rel", "Fourier, shape relative to the travel, rolls",
                           lambda rng, t, ch: draw(rng, t, ch, "rel", True)),
    "rel0": families.Family("rel0", "Fourier, shape relative to the travel, no roll",
                            lambda rng, t, ch: draw(rng, t, ch, "rel", False)),
    "mm": families.Family("mm", "Fourier, shape per mm, rolls",
                          lambda rng, t, ch: draw(rng, t, ch, "mm", True)),
    "mm0": families.Family("mm0", "Fourier, shape per mm, no roll",
                           lambda rng, t, ch: draw(rng, t, ch, "mm", False)),
    "fine": families.Family("fine", "Fourier, shape relative to the travel, 16 modes, rolls",
                            lambda rng, t, ch: draw(rng, t, ch, "fine", True)),
    "len": families.Family("len", "Fourier, shape relative to the travel, linear errors "
                           "growing with it, rolls",
                           lambda rng, t, ch: draw(rng, t, ch, "len", True)),
    "len0": families.Family("len0", "Fourier, shape relative to the travel, linear errors "
                            "growing with it, no roll",
                            lambda rng, t, ch: draw(rng, t, ch, "len", False)),
}


@dataclass(frozen=True)
class Case:
    """One machine: index, chain, machine seed, simulation seed."""

    index: int
    chain: str
    machine_seed: int
    sim_seed: int


def cases(n: int) -> list[Case]:
    """The first ``n`` machines (chains and seeds from :data:`MASTER_SEED`)."""
    rng = np.random.default_rng(MASTER_SEED)
    return [Case(i, str(families.CHAINS[int(rng.integers(len(families.CHAINS)))]),
                 int(rng.integers(2**31)), int(rng.integers(2**31))) for i in range(n)]


@dataclass
class Result:
    """Figures of one machine (as :class:`families.FamilyResult`)."""

    family: str
    design: str
    case: Case
    truth_rms_um: float
    bayes: dict = field(default_factory=dict)
    min_norm: dict = field(default_factory=dict)
    limit_rms_um: float = float("nan")


def session_for(travel, chain: str, design: str, steps: int = 10, runs: int = 5):
    """The planned session of a design."""
    return plan_session(np.asarray(travel), chain, steps, DESIGNS[design], runs=runs)


def run_case(fam: families.Family, travel_key: str, design: str, case: Case, limit,
             steps: int = 10, runs: int = 5, n_grid: int = 9,
             options: IdentifyOptions | None = None, min_norm: bool = True) -> Result:
    """Draw, simulate with :mod:`exact_sim`, identify and compare one machine."""
    travel = np.array(TRAVELS[travel_key])
    am = fam.draw(np.random.default_rng(case.machine_seed), travel, case.chain)
    session = session_for(travel, case.chain, design, steps, runs)
    exact_sim.simulate(session, to_sim(am), case.sim_seed)
    truth = am.tabulate()
    q = work_zone_grid(travel, n_grid)
    truth_g = families.gauge_map(truth)
    truth_rms = float(np.sqrt(np.mean(np.sum(
        remove_rigid_body(q, volumetric_error(truth, q)) ** 2, axis=1))))
    o = options or IdentifyOptions(suggest=False)
    out = Result(fam.name, f"{travel_key}-{design}", case, truth_rms)
    t0 = time.perf_counter()
    rb = identify(session, o)
    out.bayes = families.evaluate(rb, truth_g, q)
    out.bayes.update(seconds=time.perf_counter() - t0, sigma_um=float(rb.fit["sigma_um"]))
    if min_norm:
        rm = identify(session, replace(o, prior="none"))
        out.min_norm = families.evaluate(rm, truth_g, q, rigid=False)
    if limit is not None:
        y = np.concatenate([m.deviation for m in session.measurements])
        el = limit.estimate(y)
        dl = remove_rigid_body(q, volumetric_error(el, q) - volumetric_error(truth_g, q))
        out.limit_rms_um = float(np.sqrt(np.mean(np.sum(dl**2, axis=1))))
    return out


def run(fam_key: str, travel_key: str, design: str, n: int, limit: bool = True,
        n_draws: int = N_DRAWS, steps: int = 10, runs: int = 5, first: int = 0,
        options: IdentifyOptions | None = None, progress=None) -> list[Result]:
    """Machines ``first .. n - 1`` of one family on one travel and design."""
    fam = FAMILIES[fam_key]
    travel = np.array(TRAVELS[travel_key])
    limits: dict = {}
    out = []
    for case in cases(n)[first:]:
        lim = None
        if limit and design == "full":
            if case.chain not in limits:
                sess = session_for(travel, case.chain, design, steps, runs)
                limits[case.chain] = exact_limit(fam_key.rstrip("0"), not fam_key.endswith("0"),
                                                 travel, case.chain, sess, options)
            lim = limits[case.chain]
        r = run_case(fam, travel_key, design, case, lim, steps, runs, options=options,
                     min_norm=design == "full")
        out.append(r)
        if progress is not None:
            progress(r)
    return out


def summarise(results: list[Result]) -> dict:
    """Figures of one family, travel and design over its machines."""
    b = [r.bayes for r in results]
    out = {"family": results[0].family, "design": results[0].design,
           "machines": len(results),
           "truth_rms_um": float(np.median([r.truth_rms_um for r in results])),
           "bayes_rms_um": float(np.median([x["rms_um"] for x in b])),
           "coverage": float(np.mean([x["coverage"] for x in b])),
           "coverage_min": float(np.min([x["coverage"] for x in b])),
           "coverage_rigid": float(np.mean([x.get("coverage_rigid", np.nan) for x in b])),
           "bayes_seconds": float(np.median([x["seconds"] for x in b]))}
    if results[0].min_norm:
        rl = np.array([x["rms_um"] / r.min_norm["rms_um"] for x, r in zip(b, results, strict=True)])
        out.update(min_norm_rms_um=float(np.median([r.min_norm["rms_um"] for r in results])),
                   ratio_ls_median=float(np.median(rl)), ratio_ls_max=float(rl.max()),
                   above_1=int(np.sum(rl > 1.0)))
    if np.isfinite(results[0].limit_rms_um):
        rlim = np.array([x["rms_um"] / r.limit_rms_um for x, r in zip(b, results, strict=True)])
        out.update(limit_rms_um=float(np.median([r.limit_rms_um for r in results])),
                   ratio_limit_median=float(np.median(rlim)),
                   ratio_limit_max=float(rlim.max()))
    return out


def markdown(summaries: list[dict]) -> str:
    """One table row per family, travel and design."""
    rows = ["| family | travel-design | machines | truth RMS | volcal RMS | min-norm RMS | "
            "limit RMS | ratio to LS median / max (> 1) | ratio to limit median / max | "
            "coverage pooled (min) | rigid-free | s per identify |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def f(s, k, fmt="{:.2f}"):
        return fmt.format(s[k]) if k in s else "-"
    for s in summaries:
        ls = (f"{s['ratio_ls_median']:.2f} / {s['ratio_ls_max']:.2f} ({s['above_1']})"
              if "ratio_ls_median" in s else "-")
        lim = (f"{s['ratio_limit_median']:.2f} / {s['ratio_limit_max']:.2f}"
               if "ratio_limit_median" in s else "-")
        rows.append(f"| {s['family']} | {s['design']} | {s['machines']} | "
                    f"{s['truth_rms_um']:.2f} | {s['bayes_rms_um']:.2f} | "
                    f"{f(s, 'min_norm_rms_um')} | {f(s, 'limit_rms_um')} | {ls} | {lim} | "
                    f"{s['coverage']:.3f} ({s['coverage_min']:.2f}) | "
                    f"{s['coverage_rigid']:.3f} | {s['bayes_seconds']:.2f} |")
    return "\n".join(rows)


def _print(r: Result) -> None:
    b = r.bayes
    ls = r.min_norm.get("rms_um", float("nan"))
    print(f"{r.family:5s} {r.design:12s} #{r.case.index:2d} {r.case.chain} truth "
          f"{r.truth_rms_um:6.2f} volcal {b['rms_um']:6.2f} LS {ls:7.2f} limit "
          f"{r.limit_rms_um:6.2f} ratio LS {b['rms_um'] / ls:5.2f} limit "
          f"{b['rms_um'] / r.limit_rms_um:5.2f} cov {b['coverage']:.3f} "
          f"({b['seconds']:.2f} s)", flush=True)


def with_settings(options: IdentifyOptions, settings_json: str) -> IdentifyOptions:
    """``options`` with the :class:`EstimatorSettings` fields of ``settings_json`` replaced.

    ``settings_json`` is a JSON object of field names and values (its lists read as
    tuples, as the settings' fields are); an empty string leaves ``options`` as they are.
    """
    if not settings_json:
        return options

    def tup(v):
        return tuple(tup(x) for x in v) if isinstance(v, list) else v

    kw = {k: tup(v) for k, v in json.loads(settings_json).items()}
    return replace(options, settings=replace(options.settings, **kw))


def main(argv=None) -> int:
    """Command line (``python benchmarks/travel_study.py --help``)."""
    p = argparse.ArgumentParser(description="The estimator on short and long machines "
                                            "(issue 30).")
    p.add_argument("--family", default="all", help="comma-separated keys, or all")
    p.add_argument("--travel", default="all", help="comma-separated keys, or all")
    p.add_argument("--design", default="full,step")
    p.add_argument("--machines", type=int, default=20)
    p.add_argument("--first", type=int, default=0)
    p.add_argument("--draws", type=int, default=N_DRAWS)
    p.add_argument("--no-limit", action="store_true")
    p.add_argument("--cache", type=Path, help="keep the limits' priors in this directory")
    p.add_argument("--markdown", action="store_true")
    p.add_argument("--json", type=Path)
    p.add_argument("--from-json", type=Path)
    p.add_argument("--settings", default="",
                   help="EstimatorSettings fields as JSON (volcal's and the limit's grid)")
    a = p.parse_args(argv)
    if a.from_json:
        saved = json.loads(a.from_json.read_text())["machines"]
        groups = dict.fromkeys((m["design"], m["family"]) for m in saved)
        summaries = [summarise([Result(m["family"], m["design"], Case(**m["case"]),
                                       m["truth_rms_um"], m["bayes"], m["min_norm"],
                                       m["limit_rms_um"])
                                for m in saved if (m["design"], m["family"]) == g])
                     for g in groups]
        print(markdown(summaries) if a.markdown else json.dumps(summaries, indent=1))
        return 0
    families.CACHE = a.cache
    options = with_settings(IdentifyOptions(suggest=False), a.settings)
    fams = list(FAMILIES) if a.family == "all" else a.family.split(",")
    travels = list(TRAVELS) if a.travel == "all" else a.travel.split(",")
    everything, summaries = [], []
    for design in a.design.split(","):
        for t in travels:
            for f in fams:
                res = run(f, t, design, a.machines, not a.no_limit, a.draws, first=a.first,
                          options=options, progress=_print)
                summaries.append(summarise(res))
                everything += [{"family": r.family, "design": r.design,
                                "case": r.case.__dict__, "truth_rms_um": r.truth_rms_um,
                                "bayes": r.bayes, "min_norm": r.min_norm,
                                "limit_rms_um": r.limit_rms_um} for r in res]
                if a.json:
                    a.json.write_text(json.dumps({"machines": everything,
                                                  "summary": summaries}, indent=1))
    print(markdown(summaries) if a.markdown else json.dumps(summaries, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
