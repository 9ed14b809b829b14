"""Report section for direct optics: each optic on its own (ISO 230-1) and its residuals."""

from __future__ import annotations

import numpy as np

from volcal.report.document import Section, Table, fmt

__all__ = ["optics_section"]


def optics_section(inp) -> Section | None:
    """Straightness, angular deviation and optical-square squareness of the direct optics.

    Parameters
    ----------
    inp : volcal.report.sections.ReportInputs
        Session and results (the identified model's residuals, when present).

    Returns
    -------
    Section or None
        None when the session has no measured straightness or angular measurement.
    """
    b = getattr(inp, "budget", None)
    ev = getattr(getattr(inp, "evaluation", None), "optics", None)
    if not getattr(getattr(inp, "evaluation", None), "optics_evaluated", False):
        from volcal.standards.session import optics_evaluation

        ev = optics_evaluation(inp.session, b)
    if ev is None or not (ev["straightness"] or ev["angular"]):
        return None

    def u(r, key, nd):
        return [fmt(r[key], nd)] if b is not None else []

    def uh(head):
        return [head] if b is not None else []
    sec = Section("optics", "Direct optics (ISO 230-1)")
    sec.paragraphs.append(
        "Each optic evaluated on its own, without a model: the straightness about the "
        "end-point and the least-squares reference lines, the range of each angular line, "
        "and the squareness of each optical-square pair (corrected by the square's "
        "certificate). The identified model uses every reading of every optic together; "
        "its squareness refers to the end-point lines.")
    res = getattr(inp.result, "residuals", None) if inp.result is not None else None

    def rms(mid):
        if not res or mid not in res:
            return "-"
        return fmt(float(np.sqrt(np.mean(np.square(res[mid])))), 3)

    if ev["straightness"]:
        rows = [[k, r["axis"].upper(), r["error_direction"].upper(), fmt(r["length_mm"], 1),
                 fmt(r["end_point"]["straightness_um"], 3),
                 *u(r["end_point"], "U_straightness_um", 3),
                 fmt(r["least_squares"]["straightness_um"], 3),
                 *u(r["least_squares"], "U_straightness_um", 3), rms(k)]
                for k, r in ev["straightness"].items()]
        sec.tables.append(Table(["measurement", "axis", "along", "length [mm]",
                                 "end-point [µm]", *uh("U [µm]"), "least squares [µm]",
                                 *uh("U [µm]"), "model residual RMS [µm]"], rows,
                                "Straightness"))
    if ev["angular"]:
        rows = [[k, r["axis"].upper(), r["rotation"].upper(), r["target"].replace("_", " "),
                 fmt(r["angular_deviation_urad"], 2), *u(r, "U_angular_deviation_urad", 2),
                 rms(k)] for k, r in ev["angular"].items()]
        sec.tables.append(Table(["measurement", "axis", "about", "optic", "range [µrad]",
                                 *uh("U [µrad]"), "model residual RMS [µrad]"], rows,
                                "Angular deviation"))
    if ev["squareness"]:
        rows = [[r["name"], r["reference"], " + ".join(r["lines"]),
                 fmt(r["square_deviation_urad"], 2), fmt(r["least_squares"][r["name"]], 2),
                 *u(r["least_squares"], f"U_{r['name']}", 2),
                 fmt(r["end_point"][r["name"]], 2),
                 *u(r["end_point"], f"U_{r['name']}", 2)] for r in ev["squareness"]]
        sec.tables.append(Table(["squareness", "reference group", "lines",
                                 "square deviation [µrad]", "least-squares lines [µrad]",
                                 *uh("U [µrad]"), "end-point lines [µrad]", *uh("U [µrad]")],
                                rows, "Squareness by optical square"))
    if b is not None:
        sec.paragraphs.append(
            "U: expanded uncertainty (k = 2, 95 %) of each result from the budget's "
            "[optics] section (each optic's scale error and one reading's uncertainty) "
            "and the optical squares' certificates; "
            + "; ".join(ev["uncertainty"]["notes"][1:]) + ".")
    return sec
