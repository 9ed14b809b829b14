"""Report section of the probe_sphere and r_test tests: the rotary axes' location errors with U.

With the scatter of the sphere centre before and after and its ISO 10791-6-style test
per path (:mod:`volcal.identify.location_evaluation`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from volcal.report.document import Section, Table, fmt

__all__ = ["location_section"]


def _located(inp: Any) -> list[Any]:
    """The session's location evaluation: the one computed by the report step, else now."""
    located = getattr(inp, "location", None)
    if located is not None:
        return list(located)
    from volcal.identify.location_evaluation import locate_session

    return locate_session(inp.session, getattr(inp, "result", None))


def _unit(u: str) -> str:
    return "µm" if u == "um" else "µrad"


def _scatter_table(lc: Any) -> Table:
    """Per pose: the sphere centre's deviation before and after [um]."""
    rows = []
    for i, mid in enumerate(lc.pose_measurement):
        angles = ", ".join(f"{r} {fmt(float(v[i]), 1)}°" for r, v in lc.angles.items())
        b, a = lc.before_um[i], lc.after_um[i]
        rows.append([mid, angles, *(fmt(float(x), 1) for x in b), fmt(float(np.linalg.norm(b)), 1),
                     *(fmt(float(x), 2) for x in a), fmt(float(np.linalg.norm(a)), 2)])
    return Table(["test", "pose", "before dX [µm]", "dY [µm]", "dZ [µm]", "|d| [µm]",
                  "after dX [µm]", "dY [µm]", "dZ [µm]", "|d| [µm]"], rows,
                 f"Sphere centre at each pose, chain {lc.chain}: before (configured "
                 "kinematics) and after (identified location errors applied)",
                 "In workpiece coordinates (the table's at the zero pose). Before: the "
                 "centre each pose gives with the configured rotation points, minus the "
                 "mean of the test's poses; |d| is the dispersion the control's own probing "
                 "cycle reports. After: the same with the identified location errors "
                 "applied, minus the identified sphere centre: what a control holding them "
                 "would leave (a prediction, not a measurement after compensation).")


def _path_table(lc: Any, decisions: list[dict[str, Any]] | None) -> Table:
    rows = []
    by_path = {(d["measurement"], d["path"]): d for d in decisions or []}
    for p in lc.paths:
        d = by_path.get((p.measurement, p.path))
        row = [p.measurement, p.path, str(p.n_poses),
               "/".join(fmt(float(v), 1) for v in p.range_before_um),
               "/".join(fmt(float(v), 2) for v in p.range_after_um), fmt(p.U_um, 2)]
        if decisions is not None:
            row += [d["verdict_before"] if d else "-", d["verdict_after"] if d else "-"]
        rows.append(row)
    cols = ["test", "path", "poses", "range before X/Y/Z [µm]", "range after X/Y/Z [µm]",
            "U (k = 2) [µm]"]
    note = ("A path: the poses along which one rotary axis turns while the others stand. "
            "At each pose, the reported centre minus where the kinematics put the sphere as "
            "the path's first pose located it (an R-test's sensors zeroed at the start of "
            "the path), in machine coordinates; its range (max - min) in X, Y and Z over "
            "the path, as the kinematic tests of ISO 10791-6:2014 evaluate a rotary motion "
            "with the linear axes following (Weikert 2004; Ibaraki et al. 2011); U of a "
            "range is 2 √2 σ with the probe noise σ of the test.")
    if decisions is not None:
        cols += ["verdict before", "verdict after"]
        d0 = decisions[0] if decisions else None
        if d0 is not None:
            from volcal.standards.decision import RULE_TEXT

            note += (f" Tolerance T = {fmt(d0['tolerance_um'], 2)} µm on the largest of the "
                     f"three ranges; decision rule: {RULE_TEXT[d0['rule']]}.")
    return Table(cols, rows, f"ISO 10791-6-style test of the sphere centre per path, chain "
                 f"{lc.chain}", note)


