"""``volcal evaluate``: ISO 230-2, VDI/DGQ 3441, ISO 230-6, volumetric indices, optics."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from volcal import defaults as D
from volcal.cli._common import print_session_notes, print_table

console = Console(soft_wrap=True)  # no line breaks inside paths
err_console = Console(stderr=True, soft_wrap=True)  # warnings: standard error
evaluate_app = typer.Typer(help="Evaluate measurements to the standards (ISO 230-2, "
                           "VDI/DGQ 3441, ISO 230-6, ISO 230-1 volumetric indices).",
                           no_args_is_help=True)

_AXIS_LABELS = {"A": "A  accuracy", "A_up": "A↑", "A_down": "A↓",
                "E": "E  systematic error", "E_up": "E↑", "E_down": "E↓",
                "M": "M  range of mean bidirectional deviation",
                "R": "R  repeatability", "R_up": "R↑", "R_down": "R↓",
                "B": "B  reversal value", "B_mean": "B̄  mean reversal value"}


def _print_json(obj: Any) -> None:
    typer.echo(json.dumps(obj, indent=2))


def _iso_tables(res: Any, title: str, unc: Any = None) -> None:
    t = Table(title=escape(f"{title} (ISO 230-2:{res.edition})"))
    t.add_column("parameter")
    t.add_column(escape("value [um]"), justify="right")
    if unc is not None:
        t.add_column(escape("U [um]"), justify="right")
        t.add_column("k", justify="right")
    for k, label in _AXIS_LABELS.items():
        row = [label, f"{getattr(res, k):.3f}"]
        if unc is not None:
            e = unc.parameters[k]
            row += [f"{e.U:.3f}", f"{e.k:.2f}"]
        t.add_row(*row)
    print_table(console, t)
    tt = Table(title=escape("per target [um]; n↑ n↓: runs that reached the target"))
    cols = ["target [mm]", "n↑", "n↓", "x̄↑ [um]", "x̄↓ [um]", "x̄ [um]", "s↑ [um]",
            "s↓ [um]", "B_i [um]", "R↑ [um]", "R↓ [um]", "R_i [um]"]
    if unc is not None:
        cols.append("U(x̄) [um]")
    for c in cols:
        tt.add_column(escape(c), justify="right")
    for i, row in enumerate(res.targets.rows()):
        cells = [f"{row['target_mm']:.3f}", str(row["n_up"]), str(row["n_down"]),
                 *["-" if row[k] is None else f"{row[k]:.3f}"
                   for k in ("mean_up", "mean_down", "mean", "s_up", "s_down", "B", "R_up",
                             "R_down", "R")]]
        if unc is not None:
            cells.append(f"{unc.targets[i].U:.3f}")
        tt.add_row(*cells)
    print_table(console, tt)
    if not res.complete:
        console.print(f"[yellow]incomplete:[/] {len(res.missing)} missed reading(s); each "
                      "target is evaluated over the runs that reached it", highlight=False)
    for n in res.notes:
        console.print(f"[yellow]note:[/] {escape(n)}", highlight=False)
    for w in res.warnings:
        err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False)


def _budget_table(unc: Any, corrections: dict[str, Any]) -> None:
    r = unc.reading
    t = Table(title=f"uncertainty budget: mean deviation at {unc.length_mm:g} mm from the "
              f"datum ({unc.datum_mm:g} mm)")
    for c in ("contributor", "distribution", "u(x)", "unit", "c", "u_i [um]", "dof",
              "share"):
        t.add_column(c, justify="right")
    for c in r.components:
        t.add_row(escape(c.label), c.distribution,
                  "" if c.u_input is None else f"{c.u_input:.3g}", escape(c.unit),
                  "" if c.sensitivity is None else f"{c.sensitivity:.4g}", f"{c.u:.4f}",
                  "inf" if c.dof == float("inf") else f"{c.dof:g}", f"{100 * c.share:.1f} %")
    dof = "inf" if r.dof == float("inf") else f"{r.dof:.1f}"
    t.add_row("combined", "", "", "", "", f"{r.u:.4f}", dof, "100 %")
    console.print(t)
    console.print(f"U = k u = {r.k:.3f} × {r.u:.4f} = {r.U:.4f} um (95 % coverage, k from "
                  f"the effective degrees of freedom {dof})", highlight=False)
    console.print(f"note: {escape(corrections['text'])}", highlight=False)
    for n in unc.notes:
        console.print(f"note: {escape(n)}", highlight=False)


def _iso_decisions(res: Any, unc: Any, tolerance_um: str, rule: str,
                   guard_band_um: float | None) -> dict[str, Any]:
    """Decisions of every toleranced parameter; the combined verdict and the rule."""
    from volcal.standards.decision import RULE_TEXT, combine, decide, require_uncertainty
    from volcal.standards.tolerance import parse_parameter_tolerance

    tols = parse_parameter_tolerance(tolerance_um)
    require_uncertainty(rule, guard_band_um, unc is not None)
    ds: list[dict[str, Any]] = []
    for k, tol in tols.items():
        v = abs(float(getattr(res, k)))
        d = decide(v, tol, rule, None if unc is None else unc.parameters[k].U, guard_band_um)
        ds.append({"parameter": k, **d.to_dict(),
                   "U_um": None if unc is None else unc.parameters[k].U})
    return {"verdict": combine([d["verdict"] for d in ds]), "verdicts": ds, "rule": rule,
            "decision_rule": {"name": rule, "text": RULE_TEXT[rule]}}


def _refuse_session_folder(path: Path, standard: str = "ISO 230-2",
                           kinds: tuple[str, ...] = ("linear", "rotary")) -> None:
    """Refuse a session folder given where one positioning file is read, naming what would do.

    The files of its tests of ``kinds`` (what the command reads, one at a time;
    ``session.toml`` read leniently, a planned session too) and ``volcal evaluate session``
    (every test at once); a folder whose ``session.toml`` is not TOML is left to the
    reader's own message.

    Parameters
    ----------
    path : Path
        What the user named as the file.
    standard : str
        The standard the command evaluates, for the message.
    kinds : tuple of str
        The measurement kinds whose files the command reads.
    """
    if not (path.is_dir() and (path / "session.toml").is_file()):
        return
    from volcal.errors import VolcalInputError
    from volcal.io.paths import session_entries

    entries = session_entries(path)
    if entries is None:
        return
    files = [m["file"] for m in entries if m.get("kind") in kinds]
    if not files:
        raise VolcalInputError(f"a folder, not a positioning file (a session folder without "
                               f"{' or '.join(kinds)} tests, which {standard} evaluates; "
                               f"volcal evaluate session {path} evaluates its tests)", path)
    some = f"{', '.join(str(path / f) for f in files[:3])}{' ...' if len(files) > 3 else ''}"
    raise VolcalInputError(f"a folder, not a positioning file (a session folder: name one of "
                           f"its measurement files: {some}; volcal evaluate session {path} "
                           "evaluates every test)", path)


@evaluate_app.command("iso230-2")
def iso230_2_cmd(
    file: Path = typer.Argument(..., help="CSV: target_mm,run,direction,deviation_um or a "
                                "session measurement CSV of a linear test."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    edition: str = typer.Option(D.EDITION, help="ISO 230-2 edition: 2014, 2006, 1997, 1988."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML, `volcal budget "
                                       "--template`): U of every parameter and target "
                                       "(the values are the readings' own)."),
    tolerance_um: str | None = typer.Option(
        None, help="Tolerance [um]: a number (on the accuracy A) or A=..,E=..,R=.. per "
        "ISO 230-2 parameter; prints a verdict."),
    decision_rule: str = typer.Option(D.DECISION_RULE, help="simple (pass when value <= T) or "
                                      "guarded (pass at or below T - w, conditional up to "
                                      "T; w = U or --guard-band-um)."),
    guard_band_um: float | None = typer.Option(None, help="Guard band w of the guarded "
                                               "rule [um] (default: U of the parameter)."),
    units: str = typer.Option("urad", "--units", help="Rotary files (a target_deg column): "
                              "urad or arcsec for every angle printed."),
    tolerance_urad: str | None = typer.Option(
        None, help="Rotary files: tolerance [urad], a number (on A) or A=..,E=..,R=.."),
) -> None:
    """Positioning accuracy and repeatability of one axis, linear or rotary (ISO 230-2).

    A file with a ``target_deg`` column is a rotary axis: the parameters are angles
    (urad, or arcsec with ``--units arcsec``).
    """
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.iso230_2_rotary import is_rotary_csv
    from volcal.standards.positioning_data import read_positioning_csv

    _refuse_session_folder(file)
    rule = _checked_rule(decision_rule, guard_band_um)
    b = _budget_or_none(budget)
    if is_rotary_csv(file):
        _rotary_cmd(file, as_json, edition, b, budget, units, tolerance_um, tolerance_urad,
                    rule, guard_band_um)
        return
    if units != "urad" and Path(file).is_file():  # else the reader names the missing file
        from volcal.errors import VolcalInputError

        raise VolcalInputError("--units applies to rotary files (a target_deg column); a "
                               "linear axis' parameters are in um", file, None, "units")
    d = read_positioning_csv(file)
    unc = corrections = None
    if b is not None:
        from volcal.standards.iso230_2_uncertainty import evaluate_with_budget

        res, unc, corrections = evaluate_with_budget(d, b, edition)
    else:
        res = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, edition,
                       **d.evaluate_kwargs())
    plaus = _file_notes(d)
    dec = None if tolerance_um is None else _iso_decisions(res, unc, tolerance_um, rule,
                                                           guard_band_um)
    if as_json:
        out = res.to_dict()
        out["unit"] = "um"
        out["file"] = str(file)
        out["plausibility"] = plaus
        if unc is not None:
            ud = unc.to_dict()
            for i, row in enumerate(out["targets"]):
                e = unc.targets[i]
                row.update({"U_um": e.U, "u_um": e.u, "k": e.k,
                            "dof": None if e.dof == float("inf") else e.dof})
            out.update(ud)
            out["budget_file"] = str(budget)
            out["corrections"] = corrections
        if dec is not None:
            out.update(dec)
        _print_json(out)
        return
    _iso_tables(res, str(file), unc)
    if unc is not None and corrections is not None:
        _budget_table(unc, corrections)
    if dec is not None:
        _print_iso_decisions(dec)


def _rotary_cmd(file: Path, as_json: bool, edition: str, b: Any, budget: Path | None,
                units: str, tolerance_um: str | None, tolerance_urad: str | None, rule: str,
                guard_band_um: float | None) -> None:
    """``evaluate iso230-2`` of a rotary file: parse, evaluate, print in ``units``."""
    from volcal.errors import VolcalInputError
    from volcal.standards.iso230_2_rotary import check_units, evaluate_rotary_file

    check_units(units)
    if tolerance_um is not None or guard_band_um is not None:
        raise VolcalInputError("a rotary file's parameters are angles: give the tolerance "
                               "with --tolerance-urad (and the guard band is U)", file, None,
                               "tolerance_um")
    res, notes = evaluate_rotary_file(file, edition, b)
    for n in notes:
        err_console.print(f"note: {escape(n)}", highlight=False)
    from volcal.standards.iso230_2_rotary import read_rotary_file, rotary_plausibility

    plaus = rotary_plausibility(read_rotary_file(file)[0].deviation_urad, str(file))
    for w in plaus:
        err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False)
    dec = None
    if tolerance_urad is not None:
        dec = _iso_decisions(res, res.uncertainty, tolerance_urad, rule, None)
        for d in dec["verdicts"]:
            for k in list(d):
                if k.endswith("_um"):
                    d[k[:-3] + "_urad"] = d.pop(k)
    if as_json:
        out = res.to_dict(units)
        out["file"] = str(file)
        out["plausibility"] = plaus
        if budget is not None:
            out["budget_file"] = str(budget)
            out["corrections"] = {"material_applied": False,
                                  "cosine_expectation_applied": False,
                                  "largest_correction_um": 0.0,
                                  "text": "angles read by an angular interferometer need no "
                                          "air or material correction: the readings are "
                                          "evaluated as given"}
        if dec is not None:
            out.update(dec)
        _print_json(out)
        return
    print_rotary_tables(res, str(file), units)
    if dec is not None:
        from volcal.standards.iso230_2_rotary import UNITS

        colour = {"pass": "green", "fail": "red", "conditional": "yellow"}
        f = UNITS[units]  # the verdict in the unit of the tables above (JSON: urad keys)
        for d in dec["verdicts"]:
            console.print(f"{d['parameter']}: {d['value_urad'] * f:.3f} {units}, tolerance "
                          f"{d['tolerance_urad'] * f:.4g} {units}: [{colour[d['verdict']]}]"
                          f"{d['verdict']}[/]", highlight=False)
        console.print(f"verdict: {dec['verdict']} (decision rule: "
                      f"{escape(dec['decision_rule']['text'])})", highlight=False)


def print_rotary_tables(res: Any, title: str, units: str = "urad") -> None:
    """Print a rotary ISO 230-2 result (parameters, per target, closure) in ``units``.

    Parameters
    ----------
    res : RotaryIso2302Result
        The evaluation.
    title : str
        Table title (the file or measurement).
    units : str
        ``'urad'`` or ``'arcsec'``.
    """
    d = res.to_dict(units)
    unc = res.uncertainty
    axis = "" if res.axis == "?" else f" {res.axis}"  # a lone file does not name its axis
    t = Table(title=escape(f"{title}: rotary axis{axis} (ISO 230-2:{res.iso.edition})"))
    t.add_column("parameter")
    t.add_column(escape(f"value [{units}]"), justify="right")
    if unc is not None:
        t.add_column(escape(f"U [{units}]"), justify="right")
        t.add_column("k", justify="right")
    for k, label in _AXIS_LABELS.items():
        row = [label, f"{d[k]:.3f}"]
        if unc is not None:
            row += [f"{d[f'U_{k}']:.3f}", f"{unc.parameters[k].k:.2f}"]
        t.add_row(*row)
    print_table(console, t)
    tt = Table(title=escape(f"per target [{units}]; n↑ n↓: runs that reached the target"))
    cols = ["target [deg]", "n↑", "n↓", "x̄↑", "x̄↓", "x̄", "s↑", "s↓", "B_i", "R_i"]
    if unc is not None:
        cols.append("U(x̄)")
    for c in cols:
        tt.add_column(escape(c), justify="right")
    for row in d["targets"]:
        cells = [f"{row['target_deg']:.3f}", str(row["n_up"]), str(row["n_down"]),
                 *["-" if row[k] is None else f"{row[k]:.3f}"
                   for k in ("mean_up", "mean_down", "mean", "s_up", "s_down", "B", "R")]]
        if unc is not None:
            cells.append(f"{row[f'U_{units}']:.3f}")
        tt.add_row(*cells)
    print_table(console, tt)
    c = d["closure"]
    if c:
        console.print(f"closure ({c['targets_deg'][0]:g} and {c['targets_deg'][1]:g} deg are "
                      f"one position): {c['up']:.3f} {units} up, {c['down']:.3f} {units} down",
                      highlight=False)
    for n in res.iso.notes:
        console.print(f"[yellow]note:[/] {escape(n)}", highlight=False)
    for w in res.warnings:
        err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False)
    if unc is not None:
        for n in unc.notes:
            console.print(f"note: {escape(n)}", highlight=False)


def _print_iso_decisions(dec: dict[str, Any]) -> None:
    colour = {"pass": "green", "fail": "red", "conditional": "yellow"}
    t = Table(title=f"verdict, decision rule: {dec['decision_rule']['name']}")
    for c in ("parameter", "value [um]", "tolerance [um]", "U [um]", "T - w [um]",
              "verdict"):
        t.add_column(c, justify="right")
    for d in dec["verdicts"]:
        t.add_row(d["parameter"], f"{d['value_um']:.3f}", f"{d['tolerance_um']:g}",
                  "-" if d["U_um"] is None else f"{d['U_um']:.3f}",
                  f"{d['acceptance_limit_um']:.3f}",
                  f"[{colour[d['verdict']]}]{d['verdict']}[/]")
    console.print(t)
    console.print(f"verdict: {dec['verdict']} (decision rule: "
                  f"{escape(dec['decision_rule']['text'])})", highlight=False)
    for d in dec["verdicts"]:
        if d["note"]:
            console.print(f"note ({d['parameter']}): {escape(d['note'])}", highlight=False)


def _file_notes(d: Any) -> list[str]:
    """Print a positioning file's reader notes and plausibility warnings on stderr.

    Returns the warnings (for the JSON output).
    """
    from volcal.session.plausibility import positioning_warnings

    err = Console(stderr=True, soft_wrap=True)
    for n in d.notes:
        err.print(f"[cyan]note:[/] {escape(n)}", highlight=False)
    warnings = positioning_warnings(d)
    for w in warnings:
        err.print(f"[yellow]warning:[/] {escape(w)}", highlight=False)
    return warnings


@evaluate_app.command("vdi3441")
def vdi3441_cmd(
    file: Path = typer.Argument(..., help="Same CSV layouts as iso230-2."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Positioning parameters of VDI/DGQ 3441 (P, Pa, Ps, U)."""
    from volcal.standards.positioning_data import read_positioning_csv
    from volcal.standards.vdi3441 import evaluate

    _refuse_session_folder(file, "VDI/DGQ 3441", ("linear",))
    d = read_positioning_csv(file)
    res = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, **d.evaluate_kwargs())
    _file_notes(d)
    if as_json:
        _print_json(res.to_dict())
        return
    t = Table(title=escape(f"{file} (VDI/DGQ 3441)"))
    t.add_column("parameter")
    t.add_column(escape("value [um]"), justify="right")
    for k in ("P", "Pa", "Ps", "Ps_mean", "U", "U_mean"):
        t.add_row(k, f"{getattr(res, k):.3f}")
    print_table(console, t)


