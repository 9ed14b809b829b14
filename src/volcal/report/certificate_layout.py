"""The certificate document as printed: sections of paragraphs, fields, tables and flags.

One view of the ``volcal-certificate/1`` document (:mod:`volcal.report.certificate`),
shared by the PDF (:mod:`volcal.report.certificate_pdf`) and the HTML
(:mod:`volcal.report.certificate_html`) renderers, so both print the same words.
Deviations and uncertainties are printed in µm, lengths in mm, angles in µrad.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["Block", "CertSection", "layout"]

_UNIT = "µm"
_KEYS = {"A": "A", "A_up": "A↑", "A_down": "A↓", "E": "E", "E_up": "E↑", "E_down": "E↓",
         "M": "M", "R": "R", "R_up": "R↑", "R_down": "R↓", "B": "B", "B_mean": "mean B"}
_SHOWN = ("A", "E", "M", "R", "B", "B_mean")
_UNITS = {"um": "µm", "urad": "µrad"}
_REF = {"least_squares": "least squares", "end_point": "end points"}


@dataclass
class Block:
    """One printed block.

    Attributes
    ----------
    kind : str
        ``'p'`` paragraph, ``'fields'`` label-value lines, ``'table'``, ``'flag'`` (a
        highlighted warning), ``'note'`` (small print).
    text : str
        Paragraph, flag or note text.
    fields : list of (str, str)
        Label and value (``kind == 'fields'``).
    title : str
        Table title.
    columns : list of str
        Table header.
    rows : list of list of str
        Table cells.
    flagged : list of int
        Rows to highlight (e.g. expired equipment).
    """

    kind: str
    text: str = ""
    fields: list[tuple[str, str]] = field(default_factory=list)
    title: str = ""
    columns: list[str] = field(default_factory=list)
    rows: list[list[str]] = field(default_factory=list)
    flagged: list[int] = field(default_factory=list)


@dataclass
class CertSection:
    """A numbered section of the certificate."""

    title: str
    blocks: list[Block] = field(default_factory=list)


def _n(v: Any, digits: int = 2) -> str:
    if v is None:
        return "–"
    if isinstance(v, int | float):
        return f"{v:.{digits}f}"
    return str(v)


def _or(v: Any, missing: str = "not stated") -> str:
    return missing if v in (None, "") else str(v)


def _state(s: str) -> str:
    return s.replace("_", "-")


def layout(doc: dict[str, Any], angle_units: str = "urad") -> list[CertSection]:
    """The printed sections of a certificate document.

    Parameters
    ----------
    doc : dict
        A ``volcal-certificate/1`` document.
    angle_units : str
        ``'urad'`` or ``'arcsec'``: the printed unit of the rotary axes' results (the
        document itself keeps µrad).

    Returns
    -------
    list of CertSection
        In order: laboratory and customer, item calibrated, dates, method, environment,
        equipment, results, as-found / as-left (when given), measurement uncertainty,
        statement of conformity (when a tolerance is given), remarks.
    """
    out: list[CertSection] = []
    lab, cust, item = doc["laboratory"], doc["customer"], doc["item"]

    s = CertSection("Laboratory and customer")
    s.blocks.append(Block("fields", fields=[
        ("Calibration laboratory", _or(lab.get("name"))),
        ("Laboratory address", _or(lab.get("address"))),
        ("Customer", _or(cust.get("name"))),
        ("Customer address", _or(cust.get("address"))),
        ("Certificate number (report id)", doc["report_id"])]))
    out.append(s)

    s = CertSection("Item calibrated")
    travel = item.get("travel_mm") or []
    s.blocks.append(Block("fields", fields=[
        ("Machine", item.get("name", "")),
        ("Make", _or(item.get("make"))), ("Model", _or(item.get("model"))),
        ("Serial number", _or(item.get("serial"))), ("Control", _or(item.get("control"))),
        ("Location", _or(item.get("location"))),
        ("Kinematic chain", item.get("chain", "")),
        ("Travel X, Y, Z [mm]", ", ".join(f"{a:g} to {b:g}" for a, b in travel))]))
    out.append(s)

    d = doc["dates"]
    s = CertSection("Dates")
    f = [("Date of measurement (as-found)", _or(d.get("as_found")))]
    if doc["results"].get("as_left") is not None:
        f.append(("Date of measurement (as-left)", _or(d.get("as_left"))))
    f.append(("Date of issue", d["issued"]))
    s.blocks.append(Block("fields", fields=f))
    out.append(s)

    s = CertSection("Method")
    s.blocks.append(Block("table", columns=["method", "reference", "what", "applied to"],
                          rows=[[m["id"], m["reference"], m["title"],
                                 _applied(m["measurements"])]
                                for m in doc["methods"]]))
    s.blocks.append(Block("p", text=_referral_sentence(doc) + " Positions "
                          "in mm; deviations, their parameters and uncertainties in µm."
                          + (" Angles (angular deviations, squareness) and their "
                             "uncertainties in µrad." if any(
                                 (r or {}).get("direct_optics") for r in
                                 doc["results"].values()) else "")
                          + (" Rotary axes: commanded angles in degrees, their angular "
                             "deviations, parameters and uncertainties in "
                             + ("µrad" if angle_units == "urad" else "arcsec")
                             + " (1 arcsec = 4.848 µrad)." if any(
                                 (r or {}).get("rotary") for r in
                                 doc["results"].values()) else "")))
    out.append(s)

    s = CertSection("Environment as measured")
    rows = []
    for state, env in doc["environment"].items():
        if env is None:
            continue
        if not env["recorded"]:
            rows.append([_state(state), "(all)", "not recorded", "", "", ""])
        for e in env["measurements"]:
            rows.append([_state(state), e["measurement"],
                         *[_range(e.get(k), dig) for k, dig in
                           (("air_temperature_c", 2), ("air_pressure_pa", 0),
                            ("humidity_pct", 1), ("material_temperature_c", 2))]])
    s.blocks.append(Block("table", columns=["state", "measurement", "air temperature [°C]",
                                            "air pressure [Pa]", "humidity [%]",
                                            "material temperature [°C]"], rows=rows))
    how = [[_state(state), e["measurement"], *_readings_cells(e["readings"])]
           for state, env in doc["environment"].items() if env is not None
           for e in env["measurements"] if e.get("readings")]
    if how:
        s.blocks.append(Block("table", columns=["state", "measurement", "compensated by",
                                                "referred to 20 °C by"], rows=how))
    out.append(s)

    s = CertSection("Measuring equipment")
    eq = doc["equipment"]
    if eq:
        s.blocks.append(Block("table", columns=["role", "make and model", "serial",
                                                "certificate", "calibrated", "due", "status"],
                              rows=[[e.get("role", ""), " ".join(str(e[k]) for k in
                                                                  ("make", "model")
                                                                  if e.get(k)),
                                     _or(e.get("serial"), "–"), _or(e.get("certificate"), "–"),
                                     _or(e.get("calibrated"), "–"), _or(e.get("due"), "–"),
                                     ("EXPIRED (due before " + ", ".join(e["expired_on"]) + ")")
                                     if e["expired"] else "valid"]
                                    for e in eq],
                              flagged=[i for i, e in enumerate(eq) if e["expired"]]))
        for e in eq:
            if e["expired"]:
                s.blocks.append(Block("flag", text=f"Expired: {e.get('role')} serial "
                                      f"{_or(e.get('serial'), '–')} was due for calibration "
                                      f"on {e.get('due')}, before the measurement "
                                      f"({', '.join(e['expired_on'])})."))
    else:
        s.blocks.append(Block("flag", text="No measuring equipment listed."))
    out.append(s)

    s = CertSection("Results")
    for state in ("as_found", "as_left"):
        res = doc["results"].get(state)
        if res is None:
            continue
        s.blocks.extend(_result_blocks(state, res, doc["results"].get("as_left") is not None,
                                       angle_units))
    out.append(s)

    pair = doc.get("as_found_as_left")
    if pair is not None:
        s = CertSection("As-found and as-left")
        s.blocks.append(Block("p", text=pair["statement"]))
        t = pair.get("tables")
        if t is not None:
            s.blocks.append(Block("fields", fields=[
                ("Compensation tables loaded", t["folder"]),
                ("Manifest", f"{t['manifest']} (sha256 {t['manifest_sha256'][:16]})"),
                ("Controller format", _or(t.get("controller_format"))),
                ("From model", _or(t.get("model")) + (f" (sha256 {t['model_sha256'][:16]})"
                                                      if t.get("model_sha256") else "")),
                ("Tables carry", ", ".join(t.get("carries", [])) or "–"),
                ("Files", ", ".join(t.get("files", [])) or "–")]))
        else:
            s.blocks.append(Block("flag", text="The compensation tables loaded between the "
                                  "two measurements are not named (--tables)."))
        opt_pairs = pair.get("direct_optics_pairs") or []
        rot_pairs = pair.get("rotary_pairs") or []
        if not pair["pairs"] and not opt_pairs and not rot_pairs:
            s.blocks.append(Block("flag", text="No evaluated measurement id is common to the "
                                  "as-found and the as-left session: nothing to pair."))
        if pair["pairs"] or not rot_pairs:  # (a rotary-only calibration: the table below)
            s.blocks.append(Block("table", title="Measured as-found and as-left [µm]",
                                  columns=["measurement", "axis", "quantity", "as-found",
                                           "as-left", "change"],
                                  rows=[[p["measurement"], str(p["axis"]), _KEYS.get(
                                      p["quantity"], p["quantity"]), _n(p["as_found_um"]),
                                         _n(p["as_left_um"]),
                                         _n(p["as_left_um"] - p["as_found_um"])]
                                        for p in pair["pairs"]]))
        if rot_pairs:
            s.blocks.append(_rotary_pairs_block(rot_pairs, angle_units))
        if opt_pairs:
            s.blocks.append(Block("table", title="Direct optics (ISO 230-1) measured as-found "
                                  "and as-left", columns=["measurement", "axis", "quantity",
                                                          "unit", "as-found", "as-left",
                                                          "change"],
                                  rows=[[p["measurement"], p["axis"], p["quantity"],
                                         _UNITS[p["unit"]], _n(p["as_found"]),
                                         _n(p["as_left"]), _n(p["as_left"] - p["as_found"])]
                                        for p in opt_pairs]))
        out.append(s)

    u = doc["uncertainty"]
    s = CertSection("Measurement uncertainty")
    s.blocks.append(Block("p", text=u["statement"]))
    for mid, b in (u.get("budgets") or {}).items():
        s.blocks.extend(_budget_blocks(mid, b))
    out.append(s)

    c = doc.get("conformity")
    if c is not None:
        s = CertSection("Statement of conformity")
        s.blocks.append(Block("fields", fields=[
            ("Specification (tolerance)", f"{c['tolerance']} µm" if not c.get(
                "statements_urad") else f"{c['tolerance']} (µm; squareness_urad in µrad)"),
            ("Decision rule", f"{c['decision_rule']}: {c['rule']}")
            ] + ([("Guard band", f"{c['guard_band_um']:g} µm")]
                 if c.get("guard_band_um") is not None else [])))
        s.blocks.append(Block("table", columns=["state", "quantity", "tolerance [µm]",
                                                "value [µm]", "U [µm]", "verdict", "note"],
                              rows=[[_state(r["state"]), r["quantity"], _n(r["tolerance_um"]),
                                     _n(r["value_um"]), _n(r["U_um"]),
                                     r["verdict"] or "not stated", r.get("note") or ""]
                                    for r in c["statements"]],
                              flagged=[i for i, r in enumerate(c["statements"])
                                       if r["verdict"] == "fail"]))
        ang = c.get("statements_urad") or []
        if ang:
            s.blocks.append(Block("table", title="Squareness by optical square [µrad]",
                                  columns=["state", "quantity", "tolerance [µrad]",
                                           "value [µrad]", "U [µrad]", "verdict", "note"],
                                  rows=[[_state(r["state"]), r["quantity"],
                                         _n(r["tolerance_urad"]), _n(r["value_urad"]),
                                         _n(r["U_urad"]), r["verdict"] or "not stated",
                                         r.get("note") or ""] for r in ang],
                                  flagged=[i for i, r in enumerate(ang)
                                           if r["verdict"] == "fail"]))
        out.append(s)

    s = CertSection("Remarks")
    for w in doc["warnings"]:
        s.blocks.append(Block("flag" if w.startswith("EXPIRED") else "p", text=w))
    if doc.get("technical_report"):
        s.blocks.append(Block("p", text=f"The technical report {doc['technical_report']} "
                              "issued with this certificate gives the per-target tables, the "
                              "identified error functions and the figures."))
    s.blocks.append(Block("p", text="This certificate shall not be reproduced except in "
                          "full without the written approval of the laboratory. The results "
                          "relate only to the item calibrated, in the state and the "
                          "environment stated."))
    out.append(s)
    return out


def _applied(ids: list[str]) -> str:
    if not ids:
        return "identified model"
    return ", ".join(ids)


def _range(st: dict[str, Any] | None, digits: int) -> str:
    if st is None:
        return "–"
    if abs(st["max"] - st["min"]) < 0.5 * 10.0 ** -digits:
        return f"{st['mean']:.{digits}f}"
    return f"{st['min']:.{digits}f} to {st['max']:.{digits}f}"


def _result_blocks(state: str, res: dict[str, Any], paired: bool,
                   angle_units: str = "urad") -> list[Block]:
    head = f"{_state(state)}: " if paired else ""
    out = [Block("p", text=f"{head}session {res['session']}, measured {_or(res['date'])}, "
                 f"{res['readings']} readings (sha256 {res['readings_sha256'][:16]})"
                 + (", simulated" if res["simulated"] else "") + ".")]
    pos = res["positioning"]
    if pos:
        with_u = any(r["U_um"] for r in pos)
        cols = ["measurement", "axis"] + [f"{_KEYS[k]}" for k in _SHOWN]
        if with_u:
            cols += [f"U({_KEYS[k]})" for k in ("A", "E", "R", "B")] + ["k"]
        rows = []
        for r in pos:
            row = [r["measurement"] + ("" if r["complete"] else " (incomplete)"), r["axis"]]
            row += [_n(r["values_um"].get(k)) for k in _SHOWN]
            if with_u:
                U = r["U_um"] or {}
                row += [_n(U.get(k)) for k in ("A", "E", "R", "B")] + [_n(r.get("k"), 2)]
            rows.append(row)
        ed = sorted({str(r["edition"]) for r in pos if r.get("edition")})
        out.append(Block("table", title=f"{head}positioning, ISO 230-2:{'/'.join(ed)} [µm]",
                         columns=cols, rows=rows))
    rot = res.get("rotary") or []
    if rot:
        with_u = any(r["U"] for r in rot)
        judged = any(r.get("verdict") for r in rot)
        cols = ["measurement", "axis"] + [f"{_KEYS[k]}" for k in _SHOWN] + ["closure ↑/↓"]
        if with_u:
            cols += [f"U({_KEYS[k]})" for k in ("A", "E", "R", "B")] + ["k"]
        if judged:
            cols += ["tolerance (A)", "verdict"]
        rows = []
        from volcal.standards.iso230_2_rotary import UNITS

        f = UNITS[angle_units]  # the document's urad -> the printed unit

        def a(v: Any) -> str:
            return _n(None if v is None else float(v) * f)

        for r in rot:
            c = r.get("closure") or {}
            row = [r["measurement"] + ("" if r["complete"] else " (incomplete)"), r["axis"]]
            row += [a(r["values"].get(k)) for k in _SHOWN]
            row.append("–" if not c else f"{a(c.get('up'))} / {a(c.get('down'))}")
            if with_u:
                U = r["U"] or {}
                row += [a(U.get(k)) for k in ("A", "E", "R", "B")] + [_n(r.get("k"), 2)]
            if judged:
                row += [a(r.get("tolerance")), str(r.get("verdict") or "–")]
            rows.append(row)
        ed = sorted({str(r["edition"]) for r in rot if r.get("edition")})
        unit = "µrad" if angle_units == "urad" else "arcsec"
        out.append(Block("table", title=f"{head}rotary axes, angular positioning, ISO "
                         f"230-2:{'/'.join(ed)} [{unit}] (1 arcsec = 4.848 µrad; positive "
                         "counter-clockwise seen from the positive end of the axis, ISO 841)",
                         columns=cols, rows=rows))
    out.extend(location_blocks(head, res.get("location") or []))  # 5-axis location errors
    dia = res["diagonals"]
    if dia:
        with_u = any(r["U_E_D_um"] is not None for r in dia)
        out.append(Block("table", title=f"{head}diagonal displacement, ISO 230-6 [µm]",
                         columns=["measurement", "diagonal", "length [mm]", "points", "E_D"]
                         + (["U(E_D)"] if with_u else []),
                         rows=[[r["measurement"], str(r["diagonal"]), _n(r["length_mm"], 1),
                                r["points"], _n(r["E_D_um"])]
                               + ([_n(r["U_E_D_um"])] if with_u else []) for r in dia]))
    vol = res.get("volumetric")
    if vol:
        out.append(Block("table", title=f"{head}volumetric indices, ISO 230-1, from the "
                         "identified model [µm]",
                         columns=["", "E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ range",
                                  "grid"],
                         rows=[["value", _n(vol.get("E_VX")), _n(vol.get("E_VY")),
                                _n(vol.get("E_VZ")), _n(vol.get("E_VXYZ")),
                                _n(vol.get("E_VXYZ_range")), f"{vol.get('n')}³ points"]]
                         + ([[f"U (k = {vol.get('k', 2.0):g})",
                              *(_n(vol["U_um"].get(k)) for k in
                                ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range")),
                              "model covariance"]] if vol.get("U_um") else [])))
        if vol.get("uncertainty_note"):  # whether U includes the systematic part
            out.append(Block("note", text="Volumetric U: " + vol["uncertainty_note"]
                             + ("." if vol.get("systematic_included") else
                                ". The statement of conformity on the volumetric error "
                                "is qualified accordingly.")))
    out.extend(_optics_blocks(head, res.get("direct_optics")))
    if res.get("skipped"):
        out.append(Block("note", text="Not evaluated: " + "; ".join(
            f"{k} ({v})" for k, v in res["skipped"].items())))
    return out


def _rotary_pairs_block(pairs: list[dict[str, Any]], angle_units: str) -> Block:
    """The rotary tests' as-found / as-left table, in ``angle_units`` (the document: urad)."""
    from volcal.standards.iso230_2_rotary import UNITS

    f = UNITS[angle_units]
    unit = "µrad" if angle_units == "urad" else "arcsec"
    rows = []
    for p in pairs:
        mid = p["measurement"] + ("" if p["as_left_measurement"] == p["measurement"]
                                  else f" / {p['as_left_measurement']}")
        a, b = float(p["as_found_urad"]) * f, float(p["as_left_urad"]) * f
        rows.append([mid, str(p["axis"]), _KEYS.get(p["quantity"], p["quantity"]), _n(a),
                     _n(b), _n(b - a)])
    return Block("table", title=f"Rotary axes measured as-found and as-left [{unit}]",
                 columns=["measurement", "axis", "quantity", "as-found", "as-left", "change"],
                 rows=rows)