def location_section(inp: Any) -> Section | None:
    """The location errors the session's probe_sphere and r_test tests determine, with U (k = 2).

    Parameters
    ----------
    inp : volcal.report.sections.ReportInputs
        Session and results; the identified linear model (``inp.result``), when there is
        one, is taken as the linear axes' errors; ``inp.location`` (the report step's
        evaluation, :func:`volcal.identify.location_evaluation.locate_session`) and
        ``inp.location_tolerance`` (tolerance and decision rule of the per-path test)
        when given.

    Returns
    -------
    Section or None
        None without a measured probe_sphere or r_test test.
    """
    located = _located(inp)
    if not located:
        return None
    rtest = any(m.kind == "r_test" for m in inp.session.measurements)
    sec = Section("location", "Rotary axes: location errors (probe on a sphere)" if not rtest
                  else "Rotary axes: location errors (probe on a sphere, R-test)")
    linear = any(lc.linear for lc in located)
    sec.paragraphs.append(
        "The centre of a calibration sphere probed at a set of rotary poses, as the control "
        "reports it in machine coordinates, identifies where the rotary axes' lines are "
        "(ISO 230-1 location errors: positions EX0C... [µm] of the lines, their orientations "
        "EA0C... and the zeros of the angles [µrad]); signs and references in "
        "docs/fiveaxis.md. Errors the poses cannot separate are held at zero; the ones "
        "determined then stand for the combinations named below. The linear axes' errors "
        + ("are those identified above." if linear else "are taken as perfect."))
    if rtest:
        sec.paragraphs.append(
            "An R-test (r_test tests: a sphere on the table read by three displacement "
            "sensors in the spindle while the linear axes follow the rotary paths; ISO "
            "10791-6:2014, annex; Weikert 2004) identifies them from the sphere's "
            "displacement in the nest. Its rows of the scatter table are that displacement "
            "[µm] (in the nest's axes): before, the readings minus their mean over the test; "
            "after, what the identified errors leave of them (the readings minus the ones "
            "they predict, minus the mean). Its paths' ranges are those of the readings and "
            "of that residual; the rotary axes' error motions over the angle stay in it "
            "(docs/fiveaxis.md).")
    tol = getattr(inp, "location_tolerance", None)
    decisions = None
    if tol is not None:
        from volcal.identify.location_evaluation import path_decisions

        decisions = path_decisions(located, tol.tolerance_um, tol.rule, tol.guard_band_um)
    for lc in located:
        res = lc.result
        rows = []
        for r in lc.location_rows():
            ok = r["value"] is not None
            rows.append([str(r["name"]), str(r["meaning"]),
                         fmt(float(r["value"]), 2) if ok else "-",
                         fmt(float(r["U"]), 2) if ok else "-", _unit(str(r["unit"])),
                         str(r["status"])])
        sec.tables.append(Table(
            ["error", "meaning", "value", "U (k = 2)", "unit", "status"], rows,
            f"Location errors of the rotary axes, chain {lc.chain} "
            f"({', '.join(lc.measurements)})",
            f"Scatter of the sphere centre: RMS {fmt(res.rms_before_um, 2)} µm with the "
            f"configured kinematics, {fmt(res.rms_after_um, 2)} µm with the identified "
            f"location errors (chi-square {fmt(res.chi2, 1)} on {res.dof} degrees of "
            "freedom)."))
        sec.tables.append(_scatter_table(lc))
        if lc.paths:
            sec.tables.append(_path_table(
                lc, None if decisions is None else [d for d in decisions
                                                    if d["chain"] == lc.chain]))
        sec.paragraphs.extend(res.identifiability.messages)
    if decisions:
        from volcal.standards.decision import combine

        before = combine([d["verdict_before"] for d in decisions])
        after = combine([d["verdict_after"] for d in decisions])
        sec.paragraphs.append(
            f"ISO 10791-6-style test of the sphere centre (T = "
            f"{fmt(decisions[0]['tolerance_um'], 2)} µm per path): {before} as found with the "
            f"configured kinematics; {after} predicted with the identified location errors "
            "compensated.")
    return sec