@evaluate_app.command("iso230-6")
def iso230_6_cmd(
    session: Path = typer.Argument(..., help="Session folder."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML): U of E_D "
                                       "(and of the ISO 230-2 parameters of bidirectional "
                                       "diagonals); values unchanged."),
) -> None:
    """Diagonal displacement tests of a session (ISO 230-6), each diagonal."""
    from volcal.errors import VolcalInputError
    from volcal.session.format import read_session
    from volcal.standards.iso230_6 import evaluate_diagonal, largest_e_d

    b = _budget_or_none(budget)
    s = read_session(session)
    print_session_notes(s)
    diags = [m for m in s.measurements if m.kind == "diagonal"]
    if not diags:
        raise VolcalInputError("no diagonal measurements in the session", session)
    if b is None:
        res = [evaluate_diagonal(m) for m in diags]
        unc: list[Any] = [None] * len(res)
    else:
        from volcal.standards.iso230_6_uncertainty import evaluate_diagonal_with_budget

        pairs = [evaluate_diagonal_with_budget(m, b) for m in diags]
        res, unc = [p[0] for p in pairs], [p[1] for p in pairs]
    worst = largest_e_d(res)
    incomplete = [r.id for r in res if not r.complete]
    if as_json:
        out_d = []
        for r, u in zip(res, unc, strict=True):
            d = r.to_dict()
            if u is not None:
                d.update(u.to_dict())
                if u.iso230_2 is not None:
                    d["iso230_2"].update({k: v for k, v in u.iso230_2.to_dict().items()
                                          if k.startswith("U_") or k == "k"})
            out_d.append(d)
        _print_json({"diagonals": out_d,
                     "max_E_D": None if worst is None else worst.E_D,
                     "max_E_D_id": None if worst is None else worst.id,
                     "complete": not incomplete, "incomplete": incomplete,
                     "unmeasured": [m.id for m in s.unmeasured if m.kind == "diagonal"]})
        return
    t = Table(title=escape(f"{session}: ISO 230-6 diagonal displacement"))
    cols = ["id", "diagonal", "length [mm]", "points", "E_D [um]", "max |dev| [um]",
            "R [um]"]
    if b is not None:
        cols.insert(5, "U(E_D) [um]")
    for c in cols:
        t.add_column(escape(c), justify="right")
    for r, u in zip(res, unc, strict=True):
        rr = "" if r.iso230_2 is None else f"{r.iso230_2.R:.3f}"
        pts = f"{r.points_measured}/{r.points_planned}" + ("" if r.complete else " incomplete")
        row = [r.id, (r.plane + " " if r.plane else "") + r.diagonal, f"{r.length_mm:.1f}",
               pts, f"{r.E_D:.3f}", f"{r.max_abs_um:.3f}", rr]
        if u is not None:
            row.insert(5, f"{u.E_D.U:.3f}")
        t.add_row(*row)
    print_table(console, t)
    for r in res:
        if not r.complete:
            console.print(f"[yellow]incomplete:[/] {escape(r.note())}", highlight=False)
    if worst is not None:
        console.print(f"largest E_D of the complete diagonals: {worst.E_D:.3f} um "
                      f"({worst.id})", highlight=False)
    else:
        console.print("largest E_D: none (no complete diagonal)", highlight=False)
    notes = sorted({n for u in unc if u is not None for n in u.notes})
    for n in notes:
        console.print(f"note: {escape(n)}", highlight=False)


