"""The certificate's direct-optics results: straightness, angular deviation, squareness.

One session's direct optics (``straightness`` and ``angular`` measurements,
``docs/formats.md``) evaluated each on its own (ISO 230-1:2012;
:func:`volcal.standards.optics.evaluate_optics`) and, with an uncertainty budget, with the
expanded uncertainty of each result (:func:`volcal.standards.optics_uncertainty.
optics_uncertainty`): the same numbers as ``volcal evaluate optics --budget B --json``.
The certificate states one reference line, the least-squares line (ISO 230-1's default;
the end-point figures are in the technical report and in ``evaluate optics``).

Besides the results: the as-found / as-left pairs of these quantities
(:func:`optics_pairs`), their statements of conformity with the tolerance's
``X.straightness_um`` and ``EC0Y.squareness_urad`` limits (:func:`optics_conformity`),
and their budget tables (:func:`optics_budgets`).

References
----------
.. [1] ISO 230-1:2012, straightness (least-squares reference line), angular deviation,
   squareness by optical square (10.3).
.. [2] ISO/IEC 17025:2017, 7.8.4.1 (the uncertainty of each result on a certificate).
"""

from __future__ import annotations

import math
import re
from typing import Any

__all__ = ["REFERENCE_LINE", "direct_optics", "optics_budgets", "optics_conformity",
           "optics_pairs"]

REFERENCE_LINE = "least_squares"
"""The reference line of every straightness and squareness on the certificate
(``'least_squares'``, ISO 230-1; ``evaluate optics`` also gives ``'end_point'``)."""
REFERENCE_TEXT = ("least-squares reference line (ISO 230-1:2012); the squareness from the "
                  "least-squares lines of the two optical-square lines, corrected by the "
                  "square's certificate")
"""The reference line as stated on the certificate."""


