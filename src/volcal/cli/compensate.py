"""``volcal compensate``: controller compensation tables from an error model."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from volcal import defaults as D
from volcal.cli._common import note_moved, parse_vector, print_session_notes
from volcal.errors import VolcalInputError

console = Console(soft_wrap=True)  # no line breaks inside paths
err_console = Console(stderr=True, soft_wrap=True)  # notes, warnings: standard error


def compensate(
    model: Annotated[Path, typer.Argument(help="MODEL.json (identified) or error table .csv.")],
    format: Annotated[str, typer.Option(
        "--format", help="fanuc, siemens, heidenhain, linuxcnc, csv, isg (ISG/Beckhoff "
        "volumetric), grid (3-D).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Folder for the tables.")],
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
                           ] = "0,0,0",
    replace: Annotated[bool, typer.Option(
        "--replace", help="The output folder holds files its manifest does not list (volcal "
        "did not write them): move them into OUTPUT/backup/<UTC time>/ instead of "
        "refusing.")] = False,
) -> None:
    """Write compensation tables of a model for a controller, resampled onto its grid."""
    from volcal.compensate.formats import (
        FORMAT_INFO,
        MANIFEST,
        CompensationOptions,
        write_compensation,
    )
    from volcal.compensate.source import load_errors
    from volcal.compensate.tables import sign_factor
    from volcal.io.folders import manifest_files
    from volcal.io.paths import prepare_output_folder

    fmt = format.lower()
    if fmt not in FORMAT_INFO:
        raise VolcalInputError(f"unknown format {format!r}: expected one of "
                               f"{', '.join(FORMAT_INFO)}")
    info = FORMAT_INFO[fmt]
    if sign is not None:
        sign_factor(sign)
        if sign != info.sign:
            err_console.print(escape(
                f"note: --sign {sign} overrides the {fmt} convention '{info.sign}' "
                f"({info.sign_source}); a table in the wrong sign doubles the error"))
    moved = prepare_output_folder(output, "compensation", lambda p: (p / MANIFEST).is_file(),
                                  written=manifest_files(MANIFEST, "files"), replace=replace)
    if moved is not None:
        note_moved(output, moved)
    ref = None if reference_mm is None else tuple(parse_vector(reference_mm, "--reference-mm"))
    directional = None
    sess = None
    if session is not None:
        from volcal.compensate.bidirectional import directional_from_session
        from volcal.session.format import read_session

        # the readings as identify and evaluate read them: missed captures skipped
        sess = read_session(session)
        print_session_notes(sess)
        directional = directional_from_session(sess)
        for line in directional.notes():
            err_console.print(f"note: {escape(line)}", highlight=False)
        if not directional.source:
            err_console.print("note: the session has no bidirectional linear test: forward "
                              "= reverse", highlight=False)
            directional = None
    opts = CompensationOptions(sign, spacing, max_points, ref, unit_um, magnification,
                               max_increment, squareness,
                               tuple(parse_vector(tool_offset, "--tool-offset")),
                               fanuc_series, linuxcnc_type, directional)
    if session is not None:  # --session: the model must belong to it
        _check_session(model, session, force)
    errors = load_errors(model)
    files = write_compensation(errors, fmt, output, opts, model.name,
                               _machine_identity(model, errors, sess, force))
    used = opts.sign_for(fmt)
    console.print(escape(f"wrote {fmt} tables ({used}"
                         + (", the controller's convention" if sign is None else "")
                         + f", {spacing:g} mm): {', '.join(files)} -> {output}"))
    if sess is not None:
        _print_line_checks(sess, output, errors)


def _check_session(model: Path, session: Path, force: bool) -> None:
    from volcal.identify.modelfile import check_model_file_session

    for d in check_model_file_session(model, session, force):
        err_console.print(f"[yellow]warning[/] --force: {d}", highlight=False)


def _machine_identity(model: Path, errors: object, sess: object, force: bool) -> object:
    """The machine the tables are for: the session's identity, else what the model records.

    An error table given with --session must have the session's chain and travel (its
    name may differ: a simulated truth is called "virtual ..."); --force overrides.
    """
    from volcal.compensate.manifest import identity_of_errors, model_identity
    from volcal.session.identity import MachineIdentity, same_machine

    if sess is None:
        return model_identity(model, errors)
    me = MachineIdentity.of(sess)
    if model.suffix.lower() == ".csv":
        mine = identity_of_errors(errors)
        same, why = same_machine(MachineIdentity(me.name, mine.chain, mine.travel_mm), me)
        if not same:
            text = (f"the error table is not of this session's machine ({why}); the tables "
                    f"would be labelled {me.label()}")
            if not force:
                raise VolcalInputError(text + "; give --force to write them anyway", model)
            err_console.print(f"[yellow]warning[/] --force: {escape(text)}", highlight=False)
    return me


def _print_line_checks(sess: object, output: Path, errors: object) -> None:
    """ISO 230-2 A of every measured linear line before and after the tables just written."""
    from rich.table import Table

    from volcal.compensate.linecheck import check_lines, volumetric_before_after
    from volcal.compensate.readback import read_written_tables

    written = read_written_tables(output, travel=sess.travel)
    checks, skipped = check_lines(sess, written)
    if checks:
        t = Table(title="measured linear lines: ISO 230-2 A before and after these tables")
        for c in ("id", "axis", "line [mm]", "A before [µm]", "A after [µm]", "u [µm]"):
            t.add_column(escape(c), justify="left" if c.startswith("line") else "right")
        for c in checks:
            t.add_row(c.id, c.axis, escape(c.short), f"{c.A_before_um:.2f}",
                      f"{c.A_after_um:.2f}" + (" (worse)" if c.worse else ""), f"{c.u_um:.2f}")
        console.print(t)
    for c in checks:
        if c.worse:
            err_console.print(f"[yellow]warning[/] {escape(c.warning())}", highlight=False)
    for why in skipped:
        console.print(f"note: not evaluated: {escape(why)}", highlight=False)
    before, after = volumetric_before_after(errors, written)
    text = (f"largest modelled volumetric error over 11³ points of the travel: {before:.2f} µm "
            f"before, {after:.2f} µm after these tables")
    if after > before:
        err_console.print(f"[yellow]warning[/] {text}: the tables make it larger",
                          highlight=False)
    else:
        console.print(text, highlight=False)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("compensate")(compensate)