@evaluate_app.command("session")
def session_cmd(
    session: Path = typer.Argument(..., help="Session folder."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    edition: str = typer.Option(D.EDITION, help="ISO 230-2 edition."),
    tolerance_um: str | None = typer.Option(
        None, help="Tolerance for a pass/fail verdict [um]: X=10,Y=10,Z=8 (ISO 230-2 "
        "accuracy A per axis), a number (largest volumetric error of --model) or both "
        "(X=10,Y=10,Z=8,V=15)."),
    model: Path | None = typer.Option(None, help="Identified model (MODEL.json): the "
                                      "ISO 230-1 volumetric indices, straightness and "
                                      "squareness of the model with their U (from its "
                                      "covariance, noise and systematic parts); needed for "
                                      "a volumetric tolerance and for the verdict after "
                                      "compensation."),
    compensation: Path | None = typer.Option(None, help="Folder written by `volcal "
                                             "compensate` for this machine: the verdict after "
                                             "its tables, read back from the files. Tables "
                                             "written for another machine are refused "
                                             "(--force to use them)."),
    force: bool = typer.Option(False, "--force", help="Use --compensation tables written "
                               "for another machine (a warning instead of an error)."),
    decision_rule: str = typer.Option(D.DECISION_RULE, help="simple (pass when value <= T) or "
                                      "guarded (pass at or below T - w, conditional up to "
                                      "T; w = U from --budget, or --guard-band-um)."),
    guard_band_um: float | None = typer.Option(None, help="Guard band w of the guarded "
                                               "rule [um]."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML): U of every "
                                       "ISO 230-2 parameter of every linear test (values "
                                       "unchanged); the guard band of the guarded rule."),
    units: str = typer.Option("urad", "--units", help="Rotary tests: urad or arcsec for "
                              "every angle printed."),
) -> None:
    """ISO 230-2 for every linear and rotary measurement with runs and directions; ELv."""
    from volcal.errors import VolcalInputError
    from volcal.session.format import read_session

    tol = _tolerance_inputs(tolerance_um, model, compensation)
    tol = (_acceptance(tol[0], decision_rule, guard_band_um, budget), tol[1], tol[2])
    if tol[0] is not None and (tol[0].straightness_um or tol[0].squareness_urad):
        Console(stderr=True, soft_wrap=True).print(
            "note: the straightness_um / squareness_urad limits are the direct optics': "
            "judged by `volcal evaluate optics SESSION --tolerance-um ...` and on the "
            "certificate, not here", highlight=False)
    from volcal.standards.iso230_2_rotary import check_units

    check_units(units)
    s = read_session(session)
    print_session_notes(s)
    from volcal.steps.evaluate import evaluate

    b = tol[0].budget if tol[0] is not None else _budget_or_none(budget)
    done = evaluate(s, model=model, edition=edition, budget=b, tolerance=tol[0],
                    compensation=compensation, force=force)
    err = Console(stderr=True, soft_wrap=True)  # stdout may be --json
    for w in done.warnings:
        err.print(f"[yellow]warning[/] {escape(w)}", highlight=False)
    for d in done.other_session:
        err.print(f"note: --model {escape(str(model))} was not identified from this session "
                  f"({escape(d)}); its indices describe the model's session", highlight=False)
    ev = done.evaluation
    results, axis_of = ev.iso230_2, ev.axis
    why_skipped = {k: why for k, why in ev.skipped.items() if why != "no readings yet"}
    skipped = list(why_skipped)
    if not results and not ev.rotary:
        by_reason: dict[str, list[str]] = {}
        for k, w in why_skipped.items():
            by_reason.setdefault(w, []).append(k)
        why = "".join(f"\n  {', '.join(ks)}: {w}" for w, ks in by_reason.items())
        raise VolcalInputError("no linear or rotary measurement to evaluate to ISO 230-2"
                               + (f":{why}" if why else " (none with run and direction "
                                  "columns)"), session)
    elv_val = None if ev.elv is None else ev.elv["ELv"]
    verdict = None if done.verdicts is None else list(done.verdicts)
    uncs = ev.uncertainties
    corr_text = ev.corrections_text
    if as_json:
        out: dict[str, Any] = {"measurements": {k: {"axis": axis_of[k], **v.to_dict()}
                                                for k, v in results.items()},
                               "ELv": elv_val, "skipped": skipped,
                               "skipped_reasons": why_skipped,
                               "incomplete": [k for k, v in results.items() if not v.complete],
                               "unmeasured": list(ev.unmeasured)}
        if ev.volumetric is not None:
            out["volumetric"] = ev.volumetric.to_dict()
            out.update(ev.model_indices or {})
        from volcal.environment.apply import thermal_record

        for k in results:  # how each test's readings were compensated and referred
            out["measurements"][k]["thermal"] = thermal_record(s.get(k))
        for k, u in uncs.items():
            entry = out["measurements"][k]
            entry.update(u.to_dict())
            for i, row in enumerate(entry["targets"]):
                row["U_um"] = u.targets[i].U
        if uncs:
            out["corrections"] = corr_text
        if ev.rotary:
            out["rotary"] = {k: r.to_dict(units) for k, r in ev.rotary.items()}
        if verdict is not None:
            from volcal.standards.decision import RULE_TEXT

            out["verdict"] = [v.to_dict() for v in verdict]
            rule = tol[0].rule
            out["decision_rule"] = {"name": rule, "text": RULE_TEXT[rule]}
        _print_json(out)
        return
    for k, r in ev.rotary.items():
        print_rotary_tables(r, k, units)
    if not results:
        return
    t = Table(title=escape(f"{session}: ISO 230-2:{edition} [um]"))
    cols = ["id", "axis", "runs", "A [um]", "E [um]", "M [um]", "R [um]", "B [um]",
            "B_mean [um]"]
    if uncs:
        cols += ["U(A) [um]", "U(E) [um]", "U(R) [um]"]
    for c in cols:
        t.add_column(escape(c), justify="right")
    for k, r in results.items():
        row = [k, axis_of[k], _runs_cell(r), *[f"{getattr(r, p):.3f}" for p in
                                               ("A", "E", "M", "R", "B", "B_mean")]]
        if uncs:
            row += [f"{uncs[k].parameters[p].U:.3f}" for p in ("A", "E", "R")]
        t.add_row(*row)
    print_table(console, t)
    from volcal.environment.apply import thermal_record

    for k in results:
        console.print(f"readings {k}: {escape(thermal_record(s.get(k))['text'])}",
                      highlight=False)
    if corr_text:
        console.print(f"note: {escape(corr_text)}; U at 95 % (k from the effective degrees "
                      "of freedom)", highlight=False)
    for k, r in results.items():
        for n in r.notes:
            console.print(f"[yellow]{k}[/] {escape(n)}", highlight=False)
    if ev.unmeasured:
        console.print(f"[yellow]not measured[/] (planned, no readings): "
                      f"{', '.join(ev.unmeasured)}", highlight=False)
    if elv_val is not None:
        console.print(f"ELv (seed 002: RSS of the positioning ranges M of the first line of "
                      f"each axis) = {elv_val:.3f} um")
    if ev.volumetric is not None:
        _print_model_indices(ev)
    grouped: dict[str, list[str]] = {}
    for k, r in results.items():
        for w in r.warnings:
            grouped.setdefault(w, []).append(k)
    for w, ids in grouped.items():
        err_console.print(f"[yellow]warning[/] ({', '.join(ids)}): {escape(w)}",
                          highlight=False)
    for k, why in why_skipped.items():
        console.print(f"[yellow]skipped[/] {k}: {escape(why)}", highlight=False)
    if verdict:
        _print_verdict(verdict, model is not None)


