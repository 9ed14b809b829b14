"""Acceptance studies of the estimator (issue 10): accuracy and honesty on many machines.

For each test *design* (which tests are measured, on which travel) and ``N`` random virtual
machines, the study plans the session, fills it with the **exact** simulator (homogeneous
transforms, 0.5 um reading noise, 20 urad flat-mirror misalignment, 20 urad residual beam
misalignment, i.e. the set-up tilts), identifies it twice with the public API

* the default estimator, ``identify(session, IdentifyOptions(suggest=False))``, and
* plain minimum-norm least squares, ``IdentifyOptions(prior='none', suggest=False)``,

and compares both with the hidden truth on a uniform grid over the travel:

``rms_um``, ``max_um``
    RMS and maximum over the grid of the length of the volumetric error vector
    ``|e_est - e_true|`` [um], after removing the best-fitting rigid-body motion of the
    difference (no laser reading can see it; the same removal for both estimators,
    :func:`volcal.model.rigid.remove_rigid_body`).
``ratio``
    ``rms_um`` of the default estimator over that of minimum-norm least squares on the
    same data (issue 10 asks for <= 1 on every machine).
``coverage``
    Fraction of grid points and components where ``|e_true - e_est| <= 1.96 u`` with ``u``
    the standard uncertainty returned by ``IdentificationResult.predict``. No rigid-body
    motion is removed here, on purpose: ``predict`` propagates the posterior covariance
    of the parameters in the estimator's gauge (every function zero at the start of its
    travel, the straightness functions also at the end; ``volcal.identify.design``) with
    ``u_i^2 = J_i Sigma J_i^T``, i.e. ``u`` is the uncertainty of the error *in that
    gauge*, and the virtual machines obey the same gauge (``volcal.measure.virtual``), so
    the truth and the estimate are directly comparable. Removing a rigid-body fit from the
    difference but not from ``u`` would overstate the coverage. ``coverage_rigid`` (the
    difference with the rigid-body motion removed, against the same ``u``) is recorded as
    a diagnostic only: when it is much higher than ``coverage``, the misses are rigid-body
    like.
``roll``
    For each roll function (EAX, EBY, ECZ: ISO 230-1, the rotation about the axis' own
    direction) on 21 positions: RMS error [urad], RMS of the truth [urad], coverage of
    its 95 % interval (``IdentificationResult.function_std``) and the share the report
    calls determined (``report.determined_fraction``).
``seconds``
    Wall time of one ``identify`` call (the estimate and the identifiability report; the
    candidate-measurement suggestions are switched off: they do not change the estimate
    and cost as much again).

The machines are drawn by a fixed random generator (:data:`MASTER_SEED`), not chosen:
machine ``i`` of every design has the same chain, error seed and simulation seed (the
long machine differs only by its travel), so the designs are compared on the same
machines. Chains are drawn from :data:`CHAINS`.

The drift study (:func:`drift_study`) simulates a linear drift of the readings and
identifies with ``drift=False`` and ``drift=True`` on designs where a drift is separable
from the geometry (bidirectional linear runs), and on the full set for contrast.

Command line::

    python benchmarks/study.py --design full --machines 20
    python benchmarks/study.py --design all --machines 10 --markdown
    python benchmarks/study.py --drift --design all --machines 10

References
----------
Issue 10 of the project (estimator: honest on every design). A. Soons, "Analysis of the
step-diagonal test", NIST (seed 004) for the positioning-slope / mirror-tilt confound.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.identify import IdentifyOptions, identify
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.measure.virtual import random_machine
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import volumetric_error
from volcal.model.names import SQUARENESS_NAMES
from volcal.model.rigid import remove_rigid_body
from volcal.plan.planner import plan_session
from volcal.session.format import Session
from volcal.standards.volumetric import work_zone_grid

__all__ = [
    "CHAINS", "DESIGNS", "MASTER_SEED", "ROLL_NAMES", "Case", "MachineResult", "StudyDesign",
    "cases", "drift_study", "evaluate", "run_case", "run_design", "simulate",
    "summarise",
]

MASTER_SEED = 20261123
"""Seed of the generator that draws the study's machines (fixed, not tuned)."""

