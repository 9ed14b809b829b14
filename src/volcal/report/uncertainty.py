"""The report's measurement-uncertainty section: the budget, and the model's two parts.

* The laser budget (:mod:`volcal.uncertainty`), when ``volcal report --budget`` was given:
  what was applied to the readings, and the budget table of the mean deviation at the
  target farthest from the datum of each linear test (contributor, distribution, u of
  the input, sensitivity, component, degrees of freedom, share).
* The identification's uncertainty in its two parts (:mod:`volcal.identify.systematic`):
  the noise and prior part of the fit and the systematic part of the budget propagated
  through the fit's linear gain, per error function at its node of largest total u
  (:func:`volcal.standards.model_uncertainty.function_parts`).
* How the U of the volumetric indices, straightness and squareness of the model were
  obtained (:mod:`volcal.standards.model_uncertainty`).
"""

from __future__ import annotations

from typing import Any

from volcal.report.document import Section, Table, fmt

__all__ = ["model_parts_table", "uncertainty_section"]


def _f(v: float | None, digits: int = 3) -> str:
    return fmt(v, digits)


def model_parts_table(result: Any) -> Table:
    """Noise and systematic parts of the identified functions' u at their worst node.

    Parameters
    ----------
    result : IdentificationResult
        Identified model.

    Returns
    -------
    Table
        One row per error function and squareness: u_noise, u_sys, u_total (k = 1).
    """
    from volcal.standards.model_uncertainty import function_parts

    rows = [[r["name"], r["unit"], "-" if r["node_mm"] is None else _f(r["node_mm"], 1),
             _f(r["u_noise"]), _f(r["u_sys"]), _f(r["u_total"])]
            for r in function_parts(result)]
    return Table(["error", "unit", "node [mm]", "u noise", "u systematic", "u total"], rows,
                 "Standard uncertainty of the identified functions: noise and systematic "
                 "parts (k = 1)",
                 "At the node of the largest total u of each function; u total = "
                 "sqrt(u noise² + u systematic²). Noise: the fit's reading noise and "
                 "prior; systematic: the budget's laser, air and material inputs, "
                 "propagated through the fit's linear gain.")