def _print_model_indices(ev: Any) -> None:
    """The model's volumetric indices, straightness and squareness with U."""
    v = ev.volumetric
    u = v.uncertainty
    t = Table(title="identified model: ISO 230-1 indices")
    for c in ("index", "value", "U (k = 2)", "u noise", "u systematic", "unit"):
        t.add_column(c, justify="right")
    for k in ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range"):
        e = u.volumetric[k]
        t.add_row(k, f"{getattr(v, k):.3f}", f"{e.U:.3f}", f"{e.u_noise:.3f}",
                  f"{e.u_sys:.3f}", "um")
    for k, e in u.straightness.items():
        t.add_row(f"straightness {k}", f"{e.value:.3f}", f"{e.U:.3f}", f"{e.u_noise:.3f}",
                  f"{e.u_sys:.3f}", "um")
    for k, e in u.squareness.items():
        t.add_row(k, f"{e.value:.2f}", f"{e.U:.2f}", f"{e.u_noise:.2f}", f"{e.u_sys:.2f}",
                  "urad")
    print_table(console, t)
    for n in u.notes:
        console.print(f"note: {escape(n)}", highlight=False)


def _checked_rule(decision_rule: str, guard_band_um: float | None) -> str:
    """The decision rule (checked), refusing a guard band without the guarded rule."""
    from volcal.standards.decision import check_acceptance

    return check_acceptance(decision_rule, guard_band_um)


