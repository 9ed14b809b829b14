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
    """The uncertain true readings of each line (shared scale inputs per optic)."""

    def __init__(self, budget: Budget, prop: Propagator) -> None:
        self.b = budget
        self.prop = prop
        self.per_line = budget.values.get("optics.scale_correlation") == "measurement"
        self.scales: dict[str, Any] = {}
        self.cache: dict[str, list[Any]] = {}

    def scale(self, m: Measurement) -> Any:
        key = m.id if self.per_line else m.target
        if key not in self.scales:
            inp = self.b.inputs[OPTIC_KEYS[m.target][0]]
            self.scales[key] = self.prop.input(f"scale of the {key.replace('_', ' ')}"
                                               + (" optic" if self.per_line else ""),
                                               0.0, inp.u * 1e-2, inp.dof, inp.distribution,
                                               unit="-")
        return self.scales[key]

    def readings(self, m: Measurement) -> list[Any]:
        if m.id not in self.cache:
            g = self.scale(m)
            inp = self.b.inputs[OPTIC_KEYS[m.target][1]]
            y = np.asarray(m.deviation, dtype=float)
            self.cache[m.id] = [
                float(v) - float(v) * g + self.prop.input(
                    f"reading, {m.id}", 0.0, inp.u, inp.dof, inp.distribution,
                    unit=_UNIT[m.target])
                for v in y]
        return self.cache[m.id]


def _reference_line(s: np.ndarray, t: list[Any], reference: str) -> tuple[Any, Any, float]:
    """Slope [um/mm] and value at ``s0`` of the reference line, as uncertain numbers."""
    if reference == "least_squares":
        s0 = float(np.mean(s))
        w = (s - s0) / float(np.sum((s - s0) ** 2))
        slope = sum(float(wi) * ti for wi, ti in zip(w, t, strict=True))
        level = sum(t) / len(t)
        return slope, level, s0
    i0, i1 = int(np.argmin(s)), int(np.argmax(s))
    return (t[i1] - t[i0]) / float(s[i1] - s[i0]), t[i0], float(s[i0])


def _straightness(lines: _Lines, m: Measurement) -> dict[str, tuple[Any, Any]]:
    """Uncertain straightness [um] and slope [urad] for each reference line."""
    s = m.positions[:, m.axis]
    t = lines.readings(m)
    out = {}
    for ref in ("end_point", "least_squares"):
        slope, level, s0 = _reference_line(s, t, ref)
        r = [ti - level - slope * float(si - s0) for ti, si in zip(t, s, strict=True)]
        x = np.array([float(v.x) if hasattr(v, "x") else float(v) for v in r])
        out[ref] = (r[int(np.argmax(x))] - r[int(np.argmin(x))], slope * 1e3)
    return out


def _angular(lines: _Lines, m: Measurement) -> Any:
    t = lines.readings(m)
    x = np.asarray(m.deviation, dtype=float)
    return t[int(np.argmax(x))] - t[int(np.argmin(x))]


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
