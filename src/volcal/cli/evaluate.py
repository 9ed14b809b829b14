"""``volcal evaluate``: ISO 230-2, VDI/DGQ 3441, ISO 230-6, volumetric indices, optics."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from volcal.cli._common import print_session_notes

console = Console(soft_wrap=True)  # no line breaks inside paths
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


def _iso_tables(res: Any, title: str) -> None:
    t = Table(title=f"{title} (ISO 230-2:{res.edition})")
    t.add_column("parameter")
    t.add_column("value [um]", justify="right")
    for k, label in _AXIS_LABELS.items():
        t.add_row(label, f"{getattr(res, k):.3f}")
    console.print(t)
    tt = Table(title=escape("per target [um]; n↑ n↓: runs that reached the target"))
    for c in ("target [mm]", "n↑", "n↓", "x̄↑", "x̄↓", "x̄", "s↑", "s↓", "B_i", "R↑", "R↓",
              "R_i"):
        tt.add_column(c, justify="right")
    for row in res.targets.rows():
        tt.add_row(f"{row['target_mm']:.3f}", str(row["n_up"]), str(row["n_down"]),
                   *["-" if row[k] is None else f"{row[k]:.3f}"
                     for k in ("mean_up", "mean_down", "mean", "s_up", "s_down", "B", "R_up",
                               "R_down", "R")])
    console.print(tt)
    if not res.complete:
        console.print(f"[yellow]incomplete:[/] {len(res.missing)} missed reading(s); each "
                      "target is evaluated over the runs that reached it", highlight=False)
    for n in res.notes:
        console.print(f"[yellow]note:[/] {escape(n)}", highlight=False)
    for w in res.warnings:
        console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False)


@evaluate_app.command("iso230-2")
def iso230_2_cmd(
    file: Path = typer.Argument(..., help="CSV: target_mm,run,direction,deviation_um or a "
                                "session measurement CSV of a linear test."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    edition: str = typer.Option("2014", help="ISO 230-2 edition: 2014, 2006, 1997, 1988."),
) -> None:
    """Positioning accuracy and repeatability of one axis (ISO 230-2)."""
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.positioning_data import read_positioning_csv

    d = read_positioning_csv(file)
    res = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, edition,
                   **d.evaluate_kwargs())
    plaus = _file_notes(d)
    if as_json:
        out = res.to_dict()
        out["file"] = str(file)
        out["plausibility"] = plaus
        _print_json(out)
    else:
        _iso_tables(res, str(file))


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

    d = read_positioning_csv(file)
    res = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, **d.evaluate_kwargs())
    _file_notes(d)
    if as_json:
        _print_json(res.to_dict())
        return
    t = Table(title=f"{file} (VDI/DGQ 3441)")
    t.add_column("parameter")
    t.add_column("value [um]", justify="right")
    for k in ("P", "Pa", "Ps", "Ps_mean", "U", "U_mean"):
        t.add_row(k, f"{getattr(res, k):.3f}")
    console.print(t)


@evaluate_app.command("iso230-6")
def iso230_6_cmd(
    session: Path = typer.Argument(..., help="Session folder."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Diagonal displacement tests of a session (ISO 230-6), each diagonal."""
    from volcal.errors import VolcalInputError
    from volcal.session.format import read_session
    from volcal.standards.iso230_6 import evaluate_diagonal, largest_e_d

    s = read_session(session)
    print_session_notes(s)
    res = [evaluate_diagonal(m) for m in s.measurements if m.kind == "diagonal"]
    if not res:
        raise VolcalInputError("no diagonal measurements in the session", session)
    worst = largest_e_d(res)
    incomplete = [r.id for r in res if not r.complete]
    if as_json:
        _print_json({"diagonals": [r.to_dict() for r in res],
                     "max_E_D": None if worst is None else worst.E_D,
                     "max_E_D_id": None if worst is None else worst.id,
                     "complete": not incomplete, "incomplete": incomplete,
                     "unmeasured": [m.id for m in s.unmeasured if m.kind == "diagonal"]})
        return
    t = Table(title=f"{session}: ISO 230-6 diagonal displacement")
    for c in ("id", "diagonal", "length [mm]", "points", "E_D [um]", "max |dev| [um]",
              "R [um]"):
        t.add_column(c, justify="right")
    for r in res:
        rr = "" if r.iso230_2 is None else f"{r.iso230_2.R:.3f}"
        pts = f"{r.points_measured}/{r.points_planned}" + ("" if r.complete else " incomplete")
        t.add_row(r.id, (r.plane + " " if r.plane else "") + r.diagonal, f"{r.length_mm:.1f}",
                  pts, f"{r.E_D:.3f}", f"{r.max_abs_um:.3f}", rr)
    console.print(t)
    for r in res:
        if not r.complete:
            console.print(f"[yellow]incomplete:[/] {escape(r.note())}", highlight=False)
    if worst is not None:
        console.print(f"largest E_D of the complete diagonals: {worst.E_D:.3f} um "
                      f"({worst.id})", highlight=False)
    else:
        console.print("largest E_D: none (no complete diagonal)", highlight=False)