def _budget_or_none(budget: Path | None) -> Any:
    """The budget file read (:func:`volcal.uncertainty.budget.read_budget`), or None."""
    if budget is None:
        return None
    from volcal.uncertainty.budget import read_budget

    return read_budget(budget)


def _acceptance(tol: Any, decision_rule: str, guard_band_um: float | None,
                budget: Path | None) -> Any:
    """The tolerance with its decision rule, guard band and budget (checked).

    :func:`volcal.steps._checks.acceptance`, the check behind both faces.
    """
    from volcal.steps._checks import acceptance

    return acceptance(tol, decision_rule, guard_band_um, budget)


def _runs_cell(r: Any) -> str:
    """Runs of a linear test: ``5``, or ``4-5 incomplete`` (fewest runs at a target)."""
    nu, nd = r.targets.counts()
    full = max(r.targets.n_up, r.targets.n_down)
    if r.complete:
        return str(full)
    return f"{int(min(nu.min(), nd.min()))}-{full} incomplete"


def _tolerance_inputs(tolerance_um: str | None, model: Path | None,
                      compensation: Path | None) -> tuple[Any, Any, Any]:
    """Parse the tolerance; refuse --compensation without it or without --model."""
    from volcal.errors import VolcalInputError

    if tolerance_um is None:
        if compensation is not None:
            raise VolcalInputError("--compensation is used by the tolerance verdict: give "
                                   "--tolerance-um too")
        return None, None, None
    from volcal.standards.tolerance import parse_tolerance

    tol = parse_tolerance(tolerance_um)
    if compensation is not None and model is None:
        raise VolcalInputError("--compensation needs the --model the tables were written from")
    return tol, None, None