def _f(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def direct_optics(session: Any, budget: Any = None,
                  evaluation: dict[str, Any] | None = None) -> dict[str, Any] | None:
    """The direct optics' results of one session, as stated on the certificate.

    Parameters
    ----------
    session : Session
        A measured session.
    budget : Budget, optional
        Uncertainty budget (its ``[optics]`` section, data-sheet defaults when absent);
        without it every ``U`` and ``k`` is null.
    evaluation : dict, optional
        The optics of the session's evaluation with this ``budget``
        (:attr:`volcal.standards.session.SessionEvaluation.optics`): formatted as given;
        evaluated here (:func:`volcal.standards.session.optics_evaluation`) when omitted.

    Returns
    -------
    dict or None
        None when the session has no straightness or angular measurement with readings.
        Otherwise ``reference_line`` (``'least_squares'``), ``reference``,
        ``uncertainty_evaluated``, ``notes`` and three lists:

        * ``straightness``: ``measurement``, ``axis`` and ``error_direction`` (upper
          case), ``reference_line``, ``length_mm``, ``straightness_um`` [um], ``U_um``
          [um], ``k`` (and ``note`` when the instrument removed the slope);
        * ``angular``: ``measurement``, ``axis``, ``rotation`` (A, B, C), ``target``
          (``angular_optics``, ``level``, ``roll_optics``), ``angular_deviation_urad``
          (the range over the travel) [urad], ``min_urad``, ``max_urad``, ``U_urad``,
          ``k``;
        * ``squareness``: ``name`` (EC0Y, EB0Z, EA0Z), ``reference`` (the reference
          group), ``lines``, ``axes``, ``reference_line``, ``value_urad`` (the volcal
          name's value) [urad], ``U_urad``, ``k``, ``square_deviation_urad`` and
          ``u_square_urad`` (the optical square's certificate and its standard
          uncertainty, ``u_square_source``: ``'references.NAME'`` or ``'default'``).
    """
    from volcal.session.optics import DEFAULT_U_SQUARE_URAD

    ev = evaluation
    if ev is None:
        from volcal.standards.session import optics_evaluation

        ev = optics_evaluation(session, budget)
    if ev is None or not (ev["straightness"] or ev["angular"]):
        return None
    ref = REFERENCE_LINE
    st = []
    for mid, r in ev["straightness"].items():
        e = r[ref]
        row = {"measurement": mid, "axis": r["axis"].upper(),
               "error_direction": r["error_direction"].upper(), "reference_line": ref,
               "length_mm": float(r["length_mm"]),
               "straightness_um": float(e["straightness_um"]),
               "U_um": _f(e.get("U_straightness_um")), "k": _f(e.get("k"))}
        if r.get("note"):
            row["note"] = r["note"]
        st.append(row)
    ang = [{"measurement": mid, "axis": r["axis"].upper(), "rotation": r["rotation"].upper(),
            "target": r["target"], "angular_deviation_urad": float(r["angular_deviation_urad"]),
            "min_urad": float(r["min_urad"]), "max_urad": float(r["max_urad"]),
            "U_urad": _f(r.get("U_angular_deviation_urad")), "k": _f(r.get("k"))}
           for mid, r in ev["angular"].items()]
    sq = []
    for p in ev["squareness"]:
        cert = session.references.get(p["reference"], {}) or {}
        e = p[ref]
        sq.append({"name": p["name"], "reference": p["reference"], "lines": list(p["lines"]),
                   "axes": p["axes"].upper(), "reference_line": ref,
                   "value_urad": float(e[p["name"]]), "U_urad": _f(e.get(f"U_{p['name']}")),
                   "k": _f(e.get("k")),
                   "square_deviation_urad": float(p["square_deviation_urad"]),
                   "u_square_urad": float(cert.get("u_square_urad", DEFAULT_U_SQUARE_URAD)),
                   "u_square_source": (f"references.{p['reference']}"
                                       if "u_square_urad" in cert else "default")})
    notes = list(ev["uncertainty"]["notes"]) if budget is not None else [
        "no uncertainty budget given: the expanded uncertainties were not evaluated"]
    out = {"reference_line": ref, "reference": REFERENCE_TEXT,
           "uncertainty_evaluated": budget is not None, "notes": notes,
           "straightness": st, "angular": ang, "squareness": sq}
    if budget is not None:
        out["_budgets"] = ev["uncertainty"]  # taken out by the certificate (budget tables)
    return out


def _key(p: dict[str, Any]) -> str:
    return f"{p['name']} ({p['reference']}: {' + '.join(p['lines'])})"


def optics_pairs(found: dict[str, Any] | None, left: dict[str, Any] | None
                 ) -> list[dict[str, Any]]:
    """Pair the as-found and as-left direct-optics results quantity by quantity.

    Parameters
    ----------
    found, left : dict or None
        :func:`direct_optics` of the two sessions.

    Returns
    -------
    list of dict
        ``measurement`` (id; for a squareness its name, reference group and lines),
        ``axis``, ``quantity`` (``straightness``, ``angular deviation``, ``squareness``),
        ``unit`` (``'um'`` or ``'urad'``), ``as_found``, ``as_left``; only what both
        sessions measured (same measurement id, same optical-square pair).
    """
    if not found or not left:
        return []
    rows = []
    ls = {r["measurement"]: r for r in left["straightness"]}
    for r in found["straightness"]:
        if (o := ls.get(r["measurement"])) is not None:
            rows.append({"measurement": r["measurement"],
                         "axis": f"{r['axis']} along {r['error_direction']}",
                         "quantity": "straightness", "unit": "um",
                         "as_found": r["straightness_um"], "as_left": o["straightness_um"]})
    la = {r["measurement"]: r for r in left["angular"]}
    for r in found["angular"]:
        if (o := la.get(r["measurement"])) is not None:
            rows.append({"measurement": r["measurement"],
                         "axis": f"{r['axis']} about {r['rotation']}",
                         "quantity": "angular deviation", "unit": "urad",
                         "as_found": r["angular_deviation_urad"],
                         "as_left": o["angular_deviation_urad"]})
    lq = {_key(p): p for p in left["squareness"]}
    for p in found["squareness"]:
        if (o := lq.get(_key(p))) is not None:
            rows.append({"measurement": _key(p), "axis": p["axes"], "quantity": "squareness",
                         "unit": "urad", "as_found": p["value_urad"],
                         "as_left": o["value_urad"]})
    return rows


def optics_conformity(tolerance: Any, results: dict[str, Any], rule: str,
                      guard_band_um: float | None) -> tuple[list[dict], list[dict]]:
    """Statements of conformity of the straightness and squareness limits.

    Parameters
    ----------
    tolerance : Tolerance
        Its ``straightness_um`` (axis -> limit [um]: the straightness of every line moving
        along the axis, either error direction) and ``squareness_urad`` (EC0Y, EB0Z, EA0Z
        -> limit on the magnitude [urad]); absent attributes mean no limit.
    results : dict
        ``{'as_found': ..., 'as_left': ...}`` of the certificate, each with its
        ``direct_optics`` (:func:`direct_optics`, or None).
    rule : {'simple', 'guarded'}
        The decision rule (:func:`volcal.standards.decision.conformity_verdict`).
    guard_band_um : float or None
        Guard band [um]: applies to the straightness; the squareness (in urad) takes its
        own U as guard band.

    Returns
    -------
    um : list of dict
        Straightness statements, the keys of the certificate's ``statements`` (the
        largest straightness of the axis' lines, with its U).
    urad : list of dict
        Squareness statements: ``state``, ``quantity``, ``tolerance_urad``,
        ``value_urad`` (the largest magnitude over the name's optical-square pairs),
        ``U_urad``, ``verdict``, ``note``.
    """
    from volcal.standards.decision import conformity_verdict

    st_lim = getattr(tolerance, "straightness_um", None) or {}
    sq_lim = getattr(tolerance, "squareness_urad", None) or {}
    um: list[dict] = []
    urad: list[dict] = []
    for state, res in results.items():
        if res is None:
            continue
        opt = res.get("direct_optics") or {"straightness": [], "squareness": []}
        for axis, T in st_lim.items():
            lines = [r for r in opt["straightness"] if r["axis"] == axis]
            if not lines:
                um.append({"state": state, "quantity": f"{axis}: straightness (ISO 230-1)",
                           "tolerance_um": T, "value_um": None, "U_um": None,
                           "verdict": None, "note": f"no straightness line along {axis}"})
                continue
            w = max(lines, key=lambda r: r["straightness_um"])
            verdict, note = conformity_verdict(w["straightness_um"], T, rule, w["U_um"],
                                               guard_band_um)
            um.append({"state": state, "quantity": f"{axis}: straightness, least-squares "
                       f"line ({w['measurement']}, along {w['error_direction']}"
                       + (f"; largest of {len(lines)} lines" if len(lines) > 1 else "")
                       + ")", "tolerance_um": T,
                       "value_um": w["straightness_um"], "U_um": w["U_um"],
                       "verdict": verdict, "note": note})
        for name, T in sq_lim.items():
            pairs = [p for p in opt["squareness"] if p["name"] == name]
            if not pairs:
                urad.append({"state": state, "quantity": f"|{name}| (optical square)",
                             "tolerance_urad": T, "value_urad": None, "U_urad": None,
                             "verdict": None, "note": f"no optical-square pair gives {name}"})
                continue
            w = max(pairs, key=lambda p: abs(p["value_urad"]))
            verdict, note = conformity_verdict(abs(w["value_urad"]), T, rule, w["U_urad"],
                                               None)
            urad.append({"state": state, "quantity": f"|{name}|, least-squares lines "
                         f"(optical square {w['reference']!r}, {' + '.join(w['lines'])}"
                         + (f"; largest of {len(pairs)} pairs" if len(pairs) > 1 else "")
                         + ")", "tolerance_urad": T, "value_urad": abs(w["value_urad"]),
                         "U_urad": w["U_urad"], "verdict": verdict,
                         "note": re.sub(r" um\b", " urad", note)})
    return um, urad


def optics_budgets(opt: dict[str, Any] | None, suffix: str = "") -> dict[str, Any]:
    """The budget tables of the direct optics' results (least-squares line).

    Parameters
    ----------
    opt : dict or None
        :func:`direct_optics` with a budget (its ``_budgets``).
    suffix : str
        Appended to each name (``' (as-left)'``).

    Returns
    -------
    dict
        Name -> ``measurand``, ``u_um``/``u_urad``, ``dof``, ``k``, ``U_um``/``U_urad``,
        ``components`` (label, u, share, distribution, sensitivity, input u, unit).
    """
    if opt is None or not opt.get("_budgets"):
        return {}
    b = opt["_budgets"]
    out: dict[str, Any] = {}

    def entry(what: str, est: dict[str, Any], unit: str) -> dict[str, Any]:
        return {"measurand": what, f"u_{unit}": est["u"], "dof": est["dof"], "k": est["k"],
                f"U_{unit}": est["U"], "components": est["components"]}

    for r in opt["straightness"]:
        est = b["straightness"][r["measurement"]][REFERENCE_LINE]["straightness_um"]
        out[f"{r['measurement']}{suffix}"] = entry(
            f"straightness of {r['axis']} along {r['error_direction']}, least-squares line "
            "[µm]", est, "um")
    for r in opt["angular"]:
        est = b["angular"][r["measurement"]]["angular_deviation_urad"]
        out[f"{r['measurement']}{suffix}"] = entry(
            f"angular deviation of {r['axis']} about {r['rotation']} [µrad]", est, "urad")
    for p, bq in zip(opt["squareness"], b["squareness"], strict=True):
        est = bq[REFERENCE_LINE]["angle_minus_90_urad"]
        out[f"{_key(p)}{suffix}"] = entry(f"squareness {p['name']}, least-squares lines "
                                          "[µrad]", est, "urad")
    return out
