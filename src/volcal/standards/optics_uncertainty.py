"""Expanded uncertainty of each direct optic's own evaluation (ISO 230-1), from a budget.

Each result of :func:`volcal.standards.optics.evaluate_optics` is written as a function of
the line's true readings ``t_i``, propagated to first order on GTC
(:mod:`volcal.uncertainty.propagation`), ``U = k u`` at 95.45 % (``k`` from the
Welch-Satterthwaite degrees of freedom; 2 for type B inputs known exactly). The measured
reading is ``y_i = (1 + g) t_i + e_i``, so ``t_i = y_i (1 - g) - e_i`` to first order,
with the inputs (``[optics]`` of the budget, :mod:`volcal.uncertainty.budget`):

* ``g``: the optic's scale (calibration) error, ``u_<kind>_scale_pct``; one uncertain
  number per optic (target), shared by every line read with it (``scale_correlation =
  "instrument"``, the default), or one per line (``"measurement"``);
* ``e_i``: one reading's error, ``u_straightness_um`` (``u_angular_urad``,
  ``u_level_urad``, ``u_roll_urad``), independent from reading to reading;
* an optical-square pair's square: its certificate, ``[references.NAME]
  square_deviation_urad`` with ``u_square_urad`` (the session's, not the budget's).

Every evaluation is linear in ``t`` between the readings where the data put the maximum
and the minimum (first order: the extremes are taken where they are; GUM 5.1):

=========================  ===========================================================
straightness deviation     ``r_a - r_b`` of the residuals about the reference line
                           (least squares or end points): ``c . t``, so
                           ``u^2 = (S u_g)^2 + u_e^2 |c|^2`` with ``S`` the straightness
slope of a line            ``sum w_i t_i`` (least squares) or the end points'
angular deviation          ``t_a - t_b``: ``u^2 = (range u_g)^2 + 2 u_e^2``
squareness                 ``-(slope_1 + slope_2) + delta``: with one optic for both
                           lines the scale error enters by ``|angle - delta| u_g`` (the
                           reference optic's rotation cancels in the sum, its scale error
                           too), plus both slopes' reading terms and ``u(delta)``
=========================  ===========================================================

A reading's zero (the instrument's offset) cancels: every reading is taken since the
line's first row. Repeated runs enter through the readings themselves (the ISO 230-1
value is the range over all of them), not as a separate term. The fused model's
uncertainty of the same quantities is :mod:`volcal.standards.model_uncertainty`'s.

References
----------
.. [1] ISO 230-1:2012, 3.4 (straightness), 3.5 (angular deviation), 10.3 (squareness).
.. [2] JCGM 100:2008 (GUM), 5.1 (first-order propagation), G.4 (effective degrees of
   freedom), F.2.4.5 (one-sided terms, not needed here).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from volcal.session.format import Measurement, Session
from volcal.uncertainty.budget import OPTIC_KEYS, Budget
from volcal.uncertainty.propagation import COVERAGE_PCT, Estimate, Propagator

__all__ = ["add_optics_uncertainty", "optics_uncertainty"]

_UNIT = {"straightness_optics": "um", "angular_optics": "urad", "level": "urad",
         "roll_optics": "urad"}


class _Lines:
    """Uncertain linear functions of a line's true readings (shared scale per optic).

    A result ``c . t`` of a line's true readings ``t = y (1 - g) - e`` is
    ``c . y - (c . y) g - c . e``; the readings' part ``c . e`` of independent readings of
    one standard uncertainty ``u_e`` and ``nu`` degrees of freedom enters as one input of
    sensitivity ``|c|`` and Welch-Satterthwaite degrees of freedom
    ``nu (sum c_i^2)^2 / sum c_i^4``: the same u and effective degrees of freedom as one
    input per reading, at a cost linear in the number of readings (a dynamic capture has
    thousands). Two results of one line never enter one squareness together, so their
    readings' parts may be separate inputs.
    """

    def __init__(self, budget: Budget, prop: Propagator) -> None:
        self.b = budget
        self.prop = prop
        self.per_line = budget.values.get("optics.scale_correlation") == "measurement"
        self.scales: dict[str, Any] = {}

    def scale(self, m: Measurement) -> Any:
        key = m.id if self.per_line else m.target
        if key not in self.scales:
            inp = self.b.inputs[OPTIC_KEYS[m.target][0]]
            self.scales[key] = self.prop.input(f"scale of the {key.replace('_', ' ')}"
                                               + (" optic" if self.per_line else ""),
                                               0.0, inp.u * 1e-2, inp.dof, inp.distribution,
                                               unit="-")
        return self.scales[key]

    def combine(self, m: Measurement, c: np.ndarray) -> Any:
        """``c . t`` as an uncertain number [the readings' unit times c's]."""
        v = float(c @ np.asarray(m.deviation, dtype=float))
        out = v - v * self.scale(m)
        c2 = float(c @ c)
        if c2 > 0:
            inp = self.b.inputs[OPTIC_KEYS[m.target][1]]
            dof = inp.dof * c2**2 / float(np.sum(c**4)) if math.isfinite(inp.dof) else math.inf
            out = out + math.sqrt(c2) * self.prop.input(
                f"reading, {m.id}", 0.0, inp.u, dof, inp.distribution, unit=_UNIT[m.target])
        return out


def _straightness(lines: _Lines, m: Measurement) -> dict[str, tuple[Any, Any]]:
    """Uncertain straightness [um] and slope [urad] for each reference line."""
    from volcal.standards.straightness import straightness

    s = m.positions[:, m.axis]
    y = np.asarray(m.deviation, dtype=float)
    n = s.size
    out = {}
    for ref in ("end_point", "least_squares"):
        if ref == "least_squares":
            w = (s - s.mean()) / float(np.sum((s - s.mean()) ** 2))   # slope [um/mm per um]
        else:
            i0, i1 = int(np.argmin(s)), int(np.argmax(s))
            w = np.zeros(n)
            w[i1], w[i0] = 1.0 / (s[i1] - s[i0]), -1.0 / (s[i1] - s[i0])
        r = straightness(s, y, ref).residuals_um
        a, b = int(np.argmax(r)), int(np.argmin(r))
        c = -(s[a] - s[b]) * w  # r_a - r_b: the reference line's level cancels
        c[a] += 1.0
        c[b] -= 1.0
        out[ref] = (lines.combine(m, c), lines.combine(m, w * 1e3))
    return out


def _angular(lines: _Lines, m: Measurement) -> Any:
    x = np.asarray(m.deviation, dtype=float)
    c = np.zeros(x.size)
    c[int(np.argmax(x))] += 1.0
    c[int(np.argmin(x))] -= 1.0
    return lines.combine(m, c)


def _dict(e: Estimate) -> dict[str, Any]:
    return {"u": e.u, "dof": None if not math.isfinite(e.dof) else float(e.dof), "k": e.k,
            "U": e.U, "components": [c.to_dict() for c in e.components]}


def optics_uncertainty(session: Session, budget: Budget,
                       evaluation: dict[str, Any] | None = None) -> dict[str, Any]:
    """Expanded uncertainty of every direct optic's ISO 230-1 evaluation.

    Parameters
    ----------
    session : Session
        A measured session with straightness or angular measurements.
    budget : Budget
        The uncertainty budget (its ``[optics]`` section, or its data-sheet defaults).
    evaluation : dict, optional
        :func:`volcal.standards.optics.evaluate_optics` of the session (computed when
        not given): the squareness pairs are taken from it.

    Returns
    -------
    dict
        ``straightness`` (id -> reference -> ``U_straightness_um``, ``U_slope_urad``,
        ``k`` and the budgets), ``angular`` (id -> ``U_angular_deviation_urad``, ``k``),
        ``squareness`` (one per pair, in the order of the evaluation: reference ->
        ``U_angle_minus_90_urad``, ``U_<name>``, ``k``), ``notes``.
    """
    from volcal.session.optics import DEFAULT_U_SQUARE_URAD
    from volcal.standards.optics import evaluate_optics

    ev = evaluate_optics(session) if evaluation is None else evaluation
    prop = Propagator()
    lines = _Lines(budget, prop)
    by_id = {m.id: m for m in session.measurements}
    out: dict[str, Any] = {"straightness": {}, "angular": {}, "squareness": []}
    slopes: dict[str, dict[str, Any]] = {}
    for mid in ev["straightness"]:
        res = _straightness(lines, by_id[mid])
        slopes[mid] = {ref: v[1] for ref, v in res.items()}
        entry = {}
        for ref, (st, sl) in res.items():
            es, el = prop.estimate(st), prop.estimate(sl)
            entry[ref] = {"U_straightness_um": es.U, "U_slope_urad": el.U, "k": es.k,
                          "uncertainty": {"straightness_um": _dict(es),
                                          "slope_urad": _dict(el)}}
        out["straightness"][mid] = entry
    for mid in ev["angular"]:
        e = prop.estimate(_angular(lines, by_id[mid]))
        out["angular"][mid] = {"U_angular_deviation_urad": e.U, "k": e.k,
                               "uncertainty": {"angular_deviation_urad": _dict(e)}}
    for pair in ev["squareness"]:
        name, ref_name = pair["name"], pair["reference"]
        cert = session.references.get(ref_name, {})
        delta = prop.input(f"optical square {ref_name!r} (certificate)",
                           float(cert.get("square_deviation_urad", 0.0)),
                           float(cert.get("u_square_urad", DEFAULT_U_SQUARE_URAD)),
                           unit="urad")
        entry = {}
        for ref in ("least_squares", "end_point"):
            a, b = pair["lines"]
            e = prop.estimate(-(slopes[a][ref] + slopes[b][ref]) + delta)
            entry[ref] = {"U_angle_minus_90_urad": e.U, f"U_{name}": e.U, "k": e.k,
                          "uncertainty": {"angle_minus_90_urad": _dict(e)}}
        out["squareness"].append(entry)
    notes = [f"U = k u at {COVERAGE_PCT:.2f} % (k from the effective degrees of freedom); "
             "first order, the extremes taken where the data put them"]
    corr = budget.values.get("optics.scale_correlation", "instrument")
    notes.append("each optic's scale error is common to every line read with it"
                 if corr == "instrument" else
                 "one scale error per line ([optics] scale_correlation = \"measurement\")")
    used = {by_id[k].target for k in [*ev["straightness"], *ev["angular"]]}
    keys = [k for t in sorted(used) for k in OPTIC_KEYS[t]]
    dflt = [k.split(".", 1)[1] for k in keys if k in budget.defaulted]
    if dflt:
        notes.append("not in the budget file, data-sheet defaults used: [optics] "
                     + ", ".join(f"{k} = {budget.inputs['optics.' + k].u:.3g}"
                                 for k in dflt))
    out["notes"] = notes
    return out


def add_optics_uncertainty(evaluation: dict[str, Any], unc: dict[str, Any]) -> dict[str, Any]:
    """Put the ``U_<key>`` of :func:`optics_uncertainty` beside the evaluation's keys.

    Parameters
    ----------
    evaluation : dict
        :func:`volcal.standards.optics.evaluate_optics` (changed in place).
    unc : dict
        :func:`optics_uncertainty` of the same session.

    Returns
    -------
    dict
        ``evaluation`` with ``U_straightness_um``, ``U_slope_urad`` and ``k`` in each
        line's ``end_point`` and ``least_squares``; ``U_angular_deviation_urad`` and ``k``
        in each angular line; ``U_angle_minus_90_urad``, ``U_<name>`` and ``k`` in each
        squareness pair's references; the budgets under ``uncertainty``.
    """
    budgets: dict[str, Any] = {"coverage_pct": COVERAGE_PCT, "straightness": {},
                               "angular": {}, "squareness": [], "notes": unc["notes"]}
    for mid, entry in unc["straightness"].items():
        budgets["straightness"][mid] = {}
        for ref, e in entry.items():
            evaluation["straightness"][mid][ref].update(
                {k: v for k, v in e.items() if k != "uncertainty"})
            budgets["straightness"][mid][ref] = e["uncertainty"]
    for mid, e in unc["angular"].items():
        evaluation["angular"][mid].update({k: v for k, v in e.items() if k != "uncertainty"})
        budgets["angular"][mid] = e["uncertainty"]
    for pair, entry in zip(evaluation["squareness"], unc["squareness"], strict=True):
        b = {}
        for ref, e in entry.items():
            pair[ref].update({k: v for k, v in e.items() if k != "uncertainty"})
            b[ref] = e["uncertainty"]
        budgets["squareness"].append(b)
    evaluation["uncertainty"] = budgets
    return evaluation