def _verdict_word(w: str) -> str:
    """A verdict coloured for the terminal (pass green, fail red, conditional yellow)."""
    return {"pass": "[green]pass[/]", "fail": "[red]fail[/]",
            "conditional": "[yellow]conditional[/]"}.get(w, w)


def _print_verdict(verdict: Any, has_model: bool) -> None:
    from volcal.standards.decision import RULE_TEXT

    rule = verdict[0].rule if verdict else "simple"
    guarded = rule == "guarded"
    t = Table(title=escape(f"tolerance verdict [um], decision rule: {rule}"))
    cols = ["quantity", "tolerance [um]", "before [um]", "", "after [um]", ""]
    if guarded:
        cols[3:3] = ["U / w [um]"]
        cols.append("U / w [um]")
    for c in cols:
        t.add_column(escape(c), justify="right")

    def cell(v: Any) -> str:
        return "-" if v is None else f"{v:.3f}"

    for v in verdict:
        row = [escape(v.quantity), f"{v.tolerance_um:g}", cell(v.before_um),
               _verdict_word(v.before), cell(v.after_um), _verdict_word(v.after)]
        if guarded:
            w = v.guard_band_um
            row[3:3] = [cell(w if w is not None else v.U_before_um)]
            row.append(cell(w if w is not None else v.U_after_um))
        t.add_row(*row)
    print_table(console, t)
    console.print(f"decision rule: {escape(RULE_TEXT[rule])}", highlight=False)
    for v in verdict:
        for d in (v.decision(v.before_um, v.U_before_um), v.decision(v.after_um, v.U_after_um)):
            if d is not None and d.note:
                console.print(f"note ({escape(v.quantity)}): {escape(d.note)}",
                              highlight=False)
    if not any(v.after_um is not None for v in verdict):
        console.print("no verdict after compensation: give --model MODEL.json and "
                      "--compensation FOLDER" if not has_model else
                      "no verdict after compensation: give --compensation FOLDER",
                      highlight=False)