CHAINS: tuple[str, ...] = ("XYFZ", "FXYZ", "XFYZ", "YFXZ")
"""Kinematic chains the machines are drawn from (cross-table mill, gantry, two tables)."""

ROLL_NAMES: tuple[str, ...] = ("EAX", "EBY", "ECZ")
"""The roll of each axis (ISO 230-1): rotation about the axis' own direction."""

UNSEEN = 0.05
"""A squareness error is unseen by a design where the report's determined fraction is
below this (Abbe lines only: 0.00)."""

TRAVEL = ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0))
LONG_TRAVEL = ((0.0, 3000.0), (0.0, 800.0), (0.0, 600.0))
FULL = ("step-diagonal", "diagonal", "linear")


@dataclass(frozen=True)
class StudyDesign:
    """A test design of the study.

    Attributes
    ----------
    name : str
        Short name (command line).
    tests : tuple of str
        Tests of :func:`volcal.plan.planner.plan_session`.
    travel : tuple of 3 (float, float)
        Travel limits [mm].
    description : str
        One line for tables.
    """

    name: str
    tests: tuple[str, ...]
    travel: tuple[tuple[float, float], ...] = TRAVEL
    description: str = ""


DESIGNS: dict[str, StudyDesign] = {d.name: d for d in (
    StudyDesign("full", FULL, TRAVEL, "seeds' full test set (step diagonals, body diagonals, "
                "3 Abbe lines per axis), 800x600x500 mm"),
    StudyDesign("step", ("step-diagonal",), TRAVEL, "4 step diagonals (flat mirror) only"),
    StudyDesign("abbe", ("linear",), TRAVEL, "3 Abbe lines per axis only"),
    StudyDesign("abbe+diag", ("linear", "diagonal"), TRAVEL,
                "3 Abbe lines per axis + 4 body diagonals"),
    StudyDesign("long", FULL, LONG_TRAVEL, "full test set on a long machine, 3000x800x600 mm"),
)}
"""The designs named by issue 10."""


@dataclass(frozen=True)
class Case:
    """One random machine of the study.

    Attributes
    ----------
    index : int
        Position in the study's sequence.
    chain : str
        Chain code.
    machine_seed : int
        Seed of :func:`volcal.measure.virtual.random_machine`.
    sim_seed : int
        Seed of the simulation (noise, set-up tilts).
    """

    index: int
    chain: str
    machine_seed: int
    sim_seed: int


def cases(n: int, master_seed: int = MASTER_SEED) -> list[Case]:
    """The first ``n`` machines of the study (the same for every design).

    Parameters
    ----------
    n : int
        Number of machines.
    master_seed : int
        Seed of the generator that draws chains and seeds.

    Returns
    -------
    list of Case
    """
    rng = np.random.default_rng(master_seed)
    out = []
    for i in range(n):
        chain = str(CHAINS[int(rng.integers(len(CHAINS)))])
        out.append(Case(i, chain, int(rng.integers(2**31)), int(rng.integers(2**31))))
    return out


def simulation_options(seed: int, drift_um_per_h: float = 0.0) -> SimulationOptions:
    """The study's simulation: exact readings with realistic set-up errors.

    Parameters
    ----------
    seed : int
        Seed of noise and set-up errors.
    drift_um_per_h : float
        Linear drift of the readings [um/h].

    Returns
    -------
    SimulationOptions
        0.5 um noise, 20 urad mirror and beam misalignment, 4 s between readings.
    """
    return SimulationOptions(noise_um=0.5, mirror_misalignment_urad=20.0,
                             beam_misalignment_urad=20.0, drift_um_per_h=drift_um_per_h,
                             dwell_s=4.0, seed=seed)


def simulate(design: StudyDesign, case: Case, steps: int = 10, runs: int = 5,
             drift_um_per_h: float = 0.0) -> tuple[Session, MachineErrors]:
    """Plan and simulate one machine of the study.

    Parameters
    ----------
    design : StudyDesign
        Which tests, which travel.
    case : Case
        The machine.
    steps : int
        Increments per test.
    runs : int
        Bidirectional runs per linear test.
    drift_um_per_h : float
        Linear drift of the readings [um/h].

    Returns
    -------
    session : Session
        Simulated session.
    truth : MachineErrors
        The hidden machine.
    """
    travel = np.array(design.travel, dtype=float)
    session = plan_session(travel, case.chain, steps, design.tests, runs=runs)
    truth = random_machine(travel, case.chain, seed=case.machine_seed)
    simulate_session(session, truth, simulation_options(case.sim_seed, drift_um_per_h))
    return session, truth


