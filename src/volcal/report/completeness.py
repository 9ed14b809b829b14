"""The report's account of what was not measured and what looks wrong in the readings.

One section, left out when there is nothing to say: the planned tests without readings
(``Session.unmeasured``), the tests measured but not evaluated to their standard (the
evaluation's ``skipped``: one run per direction, too many missed captures), every missed
capture (which measurement, which row, run,
direction and target, and what the evaluation did with it: the per-target ``n`` of an
incomplete ISO 230-2 test, an incomplete diagonal left out of the largest E_D) and the
plausibility warnings of the readings (:mod:`volcal.session.plausibility`). The console
prints the same facts as notes; the report keeps them with the results they qualify.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from volcal.report.document import Section, Table

__all__ = ["completeness_section", "missed_rows"]


def _fmt_mm(v: float) -> str:
    return f"{float(v):.3f}"


def _target_effect(m: Any, rec: dict[str, Any], res: Any) -> tuple[str, str]:
    """Target [mm] of a missed linear reading and the runs that reached that target."""
    t = float(rec["position_mm"][m.axis])
    if res is None:
        return _fmt_mm(t), "not evaluated"
    targets = np.asarray(res.targets.target_mm, dtype=float)
    i = int(np.argmin(np.abs(targets - t)))
    nu, nd = res.targets.counts()
    sign = rec.get("direction", "+")
    n, total = ((nu[i], res.targets.n_up) if sign == "+" else (nd[i], res.targets.n_down))
    return _fmt_mm(targets[i]), f"n = {int(n)} of {int(total)} runs"


def missed_rows(inp: Any) -> list[list[str]]:
    """One table row per missed capture of the session's measurements.

    Parameters
    ----------
    inp : ReportInputs
        Session and results (``iso230_2``, ``iso230_6`` by measurement id).

    Returns
    -------
    list of list of str
        Measurement, kind, row, run, direction, target or position [mm], and the runs
        that reached the target (``n = 4 of 5 runs``, linear tests) or the points
        measured of planned (diagonals).
    """
    lin = inp.iso230_2 or {}
    diag = inp.iso230_6 or {}
    rows = []
    for m in inp.session.measurements:
        for rec in m.missed:
            run = str(rec.get("run", "-"))
            sign = str(rec.get("direction", "-"))
            if m.kind == "linear":
                where, effect = _target_effect(m, rec, lin.get(m.id))
            else:
                where = "(" + ", ".join(f"{v:.1f}" for v in rec["position_mm"]) + ")"
                d = diag.get(m.id)
                if d is not None:
                    effect = f"{d.points_measured} of {d.points_planned} points"
                else:
                    effect = "-"
            rows.append([m.id, m.kind.replace("_", " "), str(rec["row"]), run, sign, where,
                         effect])
    return rows


def completeness_section(inp: Any) -> Section | None:
    """Unmeasured tests, missed readings and implausible readings, in the report's text.

    Parameters
    ----------
    inp : ReportInputs
        Session and results.

    Returns
    -------
    Section or None
        None when every planned test was measured, no capture was missed and no reading
        looks implausible.
    """
    s = inp.session
    unmeasured = list(getattr(s, "unmeasured", []) or [])
    missed = missed_rows(inp)
    warnings = list(getattr(s, "warnings", []) or [])
    skipped = {k: why for k, why in (getattr(inp.evaluation, "skipped", None) or {}).items()
               if why != "no readings yet"}  # measured, not evaluated to their standard
    if not (unmeasured or missed or warnings or skipped):
        return None
    sec = Section("completeness", "Completeness and plausibility of the readings")
    planned = len(s.measurements) + len(unmeasured)
    if unmeasured:
        sec.paragraphs.append(
            f"{len(unmeasured)} of the {planned} planned tests were not measured (no "
            f"readings): {', '.join(m.id for m in unmeasured)}. Every result of this report "
            f"comes from the {len(s.measurements)} measured tests.")
        sec.tables.append(Table(["measurement", "kind", "planned readings", "notes"],
                                [[m.id, m.kind.replace("_", " "), str(m.n),
                                  str(m.meta.get("notes", ""))] for m in unmeasured],
                                "Planned tests not measured"))
    else:
        sec.paragraphs.append(f"All {planned} planned tests were measured.")
    if missed:
        ids = sorted({r[0] for r in missed})
        sec.paragraphs.append(
            f"{len(missed)} reading(s) were missed by the laser (marked 'missed' in the "
            f"measurement files) in {', '.join(ids)}. A linear test with a missed reading "
            "is evaluated to ISO 230-2 target by target over the runs that reached each "
            "target (n below, the standard deviation of that target with n - 1 degrees of "
            "freedom); a diagonal with a missed point is marked incomplete and left out of "
            "the largest E_D; the identification uses the readings there are.")
        sec.tables.append(Table(
            ["measurement", "kind", "row", "run", "direction", "target / position [mm]",
             "runs or points"], missed, "Missed readings",
            "row: line of the measurement file (the header is row 1); runs: the runs that "
            "reached that target in that direction; points: measured of planned."))
        sec.warnings.append(f"incomplete tests (missed readings): {', '.join(ids)}")
    else:
        sec.paragraphs.append("No reading was missed.")
    if skipped:
        sec.tables.append(Table(
            ["measurement", "kind", "why"],
            [[k, s.get(k).kind.replace("_", " "), why] for k, why in skipped.items()],
            "Tests measured but not evaluated to their standard"))
        sec.warnings.append(f"not evaluated to their standard: {', '.join(skipped)}")
    sec.warnings.extend(f"implausible readings: {w}" for w in warnings)
    return sec
