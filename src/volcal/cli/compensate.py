"""``volcal compensate``: controller compensation tables from an error model."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.markup import escape

from volcal import defaults as D
from volcal.cli._common import note_moved, parse_vector, print_session_notes
from volcal.cli._options import cli_spelling

if TYPE_CHECKING:
    from volcal.steps.compensate import Compensated

console = Console(soft_wrap=True)  # no line breaks inside paths
err_console = Console(stderr=True, soft_wrap=True)  # notes, warnings: standard error


def compensate(
    format: Annotated[str, typer.Option(
        "--format", help="fanuc, siemens, heidenhain, linuxcnc, csv, isg (ISG/Beckhoff "
        "volumetric), grid (3-D).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Folder for the tables.")],
    model: Annotated[Path | None, typer.Argument(
        help="MODEL.json (identified) or error table .csv. Omitted with --session: no "
        "linear model (rotary tests only), only the session's rotary tables are written.")
    ] = None,
    sign: Annotated[str | None, typer.Option(
        help="Override the controller's own sign convention (the default; see "
        "docs/compensation.md): error (table = actual - commanded) or correction "
        "(= -error).")] = D.COMP_SIGN,
    session: Annotated[Path | None, typer.Option(
        help="Session folder: its bidirectional ISO 230-2 linear tests give forward and "
        "reverse tables (LinuxCNC, Fanuc, Heidenhain BACKLASH); a MODEL.json must have "
        "been identified from it.")] = None,
    force: Annotated[bool, typer.Option(
        "--force", help="With --session: use the model even if it was identified from "
        "another session (name, chain, travel or readings differ).")] = False,
    spacing: Annotated[float, typer.Option(help="Distance between points [mm].")
        ] = D.COMP_SPACING_MM,
    max_points: Annotated[int | None, typer.Option(help="Controller's point limit.")] = None,
    reference_mm: Annotated[str | None, typer.Option(
        help="Fanuc reference position x,y,z [mm] (default: start of travel).")] = None,
    unit_um: Annotated[float, typer.Option(help="Fanuc detection unit [um].")] = D.COMP_UNIT_UM,
    magnification: Annotated[int, typer.Option(help="Fanuc magnification (3623).")
        ] = D.COMP_MAGNIFICATION,
    max_increment: Annotated[int, typer.Option(
        help="Fanuc largest value per point (7 loads on every series).")] = D.COMP_MAX_INCREMENT,
    fanuc_series: Annotated[str, typer.Option(
        help="Fanuc parameter syntax: 30i (N03620Q1..., 0i-D/0i-F/30i) or 16i (N3620...).")
    ] = D.COMP_FANUC_SERIES,
    linuxcnc_type: Annotated[int, typer.Option(
        help="LinuxCNC COMP_FILE_TYPE: 1 (trims) or 0 (actual positions).")
    ] = D.COMP_LINUXCNC_TYPE,
    squareness: Annotated[bool, typer.Option(help="Siemens CEC: add squareness terms.")
    ] = D.COMP_SQUARENESS,
    tool_offset: Annotated[str, typer.Option(help="3-D grid: target on the tool x,y,z [mm].")
                           ] = ",".join(map("{:g}".format, D.TOOL_OFFSET_MM)),
    replace: Annotated[bool, typer.Option(
        "--replace", help="The output folder holds files its manifest does not list (volcal "
        "did not write them): move them into OUTPUT/backup/<UTC time>/ instead of "
        "refusing.")] = False,
    units: Annotated[str, typer.Option(
        "--units", help="With --session: the rotary tests' A before and after in urad or "
        "arcsec (display only).")] = "urad",
    rotary_spacing: Annotated[float, typer.Option(
        help="With --session: distance between the points of the rotary tests' Siemens and "
        "Fanuc tables [deg]; divides 360 on a full-circle axis.")
    ] = D.COMP_ROTARY_SPACING_DEG,
) -> None:
    """Write compensation tables of a model for a controller, resampled onto its grid."""
    from volcal.cli._options import OPTIONS
    from volcal.errors import spell
    from volcal.standards.iso230_2_rotary import check_units
    from volcal.steps.compensate import compensate as step
    from volcal.steps.compensate import sign_note

    check_units(units)
    note = sign_note(format, sign)  # said at once, before any other check can fail
    if note is not None:
        err_console.print(escape("note: " + spell(note, OPTIONS)))
    r = step(model, format=format, output=output, sign=sign, session=session, force=force,
             spacing=spacing, max_points=max_points,
             reference_mm=None if reference_mm is None
             else parse_vector(reference_mm, "--reference-mm"),
             unit_um=unit_um, magnification=magnification, max_increment=max_increment,
             fanuc_series=fanuc_series, linuxcnc_type=linuxcnc_type, squareness=squareness,
             rotary_spacing=rotary_spacing,
             tool_offset=parse_vector(tool_offset, "--tool-offset"), replace=replace,
             on_moved=lambda rel: note_moved(output, rel))
    if r.session is not None:
        print_session_notes(r.session)
    for line in r.directional_notes:
        err_console.print(f"note: {escape(line)}", highlight=False)
    if r.no_bidirectional:
        err_console.print("note: the session has no bidirectional linear test: forward "
                          "= reverse", highlight=False)
    for d in r.forced:
        err_console.print(f"[yellow]warning[/] --force: {escape(d)}", highlight=False)
    if r.rotary_only:
        err_console.print("note: no linear model given: only the session's rotary tables are "
                          "written (the linear axes get none; give MODEL.json for them)",
                          highlight=False)
        console.print(escape(f"wrote {r.format} rotary tables ({r.sign}"
                             + (", the controller's convention" if r.convention else "")
                             + f"): {', '.join(r.files)} -> {output}"))
    else:
        console.print(escape(f"wrote {r.format} tables ({r.sign}"
                             + (", the controller's convention" if r.convention else "")
                             + f", {r.spacing:g} mm): {', '.join(r.files)} -> {output}"))
    if r.session is not None:
        _print_line_checks(r, units)


def _print_line_checks(r: Compensated, units: str = "urad") -> None:
    """ISO 230-2 A of every measured linear line before and after the tables just written."""
    from rich.table import Table

    checks = r.line_checks
    if checks:
        t = Table(title="measured linear lines: ISO 230-2 A before and after these tables")
        for col in ("id", "axis", "line [mm]", "A before [µm]", "A after [µm]", "u [µm]"):
            t.add_column(escape(col), justify="left" if col.startswith("line") else "right")
        for c in checks:
            t.add_row(c.id, c.axis, escape(c.short), f"{c.A_before_um:.2f}",
                      f"{c.A_after_um:.2f}" + (" (worse)" if c.worse else ""), f"{c.u_um:.2f}")
        console.print(t)
    for c in checks:
        if c.worse:
            err_console.print(f"[yellow]warning[/] {escape(c.warning())}", highlight=False)
    for why in r.not_checked:
        console.print(f"note: not evaluated: {escape(why)}", highlight=False)
    _print_rotary_checks(r, units)
    before, after = r.volumetric_before_um, r.volumetric_after_um
    if before is None or after is None:  # both are there whenever a session is
        return
    text = (f"largest modelled volumetric error over 11³ points of the travel: {before:.2f} µm "
            f"before, {after:.2f} µm after these tables")
    if after > before:
        err_console.print(f"[yellow]warning[/] {text}: the tables make it larger",
                          highlight=False)
    else:
        console.print(text, highlight=False)


def _print_rotary_checks(r: Compensated, units: str = "urad") -> None:
    """ISO 230-2 A of every rotary test before and after its rotary table."""
    from rich.table import Table

    from volcal.standards.iso230_2_rotary import UNITS

    f = UNITS[units]
    u = "µrad" if units == "urad" else units
    if r.rotary_checks:
        t = Table(title="rotary tests: ISO 230-2 A before and after these tables")
        for col in ("id", "axis", f"A before [{u}]", f"A after [{u}]", f"u [{u}]"):
            t.add_column(escape(col), justify="right")
        for c in r.rotary_checks:
            t.add_row(c.id, c.axis, f"{c.A_before_urad * f:.2f}",
                      f"{c.A_after_urad * f:.2f}" + (" (worse)" if c.worse else ""),
                      f"{c.u_urad * f:.2f}")
        console.print(t)
    for c in r.rotary_checks:  # what the table did with 0 and 360 deg
        if not c.modulo:
            console.print(f"note: rotary: {escape(c.id)}: a limited axis, the table holds its "
                          "end values beyond the targets", highlight=False)
            continue
        clo = ("" if not c.closure_urad else
               f" (closure {c.closure_urad['up'] * f:.2f} up, "
               f"{c.closure_urad['down'] * f:.2f} down {u}: averaged into one value)")
        console.print(f"note: rotary: {escape(c.id)}: full circle, 0 and 360 deg are one "
                      f"position{clo}; the table is periodic", highlight=False)
    for c in r.rotary_checks:
        if c.worse:
            err_console.print(f"[yellow]warning[/] rotary test {escape(c.id)}: ISO 230-2 A "
                              f"grows from {c.A_before_urad * f:.2f} {u} to "
                              f"{c.A_after_urad * f:.2f} {u} with these tables",
                              highlight=False)
    for why in r.rotary_not_written:
        console.print(f"note: rotary: {escape(why)}", highlight=False)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("compensate")(cli_spelling(compensate))