def evaluate(result, truth: MachineErrors, q: NDArray[np.float64]) -> dict:
    """Compare one identification with the truth.

    Parameters
    ----------
    result : IdentificationResult
        Output of :func:`volcal.identify.identify`.
    truth : MachineErrors
        The hidden machine.
    q : ndarray, shape (m, 3)
        Grid points [mm].

    Returns
    -------
    dict
        ``rms_um``, ``max_um`` (rigid-body motion removed), ``rms_seen_um`` (the same with
        the squareness errors no reading of the design sees taken out of the truth: both
        estimators hold them at zero, and how an estimate's other errors happen to combine
        with them is chance, not estimation), ``coverage`` (gauge frame, no removal),
        ``coverage_rigid`` (diagnostic), ``u_rms_um``, ``roll`` per roll name.
    """
    e, u = result.predict(q)
    et = volumetric_error(truth, q)
    d = e - et
    dr = remove_rigid_body(q, d)
    length = np.linalg.norm(dr, axis=1)
    det = getattr(result.report, "determined_fraction", {}) or {}
    unseen = [j for j, n in enumerate(SQUARENESS_NAMES) if det.get(n, 1.0) < UNSEEN]
    if unseen:
        seen_truth = copy.deepcopy(truth)
        seen_truth.squareness = np.asarray(truth.squareness, dtype=float).copy()
        seen_truth.squareness[unseen] = 0.0
        length_seen = np.linalg.norm(remove_rigid_body(q, e - volumetric_error(seen_truth, q)),
                                     axis=1)
    else:
        length_seen = length
    out = {
        "rms_um": float(np.sqrt(np.mean(length**2))),
        "rms_seen_um": float(np.sqrt(np.mean(length_seen**2))),
        "max_um": float(length.max()),
        "coverage": float(np.mean(np.abs(d) <= 1.96 * u)),
        "coverage_rigid": float(np.mean(np.abs(dr) <= 1.96 * u)),
        "u_rms_um": float(np.sqrt(np.mean(np.sum(u**2, axis=1)))),
        "roll": {},
    }
    for k, name in enumerate(ROLL_NAMES):
        pos = np.linspace(truth.travel[k][0], truth.travel[k][1], 21)
        est = result.errors.function(name, pos)
        tru = truth.function(name, pos)
        sd = result.function_std(name, pos)
        out["roll"][name] = {
            "rms_err_urad": float(np.sqrt(np.mean((est - tru) ** 2))),
            "rms_true_urad": float(np.sqrt(np.mean(tru**2))),
            "coverage": float(np.mean(np.abs(est - tru) <= 1.96 * sd)),
            "rms_sd_urad": float(np.sqrt(np.mean(sd**2))),
            "determined": float(det.get(name, float("nan"))),
        }
    return out


@dataclass
class MachineResult:
    """Study figures of one machine on one design.

    Attributes
    ----------
    design : str
        Design name.
    case : Case
        The machine.
    truth_rms_um : float
        RMS length of the true volumetric error, rigid-body motion removed [um].
    bayes, min_norm : dict
        :func:`evaluate` of the default estimator and of minimum-norm least squares, with
        ``seconds`` (wall time of ``identify``) and, for the default, ``ambiguity_um``,
        ``n_outliers`` and ``sigma_um``.
    """

    design: str
    case: Case
    truth_rms_um: float
    bayes: dict = field(default_factory=dict)
    min_norm: dict = field(default_factory=dict)

    @property
    def ratio(self) -> float:
        """RMS residual of the default estimator over that of minimum-norm LS, on what
        the design sees (``rms_seen_um`` of :func:`evaluate`)."""
        return self.bayes["rms_seen_um"] / max(self.min_norm["rms_seen_um"], 1e-12)