def _optics_blocks(head: str, opt: dict[str, Any] | None) -> list[Block]:
    """The direct optics' tables (ISO 230-1): straightness [µm], angular, squareness [µrad]."""
    if not opt:
        return []
    with_u = bool(opt.get("uncertainty_evaluated"))
    ref = _REF.get(opt["reference_line"], opt["reference_line"])
    uk = ["U", "k"] if with_u else []

    def u(r: dict[str, Any], key: str) -> list[str]:
        return [_n(r.get(key)), _n(r.get("k"), 2)] if with_u else []

    out = []
    st = opt["straightness"]
    if st:
        out.append(Block("table", title=f"{head}straightness, ISO 230-1 [µm]",
                         columns=["measurement", "axis", "error direction", "reference line",
                                  "length [mm]", "straightness", *uk],
                         rows=[[r["measurement"] + (" (slope removed)" if r.get("note")
                                                    else ""), r["axis"],
                                r["error_direction"], _REF.get(r["reference_line"], ref),
                                _n(r["length_mm"], 1), _n(r["straightness_um"]),
                                *u(r, "U_um")] for r in st]))
    an = opt["angular"]
    if an:
        out.append(Block("table", title=f"{head}angular deviation, ISO 230-1 [µrad]",
                         columns=["measurement", "axis", "rotation", "optic",
                                  "angular deviation (range)", "min", "max", *uk],
                         rows=[[r["measurement"], r["axis"], r["rotation"],
                                r["target"].replace("_", " "),
                                _n(r["angular_deviation_urad"]), _n(r["min_urad"]),
                                _n(r["max_urad"]), *u(r, "U_urad")] for r in an]))
    sq = opt["squareness"]
    if sq:
        out.append(Block("table", title=f"{head}squareness by optical square, ISO 230-1 "
                         "[µrad]",
                         columns=["squareness", "optical square", "lines", "reference line",
                                  "square deviation", "u(square)", "value", *uk],
                         rows=[[r["name"], r["reference"], " + ".join(r["lines"]),
                                _REF.get(r["reference_line"], ref),
                                _n(r["square_deviation_urad"]), _n(r["u_square_urad"]),
                                _n(r["value_urad"]), *u(r, "U_urad")] for r in sq]))
    text = f"Direct optics: each optic evaluated on its own (ISO 230-1), {opt['reference']}."
    if not with_u:
        text += (" The expanded uncertainties of the direct optics' results were not "
                 "evaluated (no uncertainty budget given).")
    out.append(Block("note", text=text))
    return out