def uncertainty_section(inp: Any) -> Section | None:
    """Measurement uncertainty: the budget, the model's noise and systematic parts.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; ``budget``, ``iso230_2_uncertainty``, ``corrections``,
        ``result`` and ``volumetric`` are read.

    Returns
    -------
    Section or None
        None when there is neither a budget nor a model.
    """
    from volcal.standards.model_uncertainty import has_covariance

    uncs = getattr(inp, "iso230_2_uncertainty", None) or {}
    r = inp.result
    if r is not None and not (has_covariance(r) and hasattr(r, "function_std")):
        r = None  # a stand-in without the model's covariance: nothing to say about it
    if not uncs and r is None:
        return None
    sec = Section("uncertainty", "Measurement uncertainty")
    if uncs:
        sec.paragraphs.append(
            "The linear tests were evaluated with an uncertainty budget (GUM, JCGM "
            "100:2008, on the GUM Tree Calculator): laser wavelength, air temperature, "
            "pressure and humidity, material temperature and expansion coefficient, beam "
            "misalignment (cosine error, one-sided), dead path, and the repeatability and "
            "reversal of the readings. Expanded uncertainties U are stated at about 95 % "
            "(k from the effective degrees of freedom)."
            + (f" {inp.corrections[:1].upper()}{inp.corrections[1:]}."
               if getattr(inp, "corrections", "") else ""))
        for mid, u in uncs.items():
            rd = u.reading
            rows = [[c.label, c.distribution, "" if c.u_input is None else f"{c.u_input:.3g}",
                     c.unit, "" if c.sensitivity is None else f"{c.sensitivity:.4g}",
                     _f(c.u, 4), "∞" if c.dof == float("inf") else f"{c.dof:.0f}",
                     _f(100 * c.share, 1)] for c in rd.components]
            rows.append(["combined", "", "", "", "", _f(rd.u, 4),
                         "∞" if rd.dof == float("inf") else f"{rd.dof:.1f}", "100.0"])
            sec.tables.append(Table(
                ["contributor", "distribution", "u(x)", "unit", "c", "u_i [µm]", "dof",
                 "share [%]"], rows,
                f"Uncertainty budget, {mid}: mean deviation at {u.length_mm:g} mm from the "
                f"datum ({u.datum_mm:g} mm)",
                f"U = k u = {rd.k:.3f} × {rd.u:.4f} = {rd.U:.4f} µm."))
            break  # one budget table here; every test's U is in the positioning section
        if len(uncs) > 1:
            sec.paragraphs.append(f"The budget table is shown for {next(iter(uncs))}; the "
                                  "other linear tests have the same contributors (their U "
                                  "are in the positioning section).")
    if r is not None:
        sys_labels = list(getattr(r, "sys_labels", []) or [])
        has_sys = getattr(r, "sys_factor", None) is not None and len(sys_labels) > 0
        if has_sys:
            from volcal.standards.model_uncertainty import describe_inputs

            src = getattr(r, "sys_source", "") or "the budget"
            sec.paragraphs.append(
                "The identification's uncertainty has two parts, shown apart below: the "
                "noise part (the fit's reading noise and prior) and the systematic part "
                f"({len(sys_labels)} inputs of {src}: {describe_inputs(sys_labels)}), "
                "propagated after the fit through its linear gain. "
                "Predictions, the compensation residual and the model's indices carry "
                "both.")
        else:
            sec.paragraphs.append(
                "The identification's uncertainty shown is its noise part only (the fit's "
                "reading noise and prior): the model was identified without an "
                "uncertainty budget, so the systematic part (laser wavelength, air, "
                "material) is not included; `volcal identify --budget FILE` adds it.")
        from volcal.identify.settings_file import changed_settings, recorded_settings

        settings = recorded_settings(r)
        changed = changed_settings(settings)
        bf = getattr(r, "between_factor", None)
        if bf is not None and getattr(bf, "shape", (0, 0))[1] > 0:
            factor = settings.between_readings_factor
            times = "twice" if factor == 2.0 else f"{factor:g} times"
            sec.paragraphs.append(
                "Between the readings the noise part includes what the readings cannot show "
                f"there: at the {bf.shape[1]} node values no reading touches, {times} the "
                "fitted smoothness prior's conditional variance (volcal's estimator "
                "setting between_readings_factor; docs/identification.md, section 4). The "
                "estimate and every uncertainty at the readings are without it.")
            from volcal.identify.between_share import between_share

            share = between_share(r)
            if share is not None:
                sec.paragraphs.append("Its share: the " + share.describe() + ".")
        if changed:
            sec.paragraphs.append(
                "The estimator's settings differ from volcal's defaults (volcal identify "
                "--estimator-settings; recorded in the model file as fit.estimator_settings): "
                + "; ".join(f"{k} = {v}" for k, v in changed.items()) + ".")
        sec.tables.append(model_parts_table(r))
        vol = getattr(inp, "volumetric", None)
        mu = getattr(vol, "uncertainty", None)
        if mu is not None:
            sec.paragraphs.append(
                "The expanded uncertainties of the volumetric indices and of the "
                "straightness of the model are maxima over a grid, not linear in the "
                f"parameters: they come from {mu.draws} draws of the model's posterior "
                "(GUM Supplement 1, JCGM 101:2008), U = 2 u; the squareness is a parameter "
                "of the model, its U is linear. The noise and systematic parts are given "
                "apart; with both, u is their quadrature sum.")
            rows = []
            for k, e in mu.straightness.items():
                rows.append([f"straightness {k}", "µm", _f(e.value), _f(e.U), _f(e.u_noise),
                             _f(e.u_sys)])
            for k, e in mu.squareness.items():
                rows.append([k, "µrad", _f(e.value), _f(e.U), _f(e.u_noise), _f(e.u_sys)])
            sec.tables.append(Table(
                ["quantity", "unit", "value", "U (k = 2)", "u noise", "u systematic"], rows,
                "Straightness and squareness of the identified machine (ISO 230-1)",
                "Straightness: range of the function about its least-squares line over "
                "the travel."))
    return sec