def _timed_identify(session: Session, options: IdentifyOptions):
    t0 = time.perf_counter()
    r = identify(session, options)
    return r, time.perf_counter() - t0


def run_case(design: StudyDesign, case: Case, steps: int = 10, runs: int = 5,
             n_grid: int = 9, options: IdentifyOptions | None = None) -> MachineResult:
    """Simulate one machine and identify it with both estimators.

    Parameters
    ----------
    design : StudyDesign
        The design.
    case : Case
        The machine.
    steps : int
        Increments per test.
    runs : int
        Bidirectional runs per linear test.
    n_grid : int
        Grid points per axis of the comparison.
    options : IdentifyOptions, optional
        Options of the default estimator (default ``IdentifyOptions(suggest=False)``);
        the minimum-norm run uses the same with ``prior='none'``.

    Returns
    -------
    MachineResult
    """
    session, truth = simulate(design, case, steps, runs)
    q = work_zone_grid(design.travel, n_grid)
    truth_rms = float(np.sqrt(np.mean(np.sum(remove_rigid_body(q, volumetric_error(truth, q))
                                             ** 2, axis=1))))
    o = options or IdentifyOptions(suggest=False)
    out = MachineResult(design.name, case, truth_rms)
    rb, tb = _timed_identify(session, o)
    out.bayes = evaluate(rb, truth, q)
    out.bayes.update(seconds=tb, ambiguity_um=float(getattr(rb.report, "ambiguity_um", np.nan)),
                     n_outliers=len(rb.outliers), sigma_um=float(rb.fit["sigma_um"]))
    from dataclasses import replace

    rm, tm = _timed_identify(session, replace(o, prior="none"))
    out.min_norm = evaluate(rm, truth, q)
    out.min_norm.update(seconds=tm)
    return out


def run_design(design: StudyDesign | str, n_machines: int = 10, steps: int = 10, runs: int = 5,
               n_grid: int = 9, progress=None) -> list[MachineResult]:
    """Run the study on the first ``n_machines`` machines of :func:`cases`.

    Parameters
    ----------
    design : StudyDesign or str
        The design or its name in :data:`DESIGNS`.
    n_machines : int
        Number of machines.
    steps : int
        Increments per test.
    runs : int
        Bidirectional runs per linear test.
    n_grid : int
        Grid points per axis.
    progress : callable, optional
        Called with each :class:`MachineResult` as it is done.

    Returns
    -------
    list of MachineResult
    """
    d = DESIGNS[design] if isinstance(design, str) else design
    out = []
    for case in cases(n_machines):
        r = run_case(d, case, steps, runs, n_grid)
        out.append(r)
        if progress is not None:
            progress(r)
    return out


def summarise(results: Sequence[MachineResult]) -> dict:
    """Figures of one design over its machines.

    Parameters
    ----------
    results : sequence of MachineResult
        One design's machines.

    Returns
    -------
    dict
        Medians and extremes of the residuals [um], ratios, pooled coverage, roll
        figures and median time per identification [s].
    """
    b = [r.bayes for r in results]
    m = [r.min_norm for r in results]
    ratio = np.array([r.ratio for r in results])
    roll_err = {n: float(np.max([x["roll"][n]["rms_err_urad"] for x in b])) for n in ROLL_NAMES}
    roll_cov = float(np.mean([x["roll"][n]["coverage"] for x in b for n in ROLL_NAMES]))
    return {
        "design": results[0].design if results else "",
        "machines": len(results),
        "truth_rms_um": float(np.median([r.truth_rms_um for r in results])),
        "bayes_rms_um": float(np.median([x["rms_um"] for x in b])),
        "bayes_max_um": float(np.max([x["max_um"] for x in b])),
        "min_norm_rms_um": float(np.median([x["rms_um"] for x in m])),
        "min_norm_max_um": float(np.max([x["max_um"] for x in m])),
        "ratio_median": float(np.median(ratio)),
        "ratio_max": float(ratio.max()),
        "machines_worse": int(np.sum(ratio > 1.0)),
        "machines_worse_1pct": int(np.sum(ratio > 1.01)),
        "coverage": float(np.mean([x["coverage"] for x in b])),
        "coverage_min": float(np.min([x["coverage"] for x in b])),
        "coverage_rigid": float(np.mean([x["coverage_rigid"] for x in b])),
        "min_norm_coverage": float(np.mean([x["coverage"] for x in m])),
        "roll_max_rms_err_urad": roll_err,
        "roll_coverage": roll_cov,
        "sessions_with_outliers": int(sum(x["n_outliers"] > 0 for x in b)),
        "bayes_seconds": float(np.median([x["seconds"] for x in b])),
        "min_norm_seconds": float(np.median([x["seconds"] for x in m])),
    }