def _budget_blocks(mid: str, b: dict[str, Any]) -> list[Block]:
    contrib = b.get("contributors") or b.get("components") or []
    out = []
    head = ", ".join(f"{k} = {_n(b[k], 3) if isinstance(b[k], float) else b[k]}"
                     for k in ("measurand", "quantity", "u_um", "u_urad", "u_c_um", "dof",
                               "nu_eff", "k", "U_um", "U_urad") if b.get(k) is not None)
    if contrib and isinstance(contrib, list) and isinstance(contrib[0], dict):
        cols: list[str] = []
        for c in contrib:
            cols += [k for k in c if k not in cols]
        out.append(Block("table", title=f"Uncertainty budget, {mid}" + (f" ({head})"
                                                                         if head else ""),
                         columns=cols, rows=[[_n(c.get(k), 4) if isinstance(c.get(k), float)
                                              else _or(c.get(k), "–") for k in cols]
                                             for c in contrib]))
    elif head:
        out.append(Block("p", text=f"Uncertainty budget, {mid}: {head}"))
    return out


def _readings_cells(r: dict[str, Any]) -> list[str]:
    """Who compensated a measurement's readings, and who referred them to 20 °C."""
    comp = ("volcal, from raw readings" if r["compensated_by"] != "laser software"
            else "the laser software")
    if r["referred_by"] == "volcal":
        ref = (f"volcal at t = {float(r['material_temperature_c']):g} °C "
               f"(α = {float(r['expansion_ppm_per_k']):g} ppm/K)")
    elif r["referred_by"] == "laser software":
        ref = "the laser software"
    else:
        ref = f"{r['referred_by']} (readings as given)"
    return [comp, ref]


