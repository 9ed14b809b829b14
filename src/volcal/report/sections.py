"""Fill the report document from a session and the results of the analysis.

One function per section; each returns a :class:`~volcal.report.document.Section` or
None when its input is missing (the section is then left out, never filled with
placeholders). The analysis results are taken as they come from their modules
(identification, ISO 230-2 / 230-6 evaluation, volumetric indices, compensation); this
module only formats them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES, COMPONENT_NAMES, SQUARENESS_NAMES, info
from volcal.plot import (
    diagonal_fit_plot,
    error_functions_plot,
    identifiability_plot,
    linear_deviation_plot,
    volumetric_map,
    volumetric_map_plot,
)
from volcal.plot.identifiability import FRACTION_LIMITS
from volcal.report.document import FigureItem, Report, Section, Table, fmt
from volcal.report.wording import ISO230_2_HEADS, ISO230_2_LEGEND
from volcal.session.format import Session

__all__ = ["ReportInputs", "build_report", "fmt"]


def _vec(v: Any, digits: int = 3) -> str:
    return "(" + ", ".join(f"{float(x):.{digits}g}" for x in np.asarray(v).reshape(-1)) + ")"


@dataclass
class ReportInputs:
    """Everything the report can show; missing parts leave their section out.

    Attributes
    ----------
    session : Session
        The measured session.
    result : object, optional
        Identification result (``volcal.identify``): ``errors``, ``std``,
        ``squareness_std``, ``residuals``, ``fitted``, ``sigma_um``, ``report``.
    truth : MachineErrors, optional
        The simulated truth (``SESSION/truth/machine.csv``).
    iso230_2 : mapping of str to object, optional
        ISO 230-2 results by measurement id.
    iso230_6 : mapping of str to object, optional
        ISO 230-6 results by measurement id.
    volumetric : object, optional
        Volumetric indices of the identified machine (``E_VX`` ... ``E_VXYZ_range``).
    compensation : object, optional
        Compensation summary.
    elv : mapping of str to float, optional
        Seed 002's ELx, ELy, ELz, ELv of the identified machine [um].
    extra_sections : list of Section
        Sections appended at the end (written by other modules).
    budget : Budget, optional
        The measurement-uncertainty budget the linear tests were evaluated with.
    iso230_2_uncertainty : mapping of str to Iso2302Uncertainty, optional
        U of every ISO 230-2 parameter and target, by measurement id [um].
    corrections : str
        What the budget applied to the readings before evaluation (a sentence).
    iso230_6_uncertainty : mapping of str to DiagonalUncertainty, optional
        U of every diagonal's E_D, by measurement id [um].
    evaluation : SessionEvaluation, optional
        The session's one evaluation (:func:`volcal.standards.session.evaluate_session`)
        the fields above come from; its ``optics`` feed the direct-optics section.
    angle_units : str
        Unit of the rotary axes' angles in the report: ``'urad'`` or ``'arcsec'``.
    rotary_tolerance_urad : mapping of str to float, optional
        Tolerance of the accuracy A of each rotary axis (``'C'`` -> [urad]): the rotary
        section's verdict (:mod:`volcal.report.rotary`).
    location : list of LocatedChain, optional
        The probe_sphere and r_test tests' location errors and sphere-centre scatter
        (:func:`volcal.identify.location_evaluation.locate_session`), computed once.
    location_tolerance : LocationTolerance, optional
        Tolerance and decision rule of the per-path sphere-centre test
        (:mod:`volcal.report.fiveaxis`).
    """

    session: Session
    result: Any = None
    truth: MachineErrors | None = None
    iso230_2: Mapping[str, Any] | None = None
    iso230_6: Mapping[str, Any] | None = None
    volumetric: Any = None
    compensation: Any = None
    elv: Mapping[str, float] | None = None
    extra_sections: list[Section] = field(default_factory=list)
    budget: Any = None
    iso230_2_uncertainty: Mapping[str, Any] | None = None
    corrections: str = ""
    iso230_6_uncertainty: Mapping[str, Any] | None = None
    evaluation: Any = None
    angle_units: str = "urad"
    rotary_tolerance_urad: Mapping[str, float] | None = None
    location: Any = None
    location_tolerance: Any = None


def machine_section(inp: ReportInputs) -> Section:
    """Machine, kinematic chain and work zone.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; only ``session`` and ``truth`` are read.

    Returns
    -------
    Section
        Always present.
    """
    s = inp.session
    n = sum(m.n for m in s.measurements)
    t = s.travel
    rows = [[AXES[k], fmt(t[k, 0], 1), fmt(t[k, 1], 1), fmt(t[k, 1] - t[k, 0], 1)]
            for k in range(3)]
    sec = Section("machine", "Machine")
    sec.paragraphs.append(
        f"Machine '{s.name}', kinematic chain {s.chain} (read from the workpiece to the tool, "
        "F = frame). Errors follow ISO 230-1: positions in mm, linear errors in µm, angles in "
        "µrad; every component error is the error motion of the tool relative to the "
        "workpiece caused by that axis.")
    sec.paragraphs.append(f"The session holds {len(s.measurements)} measurements with "
                          f"{n} readings" + (f" (folder {s.path})." if s.path else "."))
    if inp.truth is not None:
        tables = (s.provenance or {}).get("compensation")
        sec.paragraphs.append(
            "This session was simulated on a virtual machine; its true errors are shown "
            "beside the estimates." if not isinstance(tables, str) else
            "This session was simulated on a virtual machine running with the compensation "
            f"tables of {tables} (an as-left measurement); its true errors, those of the "
            "machine with the tables active, are shown beside the estimates.")
    sec.tables.append(Table(["axis", "min [mm]", "max [mm]", "travel [mm]"], rows,
                            "Work zone"))
    return sec


def measurements_section(inp: ReportInputs) -> Section:
    """Every measurement and its set-up.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; only ``session`` is read.

    Returns
    -------
    Section
        Always present.
    """
    from volcal.session.kinds import kind_of

    rows = []
    for m in inp.session.measurements:
        runs = "-" if m.run is None else str(len(np.unique(m.run)))
        beam = _vec(m.beam_direction) if kind_of(m.kind).along_beam else "-"  # no line
        rows.append([m.id, m.kind.replace("_", " "), m.target.replace("_", " "),
                     beam, _vec(m.tool_offset), str(m.n), runs,
                     str(m.meta.get("notes", ""))])
    sec = Section("measurements", "Measurements and set-ups")
    sec.paragraphs.append(_kinds_paragraph(inp.session))
    sec.tables.append(Table(["id", "kind", "target", "beam direction", "tool offset [mm]",
                             "readings", "runs", "notes"], rows, "Measurements"))
    thermal = _thermal_rows(inp.session)
    if thermal:
        sec.tables.append(Table(["id", "compensated by", "referred to 20 °C by"], thermal,
                                "How the readings were compensated and referred to 20 °C",
                                "Referred once where the session is read, from its record "
                                "(readings, referred_to_20c, environment: docs/formats.md); "
                                "an uncertainty budget never changes a value."))
    return sec


def _kinds_paragraph(session: Any) -> str:
    """One clause per kind of measurement the session holds, in the order they appear.

    Each kind's :attr:`volcal.session.kinds.Kind.description` with its count: a report of
    rotary tests alone no longer explains linear tests and diagonals.
    """
    from collections import Counter

    from volcal.session.kinds import kind_of

    parts = []
    for name, n in Counter(m.kind for m in session.measurements).items():  # first-seen order
        label = f"{name.replace('_', ' ')} ({n})"
        text = kind_of(name).description
        parts.append(f"{label}: {text}" if text else label)
    return "The measurements by kind: " + "; ".join(parts) + "."


def _thermal_rows(session: Any) -> list[list[str]]:
    """Per laser measurement: who compensated its readings and who referred them."""
    from volcal.environment.apply import thermal_record
    from volcal.session.kinds import kind_of

    rows = []
    for m in session.measurements:
        if not kind_of(m.kind).raw_readings:  # laser lengths only
            continue
        r = thermal_record(m)
        comp = ("volcal from raw readings" if r["compensated_by"] != "laser software"
                else "the laser software")
        if r["referred_by"] == "volcal":
            ref = (f"volcal at t = {float(r['material_temperature_c']):g} °C "
                   f"(alpha = {float(r['expansion_ppm_per_k']):g} ppm/K)")
        elif r["referred_by"] == "laser software":
            ref = "the laser software"
        else:
            ref = f"{r['referred_by']} (readings taken as they are)"
        rows.append([m.id, comp, ref])
    return rows


def diagonal_section(inp: ReportInputs) -> Section | None:
    """Show the ISO 230-6 diagonal displacement results.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; ``iso230_6`` holds the diagonal results by measurement id.

    Returns
    -------
    Section or None
        None when there are no ISO 230-6 results.
    """
    if not inp.iso230_6:
        return None
    sec = Section("iso230-6", "Diagonal displacement (ISO 230-6)")
    sec.paragraphs.append(
        "Body (and face) diagonal displacement tests: the laser reads the displacement along "
        "the diagonal while all axes move together. E_D is the range of the deviations along "
        "the diagonal; it sums the effects of positioning, straightness, squareness and some "
        "angular errors, so it is a quick volumetric check but cannot tell them apart.")
    from volcal.standards.iso230_6 import largest_e_d

    rows = []
    duncs = getattr(inp, "iso230_6_uncertainty", None) or {}
    for mid, r in inp.iso230_6.items():
        code = (f"{r.plane} " if getattr(r, "plane", None) else "") + str(r.diagonal)
        pts = f"{r.points_measured} of {r.points_planned}" + (
            "" if r.complete else " (incomplete)")
        rows.append([mid, code, fmt(r.length_mm, 1), pts, fmt(r.E_D), fmt(r.max_abs_um)])
        if duncs:
            rows[-1].append(fmt(duncs[mid].E_D.U) if mid in duncs else "-")
        if not r.complete:
            sec.warnings.append(r.note())
    if duncs:
        sec.paragraphs.append(
            "U(E_D): expanded uncertainty (95 %) of E_D from the uncertainty budget, of "
            "the readings as the session refers them (docs/uncertainty.md, ISO 230-6 "
            "diagonals).")
    worst = largest_e_d(inp.iso230_6.values())
    sec.tables.append(Table(["measurement", "diagonal", "length [mm]", "points", "E_D [µm]",
                             "max |deviation| [µm]"] + (["U(E_D) [µm]"] if duncs else []),
                            rows, "Diagonal displacement errors",
                            "No complete diagonal: no largest E_D." if worst is None else
                            f"Largest E_D of the complete diagonals: {worst.E_D:.2f} µm "
                            f"({worst.id})."))
    return sec


def _component_rows(est: MachineErrors, std, truth: MachineErrors | None) -> list[list[str]]:
    rows = []
    for idx, name in enumerate(COMPONENT_NAMES):
        a, c = divmod(idx, 6)
        v = est.values[a][:, c]
        u = np.asarray(std[a])[:, c] if std is not None else None
        e = info(name)
        row = [name, e.label, e.unit_symbol, fmt(np.ptp(v)), fmt(np.max(np.abs(v))),
               fmt(np.max(u)) if u is not None else "-"]
        if truth is not None:
            tv = truth.function(name, est.nodes[a])
            row += [fmt(np.ptp(tv)), fmt(np.max(np.abs(v - tv)))]
        rows.append(row)
    return rows


def identification_section(inp: ReportInputs) -> Section | None:
    """Show the identified errors with their uncertainties and the fit to the readings.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; ``result`` is the identification, ``truth`` the simulated
        machine if any.

    Returns
    -------
    Section or None
        None when there is no identification result.
    """
    r = inp.result
    if r is None:
        return None
    est: MachineErrors = r.errors
    std = getattr(r, "std", None)
    sq_std = getattr(r, "squareness_std", None)
    truth = inp.truth
    sec = Section("identification", "Identified errors")
    sigma = getattr(r, "sigma_um", None)
    sec.paragraphs.append(
        "All readings of all tests were fitted at once with the first-order kinematic model "
        "(Soons 2005) and the set-up tilts of every measurement as nuisance parameters. "
        "Uncertainties are standard uncertainties (k = 1) in the tables; the bands in the "
        "figures are ± 2 u." + (f" Estimated reading noise σ = {sigma:.2f} µm." if sigma
                                else ""))
    cols = ["error", "meaning", "unit", "peak-to-valley", "max |value|", "max u"]
    if truth is not None:
        cols += ["truth peak-to-valley", "max |estimate − truth|"]
    sec.tables.append(Table(cols, _component_rows(est, std, truth), "Component errors",
                            "u: largest standard uncertainty over the nodes of the function."))
    sq_rows = []
    for i, n in enumerate(SQUARENESS_NAMES):
        row = [n, info(n).label, fmt(est.squareness[i]),
               fmt(sq_std[i]) if sq_std is not None else "-"]
        if truth is not None:
            row.append(fmt(truth.squareness[i]))
        sq_rows.append(row)
    sq_cols = ["squareness", "meaning", "estimate [µrad]", "u [µrad]"] + (
        ["truth [µrad]"] if truth is not None else [])
    sec.tables.append(Table(sq_cols, sq_rows, "Squareness errors"))
    residuals = getattr(r, "residuals", None) or {}
    if residuals:
        rows = [[mid, str(np.size(res)), fmt(np.sqrt(np.mean(np.square(res)))),
                 fmt(np.max(np.abs(res)))] for mid, res in residuals.items()]
        sec.tables.append(Table(["measurement", "readings", "residual rms [µm]",
                                 "max |residual| [µm]"], rows, "Fit residuals"))
    sec.figures.append(FigureItem(
        partial(error_functions_plot, est, std, truth, sq_std),
        "Identified error functions (blue) with their ± 2 u bands"
        + (" and the simulated truth (dashed)." if truth is not None else "."),
        "error-functions", weight=4.0))
    fitted = getattr(r, "fitted", None) or {}
    for kind, label in (("diagonal", "Body diagonals"), ("step_diagonal", "Step diagonals")):
        ms = [m for m in inp.session.measurements if m.kind == kind and m.deviation is not None]
        if ms:
            sec.figures.append(FigureItem(
                partial(diagonal_fit_plot, ms, fitted, residuals,
                        title=f"{label}: readings and fit"),
                f"{label}: laser readings (dots), the identified model's fit (line) and the "
                "residuals below.", f"{kind.replace('_', '-')}-fit", weight=2.0))
    return sec


def _field(obj: Any, name: str, default: Any = None) -> Any:
    """Attribute of a result object, or key of its dict form (a loaded model file)."""
    if isinstance(obj, Mapping):
        return obj.get(name, default)
    return getattr(obj, name, default)


def identifiability_section(inp: ReportInputs) -> Section | None:
    """Explain what the tests determine, in plain words.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; the identifiability report is ``result.report``.

    Returns
    -------
    Section or None
        None when there is no identification result.
    """
    r = inp.result
    if r is None:
        return None
    sec = Section("identifiability", "Identifiability")
    rep = getattr(r, "report", None)
    msgs = [str(m) for m in _field(rep, "messages", []) or []]
    sec.warnings.extend(msgs)
    if not msgs:
        sec.paragraphs.append("The tests determine every error function the model contains.")
    frac = _field(rep, "determined_fraction", None)
    if frac:
        rows = [[n, info(n).label, fmt(100.0 * v, 1),
                 "not determined" if v < FRACTION_LIMITS[0] else
                 ("weak" if v < FRACTION_LIMITS[1] else "determined")] for n, v in frac.items()]
        sec.tables.append(Table(["error", "meaning", "prior uncertainty removed [%]",
                                 "verdict"], rows,
                                "How far the data determine each error"))
    sugg = [str(x) for x in _field(rep, "suggestions", []) or []]
    if sugg:
        sec.tables.append(Table(["rank", "extra measurement that would help most"],
                                [[str(i), t] for i, t in enumerate(sugg, start=1)],
                                "Suggested extra measurements"))
    std = getattr(r, "std", None)
    if std is not None:
        sec.figures.append(FigureItem(
            partial(identifiability_plot, std, getattr(r, "squareness_std", None),
                    _field(rep, "singular_values", None), frac),
            "Largest standard uncertainty of each error function (hatched grey and marked "
            "n/i: not determined by the data) and the share of its prior uncertainty the "
            "data remove (red: below 50 %, not determined; orange: 50 to 95 %, weak; green: "
            "95 % or more, determined).", "identifiability", weight=1.5))
    return sec


def volumetric_section(inp: ReportInputs) -> Section | None:
    """Volumetric error map of the identified machine.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; ``result``, ``volumetric`` (indices [um]) and ``elv`` [um]
        are read.

    Returns
    -------
    Section or None
        None when there is no identification result.
    """
    r = inp.result
    if r is None:
        return None
    sec = Section("volumetric", "Volumetric error")
    vm = volumetric_map(r.errors, inp.session.travel)
    sec.paragraphs.append(
        "The volumetric error is the actual minus the commanded position of the tool point "
        f"(first-order model). Over the grid shown its largest length is "
        f"{vm.length.max():.1f} µm.")
    ind = inp.volumetric
    if ind is not None:
        rows = [["E_VX", fmt(ind.E_VX), "range of the X component of the volumetric error"],
                ["E_VY", fmt(ind.E_VY), "range of the Y component"],
                ["E_VZ", fmt(ind.E_VZ), "range of the Z component"],
                ["E_VXYZ", fmt(ind.E_VXYZ), "largest length of the volumetric error vector, "
                 "at " + _vec(ind.worst_point_mm, 4) + " mm"],
                ["E_VXYZ range", fmt(ind.E_VXYZ_range),
                 "largest distance between two volumetric error vectors"]]
        cols = ["index", "value [µm]", "meaning"]
        note = f"Evaluated on a grid of {ind.n}³ points over the work zone."
        mu = getattr(ind, "uncertainty", None)
        if mu is not None:
            keys = ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range")
            for row, k in zip(rows, keys, strict=True):
                row.append(fmt(mu.volumetric[k].U))
            cols.append("U [µm]")
            note += (" U (k = 2) from the model's covariance, noise"
                     + (" and systematic parts" if mu.systematic else " part only (no "
                        "budget in the model)")
                     + f", by {mu.draws} draws of its posterior (GUM Supplement 1): see "
                     "Measurement uncertainty.")
        sec.tables.append(Table(
            cols, rows,
            "Volumetric indices (ISO 230-1:2012, Annex) of the identified machine", note))
    elv = getattr(inp, "elv", None)
    if elv:
        sec.tables.append(Table(
            ["quantity", "value [µm]"], [[k, fmt(v)] for k, v in elv.items()],
            "ELv (Wang, Optodyne): root sum of squares of the positioning ranges of the three axes",
            "ELv ignores straightness, squareness and angular errors; compare it with "
            "E_VXYZ."))
    sec.figures.append(FigureItem(
        partial(volumetric_map_plot, vm), "Volumetric error of the identified machine on three "
        "horizontal slices of the work zone: arrows show the in-plane error (magnified), the "
        "colour the full vector length.", "volumetric-map", weight=1.5))
    return sec


def compensation_section(inp: ReportInputs) -> Section | None:
    """Say what the written tables correct and the error they leave; the tolerance verdict.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; ``compensation`` is the compensation summary
        (:class:`volcal.report.pipeline.CompensationSummary`).

    Returns
    -------
    Section or None
        None when there is no compensation summary. Without a compensation folder the
        section states the model's error only, never a before/after.
    """
    c = inp.compensation
    if c is None:
        return None
    sec = Section("compensation", "Compensation")
    sec.warnings.extend(getattr(c, "warnings", []))
    cells = f"{c.n}³ points of the work zone"
    if c.folder is None or c.tables is None:
        sec.paragraphs.append(
            "No compensation tables were given for this report, so nothing is said about "
            "the error after compensation; `volcal compensate MODEL.json` writes them and "
            "`volcal report --compensation FOLDER` shows what they correct.")
        rows = [["modelled volumetric error, largest |e|", fmt(c.model_max_um)],
                ["modelled volumetric error, RMS", fmt(c.model_rms_um)],
                ["model uncertainty, largest 2u (k = 2)", fmt(c.residual_u2_max_um)]]
        if c.truth_max_um is not None:
            rows += [["true volumetric error (simulation), largest |e|", fmt(c.truth_max_um)],
                     ["true minus modelled error, largest", fmt(c.truth_model_max_um)]]
        sec.tables.append(Table(["quantity", "value [µm]"], rows,
                                "Volumetric error of the identified model", f"Over {cells}."))
    else:
        from volcal.report.carried import describe

        m, t = c.manifest, c.tables
        sec.paragraphs.append(
            f"Compensation tables for the '{m.get('controller_format', '?')}' format were "
            f"written to {c.folder}: {', '.join(map(str, m.get('files', [])))}. They carry "
            + describe(t) + " The controller corrects those components only; everything "
            "else (the components not listed, and the estimation error of the model) "
            "stays.")
        sec.paragraphs.append(
            "The error left is the model's volumetric error minus what the tables remove: "
            "the tables as written, read back from their files with the format's reader "
            "and applied with the controller's interpolation rule (table points, "
            "rounding, linear or stepwise between points), assuming they are loaded with "
            f"the sign the controller expects (written: '{t.sign}'). A table edited "
            "after it was written, or written from another model, shows here as it is.")
        rows = [["modelled volumetric error, largest |e|", fmt(c.model_max_um),
                 fmt(c.left_max_um)],
                ["modelled volumetric error, RMS", fmt(c.model_rms_um), fmt(c.left_rms_um)]]
        if c.truth_max_um is not None:
            rows.append(["true volumetric error (simulation), largest |e|",
                         fmt(c.truth_max_um), fmt(c.truth_residual_max_um)])
            rows.append(["true volumetric error (simulation), RMS", "-",
                         fmt(c.truth_residual_rms_um)])
        sec.tables.append(Table(
            ["quantity", "before [µm]", "after these tables [µm]"], rows,
            f"Volumetric error before and after the {t.kind} tables",
            f"Over {cells}. The model itself is uncertain by up to "
            f"{fmt(c.residual_u2_max_um)} µm (2u, k = 2): no table removes that."))
    if c.verdicts:
        from volcal.standards.decision import RULE_TEXT

        rule = c.verdicts[0].rule
        rows = [[v.quantity, fmt(v.tolerance_um), fmt(v.before_um), v.before,
                 fmt(v.after_um), v.after] for v in c.verdicts]
        head = ["quantity", "tolerance [µm]", "before [µm]", "verdict before",
                "after [µm]", "verdict after"]
        if rule == "guarded":  # the guard band w (U, or --guard-band-um) of each value
            for row, v in zip(rows, c.verdicts, strict=True):
                gb = v.guard_band_um
                row.insert(3, fmt(gb if gb is not None else v.U_before_um))
                row.insert(6, fmt(gb if gb is not None else v.U_after_um))
            head.insert(3, "w before [µm]")
            head.insert(6, "w after [µm]")
        sec.tables.append(Table(
            head, rows,
            f"Tolerance verdict (decision rule: {rule})",
            f"Decision rule: {RULE_TEXT[rule]}. Volumetric: largest |e| of the model; per "
            "axis: the "
            "ISO 230-2 parameter named (the accuracy A by default) of the measured linear "
            "tests, after = the same readings "
            "with the tables' correction taken off. '-': no compensation tables given."))
        failed = [v.quantity for v in c.verdicts
                  if "fail" in (v.before, v.after) and v.after != "pass"]
        sec.warnings.extend(f"out of tolerance: {q}" for q in failed)
        sec.warnings.extend(f"conformity not proven ({rule} rule): {v.quantity}"
                            for v in c.verdicts if v.quantity not in failed
                            and "conditional" in (v.before, v.after) and v.after != "pass")
    return sec


def build_report(inp: ReportInputs, title: str | None = None) -> Report:
    """Assemble the report from whatever inputs are present.

    Parameters
    ----------
    inp : ReportInputs
        Session and results.
    title : str, optional
        Report title; by default from the machine name.

    Returns
    -------
    Report
    """
    from volcal import __version__
    from volcal.report.completeness import completeness_section
    from volcal.report.uncertainty import uncertainty_section
    from volcal.report.wording import references_section
    from volcal.session.kinds import hooks_of

    kind_sections = hooks_of([m.kind for m in inp.session.measurements], "report_section")
    builders = [machine_section, measurements_section, completeness_section,
                positioning_section,
                diagonal_section, *kind_sections,  # each kind's own (volcal.kinds)
                identification_section,
                identifiability_section, volumetric_section, compensation_section,
                uncertainty_section]
    sections = [s for s in (b(inp) for b in builders) if s is not None]
    sections.extend(inp.extra_sections)
    refs = references_section(sections)
    if refs.paragraphs:  # a report citing nothing has no References
        sections.append(refs)
    return Report(title or f"Calibration report: {inp.session.name}", sections,
                  generator=f"volcal {__version__}")


def positioning_section(inp: ReportInputs) -> Section | None:
    """Show the ISO 230-2 positioning results and the deviation plots of the linear tests.

    Parameters
    ----------
    inp : ReportInputs
        Session and results; the linear measurements of ``session`` and ``iso230_2``
        (results by measurement id) are read.

    Returns
    -------
    Section or None
        None when the session has no linear test with deviations, or none of them was
        evaluated (each in the evaluation's ``skipped``, e.g. one run per direction).
    """
    lin = [m for m in inp.session.measurements if m.kind == "linear" and m.deviation is not None]
    skipped = getattr(inp.evaluation, "skipped", None) or {}
    if not lin or (not inp.iso230_2 and all(m.id in skipped for m in lin)):
        return None  # none evaluated: the completeness section says why
    sec = Section("iso230-2", "Positioning (ISO 230-2)")
    sec.paragraphs.append(
        "Linear tests with bidirectional runs, evaluated as ISO 230-2:2014 asks: mean "
        "deviations per target and direction, their envelopes ± 2 s, and the figures A "
        "(accuracy), E (systematic error), M (range of the mean bidirectional deviation), "
        "R (repeatability) and B (reversal).")
    if inp.iso230_2:
        keys = ("A", "A_up", "A_down", "E", "M", "R", "R_up", "R_down", "B", "B_mean")
        rows = []
        same: dict[str, list[str]] = {}  # one warning, the tests it concerns
        for mid, res in inp.iso230_2.items():
            axis = AXES[inp.session.get(mid).axis or 0]
            rows.append([mid, axis, *(fmt(getattr(res, k)) for k in keys)])
            for w in getattr(res, "warnings", []) or []:
                same.setdefault(str(w), []).append(mid)
        sec.warnings.extend(f"{', '.join(ids)}: {w}" for w, ids in same.items())
        sec.warnings.extend(f"{mid}: {n}" for mid, res in inp.iso230_2.items()
                            for n in getattr(res, "notes", []) or [])
        edition = next(iter(inp.iso230_2.values())).edition
        sec.tables.append(Table(
            ["measurement", "axis", *(f"{ISO230_2_HEADS[k]} [µm]" for k in keys)], rows,
            f"ISO 230-2:{edition} positioning parameters", ISO230_2_LEGEND))
    uncs = inp.iso230_2_uncertainty or {}
    if inp.iso230_2 and uncs:
        _positioning_uncertainty(sec, inp, uncs)
    seen: set[int | None] = set()
    for m in lin:
        if m.axis in seen:
            continue
        seen.add(m.axis)
        u = uncs.get(m.id)
        if u is None or inp.budget is None:
            sec.figures.append(FigureItem(
                partial(linear_deviation_plot, m), f"{m.id}: positional deviation of every "
                "run with the mean ± 2 s envelopes of each approach direction (ISO 230-2, "
                "Figure 1).",
                f"{m.id}-deviation"))
            continue
        mc, bars = _corrected_with_bars(m, inp, u)
        sec.figures.append(FigureItem(
            partial(linear_deviation_plot, mc, uncertainty=bars), f"{m.id}: positional "
            "deviation of "
            "every run with the mean ± 2 s "
            "envelopes of each approach direction (ISO 230-2, Figure 1) and the mean "
            "bidirectional deviation of each target with its expanded uncertainty ± U "
            "(95 %, error bars).", f"{m.id}-deviation"))
    return sec


_U_KEYS = ("A", "E", "M", "R", "B", "B_mean")


def _positioning_uncertainty(sec: Section, inp: ReportInputs, uncs: Mapping[str, Any]
                             ) -> None:
    """U of the ISO 230-2 parameters and of every target's mean (a budget was given)."""
    rows = []
    for mid in inp.iso230_2 or {}:
        u = uncs.get(mid)
        if u is None:
            continue
        rows.append([mid, *(fmt(u.parameters[k].U) for k in _U_KEYS),
                     fmt(u.parameters["A"].k)])
    sec.tables.append(Table(
        ["measurement", *(f"U({ISO230_2_HEADS[k]}) [µm]" for k in _U_KEYS), "k (A)"],
        rows, "Expanded uncertainty of the ISO 230-2 parameters (95 %)",
        "U = k u, k from the effective degrees of freedom (Welch-Satterthwaite); the "
        "budget gives uncertainties only: the values are those of the readings as the "
        "session refers them (section Measurements)"
        + (f" ({inp.corrections})." if inp.corrections else ".")
        + " The budget tables and the equations: docs/uncertainty.md."))
    for mid, res in (inp.iso230_2 or {}).items():
        u = uncs.get(mid)
        if u is None:
            continue
        t = res.targets
        trows = [[fmt(t.target_mm[i], 1), fmt(t.mean_up[i]), fmt(t.mean_down[i]),
                  fmt(u.targets[i].value), fmt(u.targets[i].U), fmt(u.targets[i].k)]
                 for i in range(t.target_mm.size)]
        sec.tables.append(Table(
            ["target [mm]", "x̄↑ [µm]", "x̄↓ [µm]", "x̄ [µm]", "U(x̄) [µm]", "k"], trows,
            f"{mid}: mean deviation of each target with its expanded uncertainty"))


def _corrected_with_bars(m: Any, inp: ReportInputs, u: Any) -> tuple[Any, Any]:
    """The test's readings (as the session refers them) and its ± U error bars."""
    t = (inp.iso230_2 or {})[m.id].targets
    return m, (t.target_mm, [e.value for e in u.targets], [e.U for e in u.targets])