# ----------------------------------------------------------------------------- drift
def drift_study(designs: Sequence[str] = ("abbe", "full"), n_machines: int = 10,
                drift_um_per_h: float = 10.0, steps: int = 10, runs: int = 5,
                n_grid: int = 9, progress=None) -> list[dict]:
    """``drift=True`` against ``drift=False`` with and without a simulated drift.

    Each machine is simulated twice with the same seeds, without drift and with a linear
    drift of ``drift_um_per_h`` (readings every 4 s), and each session is identified with
    the default estimator with ``drift=False`` and ``drift=True``. A ``drift=True`` call
    the estimator refuses (``VolcalInputError``) is recorded as refused.

    Parameters
    ----------
    designs : sequence of str
        Design names; ``abbe`` (bidirectional linear runs only) separates drift from
        geometry, ``full`` adds single-pass step and body diagonals.
    n_machines : int
        Number of machines.
    drift_um_per_h : float
        Simulated drift [um/h].
    steps : int
        Increments per test.
    runs : int
        Bidirectional runs per linear test.
    n_grid : int
        Grid points per axis.
    progress : callable, optional
        Called with each row.

    Returns
    -------
    list of dict
        One row per design, machine, simulated drift and option: ``rms_um`` (rigid-body
        motion removed), ``coverage``, ``positioning_rms_um`` (EXX, EYY, EZZ against the
        truth), ``n_outliers`` or ``refused``.
    """
    rows = []
    for name in designs:
        d = DESIGNS[name]
        q = work_zone_grid(d.travel, n_grid)
        for case in cases(n_machines):
            for sim_drift in (0.0, drift_um_per_h):
                session, truth = simulate(d, case, steps, runs, sim_drift)
                for opt in (False, True):
                    row = {"design": name, "machine": case.index, "chain": case.chain,
                           "simulated_drift_um_per_h": sim_drift, "drift_option": opt}
                    try:
                        r, dt = _timed_identify(session, IdentifyOptions(drift=opt,
                                                                         suggest=False))
                    except VolcalInputError as exc:
                        row.update(refused=str(exc))
                    else:
                        ev = evaluate(r, truth, q)
                        row.update(rms_um=ev["rms_um"], coverage=ev["coverage"],
                                   positioning_rms_um=_positioning_error(r, truth),
                                   n_outliers=len(r.outliers), seconds=dt)
                    rows.append(row)
                    if progress is not None:
                        progress(row)
    return rows


def _positioning_error(result, truth: MachineErrors) -> float:
    """RMS error of EXX, EYY, EZZ over 21 positions each [um] (what a drift corrupts
    first, and what linear lines determine, unlike the volumetric field of a partial
    design, which is dominated by what the design cannot see)."""
    err = []
    for k, name in enumerate(("EXX", "EYY", "EZZ")):
        pos = np.linspace(truth.travel[k][0], truth.travel[k][1], 21)
        err.append(result.errors.function(name, pos) - truth.function(name, pos))
    return float(np.sqrt(np.mean(np.square(err))))


