"""The certificate's location-error section: what ``results.*.location`` states.

Built from the one location evaluation of a session
(:func:`volcal.identify.location_evaluation.locate_session`): every location error of
each 5-axis chain with its U (k = 2) or "redundant (held at zero)", the scatter of the
sphere centre before and after, and the ISO 10791-6-style test of every path against
the tolerance given (``volcal report --location-tolerance-um``), by the decision rules of
the linear axes (:mod:`volcal.standards.decision`).
"""

from __future__ import annotations

from typing import Any

__all__ = ["location_results"]


def location_results(located: list[Any], tolerance: Any = None) -> list[dict[str, Any]]:
    """``results.<state>.location`` of the certificate (schema ``$defs/location``).

    Parameters
    ----------
    located : list of LocatedChain
        The session's location evaluation.
    tolerance : LocationTolerance, optional
        Tolerance and decision rule of the per-path test; None: no verdicts.

    Returns
    -------
    list of dict
        One entry per chain.
    """
    from volcal.identify.location_evaluation import COVERAGE_K, path_decisions
    from volcal.standards.decision import RULE_TEXT, combine

    out = []
    for lc in located:
        res = lc.result
        dec = ({} if tolerance is None else {
            (d["measurement"], d["path"]): d for d in path_decisions(
                [lc], tolerance.tolerance_um, tolerance.rule, tolerance.guard_band_um)})
        paths = []
        for p in lc.paths:
            d = dec.get((p.measurement, p.path))
            paths.append({"measurement": p.measurement, "path": p.path, "n_poses": p.n_poses,
                          "range_before_um": [float(v) for v in p.range_before_um],
                          "range_after_um": [float(v) for v in p.range_after_um],
                          "U_um": float(p.U_um),
                          "verdict_before": d["verdict_before"] if d else None,
                          "verdict_after": d["verdict_after"] if d else None})
        tol = None
        if tolerance is not None:
            vb = combine([p["verdict_before"] for p in paths])
            va = combine([p["verdict_after"] for p in paths])
            tol = {"tolerance_um": float(tolerance.tolerance_um), "rule": tolerance.rule,
                   "guard_band_um": tolerance.guard_band_um, "verdict_before": vb,
                   "verdict_after": va,
                   "statement": (f"The largest range (X, Y or Z) of the sphere centre's "
                                 f"deviation over each path against T = "
                                 f"{tolerance.tolerance_um:g} um (ISO 10791-6-style): {vb} "
                                 f"as found with the configured kinematics, {va} predicted "
                                 "with the identified location errors compensated; "
                                 f"decision rule: {RULE_TEXT[tolerance.rule]}.")}
        combos = []
        rep = res.identifiability
        for g in rep.fixed:
            ks = {n: k for n, k in rep.combinations[g].items() if n in rep.free}
            combos += [f"{n} {'-' if k < 0 else '+'} {abs(k):.3g} {g}" for n, k in ks.items()]
        out.append({"chain": lc.chain, "measurements": list(lc.measurements),
                    "linear_model": bool(lc.linear), "coverage_factor": COVERAGE_K,
                    "errors": lc.location_rows(), "determined_combinations": combos,
                    "scatter": {"rms_before_um": float(res.rms_before_um),
                                "rms_after_um": float(res.rms_after_um),
                                "chi2": float(res.chi2), "dof": int(res.dof)},
                    "paths": paths, "tolerance": tol})
    return out