@evaluate_app.command("volumetric")
def volumetric_cmd(
    errors: Path = typer.Argument(..., help="Error table CSV (ERRORS.csv) or identified "
                                  "model (MODEL.json: the indices of its estimate; "
                                  "`volcal report` states them with their U)."),
    tool_offset: str = typer.Option("0,0,0", help="Tool point offset x,y,z [mm]."),
    n: int = typer.Option(11, min=2, max=201, help="Grid points per axis."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """ISO 230-1 volumetric indices E_VX, E_VY, E_VZ, E_VXYZ of an error table or a model; ELv."""
    from volcal.cli._common import parse_vector
    from volcal.compensate.source import load_errors
    from volcal.standards.volumetric import elv_from_model, volumetric_indices

    m = load_errors(errors)
    res = volumetric_indices(m, parse_vector(tool_offset, "--tool-offset"), n)
    out = {**res.to_dict(), **elv_from_model(m)}
    if as_json:
        _print_json(out)
        return
    t = Table(title=escape(f"{errors}: volumetric indices [um]"))
    t.add_column("index")
    t.add_column(escape("value [um]"), justify="right")
    for k in ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range", "ELx", "ELy", "ELz", "ELv"):
        t.add_row(k, f"{out[k]:.3f}")
    print_table(console, t)


@evaluate_app.command("optics")
def optics_cmd(
    session: Path = typer.Argument(..., help="Session folder."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML, `volcal budget "
                                       "--template`): expanded uncertainty (k = 2) of every "
                                       "straightness, angular deviation and squareness from "
                                       "its [optics] section (data-sheet defaults when "
                                       "absent) and the optical squares' certificates."),
    tolerance_um: str | None = typer.Option(
        None, help="Limits for a verdict: X.straightness_um=4 (the largest ISO 230-1 "
        "straightness, least-squares line, of the lines moving along X) and "
        "EC0Y.squareness_urad=20 (the magnitude of a squareness by optical square), "
        "comma-separated."),
    decision_rule: str = typer.Option(D.DECISION_RULE, help="simple (pass when value <= T) or "
                                      "guarded (pass at or below T - w, conditional up to "
                                      "T; w = U from --budget, or --guard-band-um for the "
                                      "straightness)."),
    guard_band_um: float | None = typer.Option(None, help="Guard band w of the guarded "
                                               "rule for the straightness [um] (a "
                                               "squareness takes its own U)."),
) -> None:
    """ISO 230-1 of the direct optics: straightness, angular deviation, optical squares.

    Straightness about the end-point and the least-squares lines, the range of each
    angular line, the squareness of each optical-square pair; with --budget, U of each;
    with --tolerance-um, a verdict per limit under the decision rule (the certificate's
    statements, volcal.report.certificate_optics).
    """
    from volcal.errors import VolcalInputError
    from volcal.session.format import read_session
    from volcal.standards.session import optics_evaluation

    tol = None
    if tolerance_um is not None:
        from volcal.standards.tolerance import parse_tolerance

        tol = parse_tolerance(tolerance_um)
        if not (tol.straightness_um or tol.squareness_urad):
            raise VolcalInputError(
                f"--tolerance-um {tolerance_um!r} holds no direct-optics limit: give "
                "<axis>.straightness_um=... or <EC0Y|EB0Z|EA0Z>.squareness_urad=... (ISO 230-2 "
                "and volumetric limits are judged by `volcal evaluate session`)")
    decision_rule = _checked_rule(decision_rule, guard_band_um)
    b = _budget_or_none(budget)
    s = read_session(session)
    print_session_notes(s)
    ev = optics_evaluation(s, b)  # once, with U given a budget
    if ev is None:
        raise VolcalInputError("no straightness or angular measurement with readings", session)
    if b is not None:
        ev["budget_file"] = str(budget)
    if tol is not None:
        from volcal.report.certificate_optics import direct_optics, optics_conformity
        from volcal.standards.decision import RULE_TEXT

        um, urad = optics_conformity(
            tol, {"as_found": {"direct_optics": direct_optics(s, b, ev)}}, decision_rule,
            guard_band_um)
        ev["conformity"] = {"decision_rule": decision_rule, "rule": RULE_TEXT[decision_rule],
                            "guard_band_um": guard_band_um,
                            "statements": [{k: v for k, v in r.items() if k != "state"}
                                           for r in um + urad]}
    if as_json:
        _print_json(ev)
        return

    def _u(r: dict[str, Any], key: str, fmt: str) -> list[str]:
        return [] if b is None else [format(r[key], fmt)]

    t = Table(title=escape(f"{session}: straightness (ISO 230-1) [um], slope [urad]"
                           + (", U (k = 2)" if b is not None else "")))
    cols = ["id", "axis", "along", "end-point", "least-squares", "LS slope"]
    if b is not None:
        cols[4:4] = ["U end-point"]
        cols[6:6] = ["U least-squares"]
        cols.append("U slope")
    for c in cols:
        t.add_column(c, justify="right")
    for k, r in ev["straightness"].items():
        ep, ls = r["end_point"], r["least_squares"]
        t.add_row(k, r["axis"].upper(), r["error_direction"].upper(),
                  f"{ep['straightness_um']:.3f}", *_u(ep, "U_straightness_um", ".3f"),
                  f"{ls['straightness_um']:.3f}", *_u(ls, "U_straightness_um", ".3f"),
                  f"{ls['slope_urad']:.2f}", *_u(ls, "U_slope_urad", ".2f"))
    if ev["straightness"]:
        print_table(console, t)
    t = Table(title=escape(f"{session}: angular deviation (ISO 230-1) [urad]"))
    for c in ("id", "axis", "about", "optic", "range", *(["U"] if b is not None else [])):
        t.add_column(c, justify="right")
    for k, r in ev["angular"].items():
        t.add_row(k, r["axis"].upper(), r["rotation"].upper(), r["target"].replace("_", " "),
                  f"{r['angular_deviation_urad']:.2f}",
                  *_u(r, "U_angular_deviation_urad", ".2f"))
    if ev["angular"]:
        print_table(console, t)
    for r in ev["squareness"]:
        nm = r["name"]
        ls, ep = r["least_squares"], r["end_point"]

        def pm(e: dict[str, Any], nm: str = nm) -> str:
            return f" +- {e['U_' + nm]:.2f}" if b is not None else ""

        console.print(f"squareness {r['axes'].upper()} (optical square {r['reference']!r}, "
                      f"{' + '.join(r['lines'])}, square {r['square_deviation_urad']:g} urad): "
                      f"{nm} = {ls[nm]:.2f}{pm(ls)} urad from the least-squares "
                      f"lines (ISO 230-1), {ep[nm]:.2f}{pm(ep)} urad from the end-point "
                      "lines (the identified model's reference)", highlight=False)
    if b is not None:
        for n in ev["uncertainty"]["notes"]:
            console.print(f"note: {escape(n)}", highlight=False)
    if "conformity" in ev:
        _print_optics_conformity(ev["conformity"])


def _print_optics_conformity(conf: dict[str, Any]) -> None:
    """The verdict table of `evaluate optics --tolerance-um`."""
    t = Table(title=escape(f"tolerance verdict, decision rule: {conf['decision_rule']}"))
    for c in ("quantity", "unit", "tolerance", "value", "U", "verdict"):
        t.add_column(c, justify="right")
    for r in conf["statements"]:
        unit = "um" if "tolerance_um" in r else "urad"
        val, U = r[f"value_{unit}"], r[f"U_{unit}"]
        t.add_row(escape(r["quantity"]), unit, f"{r[f'tolerance_{unit}']:g}",
                  "-" if val is None else f"{val:.3f}", "-" if U is None else f"{U:.3f}",
                  "-" if r["verdict"] is None else _verdict_word(r["verdict"]))
    print_table(console, t)
    console.print(f"decision rule: {escape(conf['rule'])}", highlight=False)
    for r in conf["statements"]:
        if r.get("note"):
            console.print(f"note ({escape(r['quantity'])}): {escape(r['note'])}",
                          highlight=False)


def register(app: typer.Typer) -> None:
    """Add the ``evaluate`` command group to the app."""
    app.add_typer(evaluate_app, name="evaluate")