def summarise_drift(rows: Sequence[dict]) -> list[dict]:
    """Median figures of :func:`drift_study` per design, simulated drift and option.

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`drift_study`.

    Returns
    -------
    list of dict
    """
    keys = sorted({(r["design"], r["simulated_drift_um_per_h"], r["drift_option"])
                   for r in rows}, key=lambda k: (k[0], k[1], k[2]))
    out = []
    for key in keys:
        sel = [r for r in rows if (r["design"], r["simulated_drift_um_per_h"],
                                   r["drift_option"]) == key]
        ok = [r for r in sel if "rms_um" in r]
        out.append({
            "design": key[0], "simulated_drift_um_per_h": key[1], "drift_option": key[2],
            "machines": len(sel), "refused": len(sel) - len(ok),
            "rms_um_median": float(np.median([r["rms_um"] for r in ok])) if ok else None,
            "rms_um_max": float(np.max([r["rms_um"] for r in ok])) if ok else None,
            "coverage": float(np.mean([r["coverage"] for r in ok])) if ok else None,
            "positioning_rms_um_median": float(np.median([r["positioning_rms_um"] for r in ok]))
            if ok else None,
            "sessions_with_outliers": int(sum(r["n_outliers"] > 0 for r in ok)),
        })
    return out


# ----------------------------------------------------------------------------- output
def false_alarm_study(designs: Sequence[str], n_sessions: int = 60, steps: int = 10,
                      runs: int = 2, master_seed: int = 777) -> list[dict]:
    """Share of clean sessions the default outlier check flags (issue 10: <= 2 %).

    Every session is a machine of its own with its own simulation seed (the study's
    machines share a seed across designs, so their sessions are not independent noise
    draws: 40 sessions of machines 0-7 are ~16 streams).

    Parameters
    ----------
    designs : sequence of str
        Designs of :data:`DESIGNS`.
    n_sessions : int
        Clean sessions per design.
    steps, runs : int
        Increments per test, bidirectional runs per linear test.
    master_seed : int
        Seed of the machine sequence (not the study's :data:`MASTER_SEED`, so the machines
        differ from the accuracy study's).

    Returns
    -------
    list of dict
        Per design: ``design``, ``sessions``, ``flagged`` (count), ``share``, ``readings``
        (list of ``(machine, measurement, standardised residual)``).
    """
    out = []
    for name in designs:
        flagged = []
        for j, case in enumerate(cases(n_sessions, master_seed + 1000 * list(DESIGNS).index(name))):
            session, _ = simulate(DESIGNS[name], case, steps, runs)
            r = identify(session, IdentifyOptions(suggest=False))
            flagged += [(j, o["measurement"], round(float(o["standardised"]), 2))
                        for o in r.outliers]
        n_flag = len({f[0] for f in flagged})
        out.append({"design": name, "sessions": n_sessions, "flagged": n_flag,
                    "share": n_flag / n_sessions, "readings": flagged})
    return out


def _markdown(summaries: Sequence[dict]) -> str:
    head = ("| design | machines | truth RMS | Bayes RMS (median) | Bayes max | min-norm RMS "
            "(median) | ratio median / max | worse (> 1 / > 1.01) | coverage pooled (min) | "
            "roll err max EAX/EBY/ECZ [urad] | roll coverage | s per identify (Bayes / "
            "min-norm) |\n|---|---|---|---|---|---|---|---|---|---|---|---|")
    rows = [head]
    for s in summaries:
        re = s["roll_max_rms_err_urad"]
        rows.append(
            f"| {s['design']} | {s['machines']} | {s['truth_rms_um']:.2f} | "
            f"{s['bayes_rms_um']:.2f} | {s['bayes_max_um']:.2f} | {s['min_norm_rms_um']:.2f} | "
            f"{s['ratio_median']:.2f} / {s['ratio_max']:.2f} | "
            f"{s['machines_worse']} / {s['machines_worse_1pct']} | "
            f"{s['coverage']:.3f} ({s['coverage_min']:.2f}) | "
            f"{re['EAX']:.1f} / {re['EBY']:.1f} / {re['ECZ']:.1f} | "
            f"{s['roll_coverage']:.2f} | "
            f"{s['bayes_seconds']:.2f} / {s['min_norm_seconds']:.2f} |")
    return "\n".join(rows)