@evaluate_app.command("session")
def session_cmd(
    session: Path = typer.Argument(..., help="Session folder."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    edition: str = typer.Option("2014", help="ISO 230-2 edition."),
    tolerance_um: str | None = typer.Option(
        None, help="Tolerance for a pass/fail verdict [um]: X=10,Y=10,Z=8 (ISO 230-2 "
        "accuracy A per axis), a number (largest volumetric error of --model) or both "
        "(X=10,Y=10,Z=8,V=15)."),
    model: Path | None = typer.Option(None, help="Identified model (MODEL.json): needed for "
                                      "a volumetric tolerance and for the verdict after "
                                      "compensation."),
    compensation: Path | None = typer.Option(None, help="Folder written by `volcal "
                                             "compensate` from --model: the verdict after "
                                             "applying exactly what its tables carry."),
) -> None:
    """ISO 230-2 for every linear measurement with runs and directions; ELv (seed 002)."""
    from volcal.errors import VolcalInputError
    from volcal.session.format import read_session
    from volcal.standards.session import evaluate_session

    tol = _tolerance_inputs(tolerance_um, model, compensation)
    s = read_session(session)
    print_session_notes(s)
    ev = evaluate_session(s, edition=edition)
    results, axis_of = ev.iso230_2, ev.axis
    why_skipped = {k: why for k, why in ev.skipped.items() if why != "no readings yet"}
    skipped = list(why_skipped)
    if not results:
        raise VolcalInputError("no linear measurement with run and direction columns", session)
    elv_val = None if ev.elv is None else ev.elv["ELv"]
    verdict = _verdicts(tol, s, edition)
    if as_json:
        out: dict[str, Any] = {"measurements": {k: {"axis": axis_of[k], **v.to_dict()}
                                                for k, v in results.items()},
                               "ELv": elv_val, "skipped": skipped,
                               "skipped_reasons": why_skipped,
                               "incomplete": [k for k, v in results.items() if not v.complete],
                               "unmeasured": list(ev.unmeasured)}
        if verdict is not None:
            out["verdict"] = [v.to_dict() for v in verdict]
        _print_json(out)
        return
    t = Table(title=f"{session}: ISO 230-2:{edition} [um]")
    for c in ("id", "axis", "runs", "A", "E", "M", "R", "B", "B_mean"):
        t.add_column(c, justify="right")
    for k, r in results.items():
        t.add_row(k, axis_of[k], _runs_cell(r), *[f"{getattr(r, p):.3f}" for p in
                                                  ("A", "E", "M", "R", "B", "B_mean")])
    console.print(t)
    for k, r in results.items():
        for n in r.notes:
            console.print(f"[yellow]{k}[/] {escape(n)}", highlight=False)
    if ev.unmeasured:
        console.print(f"[yellow]not measured[/] (planned, no readings): "
                      f"{', '.join(ev.unmeasured)}", highlight=False)
    if elv_val is not None:
        console.print(f"ELv (seed 002: RSS of the positioning ranges M of the first line of "
                      f"each axis) = {elv_val:.3f} um")
    grouped: dict[str, list[str]] = {}
    for k, r in results.items():
        for w in r.warnings:
            grouped.setdefault(w, []).append(k)
    for w, ids in grouped.items():
        console.print(f"[yellow]warning[/] ({', '.join(ids)}): {escape(w)}", highlight=False)
    for k, why in why_skipped.items():
        console.print(f"[yellow]skipped[/] {k}: {escape(why)}", highlight=False)
    if verdict is not None:
        _print_verdict(verdict, tol[1] is not None)


def _runs_cell(r: Any) -> str:
    """Runs of a linear test: ``5``, or ``4-5 incomplete`` (fewest runs at a target)."""
    nu, nd = r.targets.counts()
    full = max(r.targets.n_up, r.targets.n_down)
    if r.complete:
        return str(full)
    return f"{int(min(nu.min(), nd.min()))}-{full} incomplete"


def _tolerance_inputs(tolerance_um: str | None, model: Path | None,
                      compensation: Path | None) -> tuple[Any, Any, Any]:
    """Parse the tolerance and read the model and the tables' manifest (or None)."""
    from volcal.errors import VolcalInputError

    if tolerance_um is None:
        if compensation is not None or model is not None:
            raise VolcalInputError("--model and --compensation are used by the tolerance "
                                   "verdict: give --tolerance-um too")
        return None, None, None
    from volcal.standards.tolerance import parse_tolerance

    tol = parse_tolerance(tolerance_um)
    if compensation is not None and model is None:
        raise VolcalInputError("--compensation needs the --model the tables were written from")
    errors = tables = None
    if model is not None:
        from volcal.compensate.source import load_errors

        errors = load_errors(model)
    if compensation is not None:
        from volcal.report.carried import table_set_from_manifest
        from volcal.report.pipeline import read_manifest

        tables = table_set_from_manifest(read_manifest(compensation), compensation)
    return tol, errors, tables


def _verdicts(tol: tuple[Any, Any, Any], s: Any, edition: str) -> Any:
    if tol[0] is None:
        return None
    from volcal.report.verdict import verdicts

    return verdicts(tol[0], s, tol[1], tol[2], edition)


def _print_verdict(verdict: Any, has_model: bool) -> None:
    t = Table(title="tolerance verdict [um]")
    for c in ("quantity", "tolerance", "before", "", "after", ""):
        t.add_column(c, justify="right")

    def cell(v: Any) -> str:
        return "-" if v is None else f"{v:.3f}"

    def word(w: str) -> str:
        return {"pass": "[green]pass[/]", "FAIL": "[red]FAIL[/]"}.get(w, w)

    for v in verdict:
        t.add_row(escape(v.quantity), f"{v.tolerance_um:g}", cell(v.before_um), word(v.before),
                  cell(v.after_um), word(v.after))
    console.print(t)
    if not any(v.after_um is not None for v in verdict):
        console.print("no verdict after compensation: give --model MODEL.json and "
                      "--compensation FOLDER" if not has_model else
                      "no verdict after compensation: give --compensation FOLDER",
                      highlight=False)


@evaluate_app.command("volumetric")
def volumetric_cmd(
    errors: Path = typer.Argument(..., help="Error table CSV (ERRORS.csv)."),
    tool_offset: str = typer.Option("0,0,0", help="Tool point offset x,y,z [mm]."),
    n: int = typer.Option(11, min=2, max=201, help="Grid points per axis."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """ISO 230-1 volumetric indices E_VX, E_VY, E_VZ, E_VXYZ of an error table; ELv."""
    from volcal.cli._common import parse_vector
    from volcal.session.errortable import read_error_table
    from volcal.standards.volumetric import elv_from_model, volumetric_indices

    m = read_error_table(errors)
    res = volumetric_indices(m, parse_vector(tool_offset, "--tool-offset"), n)
    out = {**res.to_dict(), **elv_from_model(m)}
    if as_json:
        _print_json(out)
        return
    t = Table(title=f"{errors}: volumetric indices [um]")
    t.add_column("index")
    t.add_column("value [um]", justify="right")
    for k in ("E_VX", "E_VY", "E_VZ", "E_VXYZ", "E_VXYZ_range", "ELx", "ELy", "ELz", "ELv"):
        t.add_row(k, f"{out[k]:.3f}")
    console.print(t)


@evaluate_app.command("optics")
def optics_cmd(
    session: Path = typer.Argument(..., help="Session folder."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """ISO 230-1 of the direct optics: straightness, angular deviation, optical squares.

    Straightness about the end-point and the least-squares lines, the range of each
    angular line, the squareness of each optical-square pair.
    """
    from volcal.errors import VolcalInputError
    from volcal.session.format import read_session
    from volcal.standards.optics import evaluate_optics

    s = read_session(session)
    print_session_notes(s)
    ev = evaluate_optics(s)
    if not (ev["straightness"] or ev["angular"]):
        raise VolcalInputError("no straightness or angular measurement with readings", session)
    if as_json:
        _print_json(ev)
        return
    t = Table(title=escape(f"{session}: straightness (ISO 230-1) [um], slope [urad]"))
    for c in ("id", "axis", "along", "end-point", "least-squares", "LS slope"):
        t.add_column(c, justify="right")
    for k, r in ev["straightness"].items():
        t.add_row(k, r["axis"].upper(), r["error_direction"].upper(),
                  f"{r['end_point']['straightness_um']:.3f}",
                  f"{r['least_squares']['straightness_um']:.3f}",
                  f"{r['least_squares']['slope_urad']:.2f}")
    if ev["straightness"]:
        console.print(t)
    t = Table(title=escape(f"{session}: angular deviation (ISO 230-1) [urad]"))
    for c in ("id", "axis", "about", "optic", "range"):
        t.add_column(c, justify="right")
    for k, r in ev["angular"].items():
        t.add_row(k, r["axis"].upper(), r["rotation"].upper(), r["target"].replace("_", " "),
                  f"{r['angular_deviation_urad']:.2f}")
    if ev["angular"]:
        console.print(t)
    for r in ev["squareness"]:
        nm = r["name"]
        console.print(f"squareness {r['axes'].upper()} (optical square {r['reference']!r}, "
                      f"{' + '.join(r['lines'])}, square {r['square_deviation_urad']:g} urad): "
                      f"{nm} = {r['least_squares'][nm]:.2f} urad from the least-squares "
                      f"lines (ISO 230-1), {r['end_point'][nm]:.2f} urad from the end-point "
                      "lines (the identified model's reference)", highlight=False)


def register(app: typer.Typer) -> None:
    """Add the ``evaluate`` command group to the app."""
    app.add_typer(evaluate_app, name="evaluate")
