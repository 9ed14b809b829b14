"""Expanded uncertainty of the ISO 230-2 parameters of one positioning test.

Every parameter is written as a function of the per-target means ``xbar_i_up``,
``xbar_i_down`` and standard deviations ``s_i_up``, ``s_i_down`` (ISO 230-2:2014 clause 3,
:mod:`volcal.standards.iso230_2`), at the targets where the data put its maximum and
minimum (first order: the max/min are taken where they are; GUM 5.1). The inputs:

* ``xbar_i`` = mean of the runs (type A: ``s_i / sqrt(n_i)``, ``n_i - 1`` degrees of
  freedom) + the systematic laser terms at ``L_i`` (:class:`~volcal.uncertainty.laser.
  LaserModel`, shared by all targets: a scale error) + a dead-path term;
* ``s_i`` with the standard uncertainty of a standard deviation of ``n`` normal
  readings, ``s / sqrt(2 (n - 1))`` (GUM E.4.3; ``n - 1`` degrees of freedom).

Hence (``k_e`` = 2, or 3 for the 1988 edition):

=============  =====================================================================
E, E_up, ...   ``xbar_a - xbar_b``: type A of both means + the scale terms
               ``(L_a - L_b) u_rel`` (correlated, so only the difference of lengths)
M              the same on ``(xbar_up + xbar_down) / 2``
A, A_up, ...   ``(xbar_a + k_e s_a) - (xbar_b - k_e s_b)``
R_up, R_down   ``2 k_e s_i``: the statistics of ``s`` only
R              ``k_e s_up + k_e s_down + |B_i|`` (or ``2 k_e s``): ``s`` and the type A
               of ``B_i``; the scale terms cancel (same ``L`` up and down)
B              ``|xbar_up - xbar_down|`` at its largest target: type A + dead path
B_mean         mean of the signed ``B_i``
=============  =====================================================================

The expanded uncertainty ``U = k u`` with ``k`` from the Welch-Satterthwaite effective
degrees of freedom (:mod:`volcal.uncertainty.propagation`). ISO/TR 230-9 could not be
sourced for this work; the structure above (the parameter as a function of its inputs,
systematic laser terms proportional to length, repeatability parameters from the
statistics of ``s``) is what its public summaries and ISO 230-2:2014 annex A describe;
docs/uncertainty.md says which parts are volcal's own choices.

References
----------
.. [1] ISO 230-2:2014, clause 3 and annex A.
.. [2] ISO/TR 230-9:2005, Estimation of measurement uncertainty for machine tool tests
   according to series ISO 230, basic equations.
.. [3] JCGM 100:2008 (GUM), E.4.3 (uncertainty of an experimental standard deviation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from volcal.standards.iso230_2 import AXIS_KEYS, EDITIONS
from volcal.uncertainty.budget import Budget
from volcal.uncertainty.laser import LaserModel
from volcal.uncertainty.propagation import Estimate, Propagator

__all__ = ["Iso2302Uncertainty", "budget_for", "datum_of", "evaluate_with_budget",
           "iso230_2_uncertainty"]


@dataclass
class Iso2302Uncertainty:
    """Uncertainty of an ISO 230-2 evaluation.

    Attributes
    ----------
    parameters : dict of str to Estimate
        ``A, A_up, ..., B_mean`` [um].
    targets : list of Estimate
        Mean bidirectional deviation of each target [um].
    reading : Estimate
        Budget of the mean bidirectional deviation at the target farthest from the datum
        (the measurement's budget table) [um].
    datum_mm : float
        Datum (where the laser was zeroed) [mm].
    length_mm : float
        Distance of that target from the datum [mm].
    notes : list of str
        What was assumed.
    """

    parameters: dict[str, Estimate]
    targets: list[Estimate]
    reading: Estimate
    datum_mm: float
    length_mm: float
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """``U_<key>`` per parameter, ``k`` (of A) and the budget, JSON-friendly."""
        def dof(x: float) -> float | None:
            return None if not math.isfinite(x) else float(x)

        out: dict[str, Any] = {f"U_{k}": e.U for k, e in self.parameters.items()}
        out["k"] = self.parameters["A"].k
        out["uncertainty"] = {
            "coverage_pct": 95.45,
            "parameters": {k: {"u": e.u, "dof": dof(e.dof), "k": e.k, "U": e.U,
                               "components": [c.to_dict() for c in e.components]}
                           for k, e in self.parameters.items()},
            "budget": {"measurand": "mean bidirectional positional deviation at "
                                    f"{self.length_mm:g} mm from the datum",
                       "datum_mm": self.datum_mm, "u_um": self.reading.u,
                       "dof": dof(self.reading.dof), "k": self.reading.k,
                       "U_um": self.reading.U,
                       "components": [c.to_dict() for c in self.reading.components]},
            "notes": list(self.notes)}
        return out


def datum_of(targets_mm: Any, budget: Budget) -> float:
    """The datum: ``[setup] datum_mm`` or the lowest target [mm].

    Parameters
    ----------
    targets_mm : array_like
        Target positions [mm].
    budget : Budget
        The budget.

    Returns
    -------
    float
    """
    d = budget.values.get("setup.datum_mm")
    return float(np.min(targets_mm)) if d is None else float(d)


def _n(v: Any, m: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(v, dtype=float), (m,))


def parameter_expressions(mu: list[Any], md: list[Any], su: list[Any], sd: list[Any],
                          ke: float, argmax: Any = np.argmax, argmin: Any = np.argmin
                          ) -> dict[str, Any]:
    """The ISO 230-2 parameters as propagated expressions of the per-target statistics.

    Parameters
    ----------
    mu, md : list
        Mean positional deviation per target, up and down (propagated inputs).
    su, sd : list
        Standard deviation per target, up and down (propagated inputs).
    ke : float
        Coverage factor of the edition (2 or 3).
    argmax, argmin : callable
        How the largest and smallest values are found (``np.nanargmax`` /
        ``np.nanargmin`` where a target may have no readings).

    Returns
    -------
    dict
        The expression of every key of :data:`volcal.standards.iso230_2.AXIS_KEYS`
        (ISO 230-2:2014 3.3 to 3.19; the same formulas as :func:`~volcal.standards.
        iso230_2.evaluate`, on the propagated inputs).
    """
    m = len(mu)
    mid = [(a + b) / 2 for a, b in zip(mu, md, strict=True)]

    def rng(vals: list[Any]) -> Any:
        x = np.array([float(v.x) for v in vals])
        return vals[int(argmax(x))] - vals[int(argmin(x))]

    def acc(means: list[Any], sds: list[Any]) -> Any:
        hi = [a + ke * s for a, s in zip(means, sds, strict=True)]
        lo = [a - ke * s for a, s in zip(means, sds, strict=True)]
        xh = np.array([float(v.x) for v in hi])
        xl = np.array([float(v.x) for v in lo])
        return hi[int(argmax(xh))] - lo[int(argmin(xl))]

    def largest(vals: list[Any]) -> Any:
        return vals[int(argmax([float(v.x) for v in vals]))]

    b = [a - c for a, c in zip(mu, md, strict=True)]
    babs = [v if float(v.x) >= 0 else -v for v in b]
    r_bi = [ke * su[i] + ke * sd[i] + babs[i] for i in range(m)]
    return {
        "A": acc(mu + md, su + sd), "A_up": acc(mu, su), "A_down": acc(md, sd),
        "E": rng(mu + md), "E_up": rng(mu), "E_down": rng(md), "M": rng(mid),
        "R": largest(r_bi + [2 * ke * s for s in su] + [2 * ke * s for s in sd]),
        "R_up": largest([2 * ke * s for s in su]),
        "R_down": largest([2 * ke * s for s in sd]),
        "B": largest(babs), "B_mean": sum(b) / m,
    }


def iso230_2_uncertainty(res: Any, budget: Budget, datum_mm: float | None = None
                         ) -> Iso2302Uncertainty:
    """Expanded uncertainty of every ISO 230-2 parameter and every target's mean.

    Parameters
    ----------
    res : Iso2302Result
        The evaluation of the readings as the session records them.
    budget : Budget
        Instrument, environment and set-up uncertainties.
    datum_mm : float, optional
        Where the laser was zeroed [mm] (default :func:`datum_of`).

    Returns
    -------
    Iso2302Uncertainty
    """
    t = res.targets
    m = t.target_mm.size
    datum = datum_of(t.target_mm, budget) if datum_mm is None else float(datum_mm)
    prop = Propagator()
    laser = LaserModel(budget, prop)
    ke = EDITIONS[res.edition]
    # runs that reached each target (incomplete tests: fewer than the runs of the test)
    nu = _n(t.n_up if getattr(t, "n_up_target", None) is None else t.n_up_target, m)
    nd = _n(t.n_down if getattr(t, "n_down_target", None) is None else t.n_down_target, m)
    L = t.target_mm - datum

    notes: list[str] = []

    def mean(label: str, x: float, s: float, n: float) -> Any:
        if not (math.isfinite(s) and n >= 2):
            notes.append(f"a target with {n:g} run(s) in direction {label}: no "
                         "repeatability term there (a standard deviation needs two runs)")
            return prop.input(f"repeatability ({label})", x, 0.0)
        return prop.input(f"repeatability ({label})", x, s / math.sqrt(n), n - 1.0,
                          unit="um")

    def sdev(label: str, s: float, n: float) -> Any:
        if not (math.isfinite(s) and n >= 2):
            return prop.input(f"standard deviation s ({label})", 0.0, 0.0)
        return prop.input(f"standard deviation s ({label})", s,
                          s / math.sqrt(2.0 * (n - 1.0)), n - 1.0, unit="um")

    mu, md, su, sd = [], [], [], []
    for i in range(m):
        sys_i = laser.length_term(L[i])
        mu.append(mean("+", t.mean_up[i], t.s_up[i], nu[i]) + sys_i + laser.dead_path())
        md.append(mean("-", t.mean_down[i], t.s_down[i], nd[i]) + sys_i + laser.dead_path())
        su.append(sdev("+", t.s_up[i], nu[i]))
        sd.append(sdev("-", t.s_down[i], nd[i]))
    mid = [(a + b) / 2 for a, b in zip(mu, md, strict=True)]

    expr = parameter_expressions(mu, md, su, sd, ke)
    params = {k: prop.estimate(expr[k]) for k in AXIS_KEYS}
    targets = [prop.estimate(v) for v in mid]
    far = int(np.argmax(np.abs(L)))
    notes = list(budget.notes) + sorted(set(notes))
    notes.append(f"datum (laser zeroed) at {datum:g} mm"
                 + ("" if budget.values.get("setup.datum_mm") is not None
                    else " (the lowest target; set [setup] datum_mm otherwise)"))
    return Iso2302Uncertainty(params, targets, targets[far], datum, float(L[far]), notes)


def budget_for(d: Any, budget: Budget) -> Budget:
    """The budget at the operating point the readings record, cross-checked with them.

    Parameters
    ----------
    d : PositioningData or Measurement
        Readings; ``thermal`` (positioning data) or the measurement's record
        (:func:`volcal.environment.apply.thermal_record`) when they come from a session.
    budget : Budget
        The budget.

    Returns
    -------
    Budget
        :meth:`Budget.at` the recorded operating point (the budget's values serve only
        what the session does not record).

    Warns
    -----
    BudgetWarning
        The budget's retired ``[material] referred_to_20c`` disagrees with the record.
    """
    from volcal.uncertainty.budget import cross_check_referral

    rec = _thermal_of(d)
    what = (f"measurement {d.id!r}" if hasattr(d, "id")
            else str(getattr(d, "file", "the readings")))
    given = None if rec is None else {"laser software": True, "volcal": False,
                                      "not referred": False}.get(rec["referred_by"])
    cross_check_referral(budget, given, what)  # the readings as given, before volcal's
    return budget if rec is None else budget.at(rec["operating_point"])


def _thermal_of(d: Any) -> dict[str, Any] | None:
    """The thermal record of positioning data or of a session measurement (None: none)."""
    if hasattr(d, "meta") and hasattr(d, "kind"):
        from volcal.environment.apply import thermal_record

        return thermal_record(d)
    return getattr(d, "thermal", None)


def evaluate_with_budget(d: Any, budget: Budget, edition: str = "2014"
                         ) -> tuple[Any, Iso2302Uncertainty, dict[str, Any]]:
    """Evaluate a positioning test's readings (ISO 230-2) and their uncertainty.

    The readings are evaluated as they are: referred to 20 degC (or not) as the session
    records it, once, where the session is read
    (:func:`volcal.environment.apply.prepare_readings`); the budget gives the
    uncertainties only (its operating point serves the sensitivities where the session
    records none), so every parameter has the same value with and without a budget.

    Parameters
    ----------
    d : PositioningData
        Readings (:mod:`volcal.standards.positioning_data`).
    budget : Budget
        The budget.
    edition : str
        ISO 230-2 edition.

    Returns
    -------
    res : Iso2302Result
        Parameters of the readings (the same as without a budget).
    unc : Iso2302Uncertainty
        Their uncertainty.
    corrections : dict
        What the readings are (JSON-friendly): nothing is applied by the budget
        (``material_applied`` and ``cosine_expectation_applied`` false,
        ``largest_correction_um`` 0); ``thermal``: how the readings were compensated and
        referred; a sentence in ``'text'``.
    """
    from volcal.standards.iso230_2 import evaluate

    b = budget_for(d, budget)
    datum = datum_of(d.targets_mm, b)
    length = np.asarray(d.targets_mm, dtype=float) - datum
    kw = d.evaluate_kwargs() if hasattr(d, "evaluate_kwargs") else {"file": d.file,
                                                                     "rows": d.rows}
    res = evaluate(d.targets_mm, d.run, d.direction, np.asarray(d.deviation_um, dtype=float),
                   edition, **kw)
    unc = iso230_2_uncertainty(res, b, datum)
    v = b.values
    rec = _thermal_of(d)
    th = b.inputs["setup.u_misalignment_urad"].u
    far = int(np.argmax(np.abs(length)))
    text = ("no correction by the budget (it gives uncertainties only; the readings are "
            "evaluated as the session refers them to 20 °C): its operating point serves the "
            "sensitivities where the session records none; the cosine error (u_theta = "
            f"{th:g} urad) is an uncorrected bias in U"
            f"; correction at {length[far]:g} mm from the datum: {0.0:+.4f} um")
    corrections = {"material_applied": False,
                   "material_temperature_c": v["material.temperature_c"],
                   "expansion_ppm_per_k": v["material.expansion_ppm_per_k"],
                   "cosine_expectation_applied": False, "datum_mm": datum,
                   "largest_correction_um": 0.0, "text": text}
    if rec is not None:
        corrections["thermal"] = {k: rec[k] for k in rec if k != "operating_point"}
    return res, unc, corrections