def _markdown_drift(summary: Sequence[dict]) -> str:
    rows = ["| design | simulated drift [um/h] | drift option | machines | refused | "
            "RMS median [um] | RMS max [um] | coverage | positioning error RMS median [um] | "
            "sessions flagged |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        f = (lambda v: "-" if v is None else f"{v:.2f}")  # noqa: E731
        rows.append(f"| {s['design']} | {s['simulated_drift_um_per_h']:g} | "
                    f"{s['drift_option']} | {s['machines']} | {s['refused']} | "
                    f"{f(s['rms_um_median'])} | {f(s['rms_um_max'])} | "
                    f"{f(s['coverage'])} | {f(s['positioning_rms_um_median'])} | "
                    f"{s['sessions_with_outliers']} |")
    return "\n".join(rows)


def _print_machine(r: MachineResult) -> None:
    b, m = r.bayes, r.min_norm
    print(f"  {r.design:9s} #{r.case.index:<3d} {r.case.chain}  truth {r.truth_rms_um:6.2f}  "
          f"bayes {b['rms_um']:6.2f} (max {b['max_um']:6.2f}, cover {b['coverage']:.2f}, "
          f"{b['seconds']:.1f} s)  min-norm {m['rms_um']:6.2f}  ratio {r.ratio:5.2f}  "
          f"roll err " + "/".join(f"{b['roll'][n]['rms_err_urad']:.1f}" for n in ROLL_NAMES),
          flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Command line of the study (``python benchmarks/study.py --help``).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status.
    """
    p = argparse.ArgumentParser(description="Acceptance studies of the estimator (issue 10).")
    p.add_argument("--design", default="full", choices=[*DESIGNS, "all"])
    p.add_argument("--machines", type=int, default=10)
    p.add_argument("--steps", type=int, default=10, help="increments per test")
    p.add_argument("--runs", type=int, default=5, help="bidirectional runs per linear test")
    p.add_argument("--grid", type=int, default=9, help="grid points per axis")
    p.add_argument("--drift", action="store_true", help="run the drift study instead")
    p.add_argument("--drift-um-per-h", type=float, default=10.0)
    p.add_argument("--false-alarms", type=int, metavar="N",
                   help="count the clean sessions (N per design) the outlier check flags")
    p.add_argument("--quiet", action="store_true", help="no line per machine")
    p.add_argument("--markdown", action="store_true", help="print Markdown tables")
    p.add_argument("--json", type=Path, help="write every machine's figures to this file")
    p.add_argument("--from-json", type=Path,
                   help="summarise the machines saved by an earlier --json run (no new runs)")
    a = p.parse_args(argv)
    if a.from_json:
        saved = json.loads(a.from_json.read_text())["machines"]
        summaries = []
        for name in dict.fromkeys(m["design"] for m in saved):
            res = [MachineResult(m["design"], Case(**m["case"]), m["truth_rms_um"],
                                 m["bayes"], m["min_norm"]) for m in saved
                   if m["design"] == name]
            summaries.append(summarise(res))
        print(_markdown(summaries) if a.markdown else json.dumps(summaries, indent=1))
        return 0
    show = None if a.quiet else _print_machine
    if a.false_alarms:
        designs = list(DESIGNS) if a.design == "all" else [a.design]
        rows = false_alarm_study(designs, a.false_alarms, a.steps, a.runs)
        total = sum(r["flagged"] for r in rows)
        n = sum(r["sessions"] for r in rows)
        print(json.dumps(rows, indent=1))
        print(f"{total} of {n} clean sessions flagged ({100 * total / n:.1f} %)")
        return 0
    if a.drift:
        designs = ["abbe", "full"] if a.design == "all" else [a.design]
        rows = drift_study(designs, a.machines, a.drift_um_per_h, a.steps, a.runs, a.grid,
                           progress=None if a.quiet else (lambda r: print(" ", r, flush=True)))
        summary = summarise_drift(rows)
        print(_markdown_drift(summary) if a.markdown else json.dumps(summary, indent=1))
        if a.json:
            a.json.write_text(json.dumps({"rows": rows, "summary": summary}, indent=1))
        return 0
    names = list(DESIGNS) if a.design == "all" else [a.design]
    summaries, everything = [], []
    for name in names:
        res = run_design(name, a.machines, a.steps, a.runs, a.grid, progress=show)
        summaries.append(summarise(res))
        everything += [{**asdict(r), "ratio": r.ratio} for r in res]
        if not a.markdown:
            print(json.dumps(summaries[-1], indent=1), flush=True)
    if a.markdown:
        print(_markdown(summaries))
    if a.json:
        a.json.write_text(json.dumps({"machines": everything, "summary": summaries}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