def _referral_sentence(doc: dict[str, Any]) -> str:
    """"Deviations are referred to 20 °C (ISO 1)." where true, else which are not stated."""
    unstated = sorted({e["measurement"] for env in doc["environment"].values()
                       if env is not None for e in env["measurements"]
                       if (e.get("readings") or {}).get("referred_by") in ("not stated",
                                                                           "not referred")})
    if not unstated:
        return "Deviations are referred to 20 °C (ISO 1)."
    return ("Deviations are referred to 20 °C (ISO 1) where the section Environment as "
            "measured says by whom; for " + ", ".join(unstated) + " the referral to "
            "20 °C is not stated: their readings are taken as the laser software gave them.")


def _nl(v: Any, d: int = 2) -> str:
    return "–" if v is None else f"{float(v):.{d}f}"


def location_blocks(head: str, entries: list[dict[str, Any]]) -> list[Block]:
    """The certificate's tables of ``results.<state>.location``.

    Parameters
    ----------
    head : str
        ``'As-found: '`` or ``''``.
    entries : list of dict
        :func:`volcal.report.certificate_location.location_results`'s.
    """
    out: list[Block] = []
    for e in entries:
        unit = {"um": "µm", "urad": "µrad"}
        out.append(Block(
            "table", title=f"{head}location errors of the rotary axes, chain {e['chain']} "
            f"(ISO 230-1:2012 3.5; U with k = {e['coverage_factor']:g})",
            columns=["error", "meaning", "value", "U", "unit", "status"],
            rows=[[r["name"], r["meaning"], _nl(r["value"]), _nl(r["U"]), unit[r["unit"]],
                   r["status"]] for r in e["errors"]]))
        sc = e["scatter"]
        text = (f"{head}scatter of the sphere centre (RMS): {_nl(sc['rms_before_um'])} µm with "
                f"the configured kinematics, {_nl(sc['rms_after_um'])} µm with the identified "
                "location errors applied (predicted); the linear axes' errors "
                + ("of the identified model applied." if e["linear_model"]
                   else "taken as perfect."))
        if e["determined_combinations"]:
            text += (" The determined errors stand for: "
                     + "; ".join(e["determined_combinations"]) + ".")
        out.append(Block("p", text=text))
        if e["paths"]:
            judged = e["tolerance"] is not None
            cols = ["test", "path", "poses", "range before X/Y/Z [µm]",
                    "range after X/Y/Z [µm]", "U [µm]"]
            if judged:
                cols += ["verdict before", "verdict after"]
            rows = []
            for p in e["paths"]:
                row = [p["measurement"], p["path"], str(p["n_poses"]),
                       "/".join(_nl(v, 1) for v in p["range_before_um"]),
                       "/".join(_nl(v, 2) for v in p["range_after_um"]), _nl(p["U_um"])]
                if judged:
                    row += [str(p["verdict_before"]), str(p["verdict_after"])]
                rows.append(row)
            out.append(Block("table", title=f"{head}sphere centre per path, ISO 10791-6-style "
                             f"(chain {e['chain']})", columns=cols, rows=rows))
        if e["tolerance"] is not None:
            out.append(Block("p", text=e["tolerance"]["statement"]))
    return out
