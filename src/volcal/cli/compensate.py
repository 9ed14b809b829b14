"""``volcal compensate``: controller compensation tables from an error model."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from volcal.cli._common import parse_vector
from volcal.errors import VolcalInputError

console = Console()


def compensate(
    model: Annotated[Path, typer.Argument(help="MODEL.json (identified) or error table .csv.")],
    format: Annotated[str, typer.Option(
        "--format", help="fanuc, siemens, heidenhain, linuxcnc, csv, isg (volumetric blocks), "
        "grid (3-D).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Folder for the tables.")],
    sign: Annotated[str | None, typer.Option(
        help="Override of the format's own sign convention: error (table = actual - "
        "commanded) or correction (= -error). Default: the controller's convention "
        "(docs/compensation.md).")] = None,
    spacing: Annotated[float, typer.Option(help="Distance between points [mm].")] = 20.0,
    max_points: Annotated[int | None, typer.Option(help="Controller's point limit.")] = None,
    reference_mm: Annotated[str | None, typer.Option(
        help="Fanuc reference position x,y,z [mm] (default: start of travel).")] = None,
    unit_um: Annotated[float, typer.Option(help="Fanuc detection unit [um].")] = 1.0,
    magnification: Annotated[int, typer.Option(help="Fanuc magnification (3623).")] = 1,
    max_increment: Annotated[int, typer.Option(help="Fanuc largest value per point.")] = 7,
    squareness: Annotated[bool, typer.Option(help="Siemens CEC: add squareness terms.")] = True,
    tool_offset: Annotated[str, typer.Option(help="3-D grid: target on the tool x,y,z [mm].")
                           ] = "0,0,0",
    session: Annotated[Path | None, typer.Option(
        help="Session folder: its bidirectional ISO 230-2 linear tests give the reversal "
        "for formats with two directions (linuxcnc, heidenhain BACKLASH).")] = None,
    linuxcnc_type: Annotated[int, typer.Option(
        help="LinuxCNC COMP_FILE_TYPE: 1 (nominal, forward trim, reverse trim) or 0 "
        "(nominal, actual forward, actual reverse).")] = 1,
) -> None:
    """Write compensation tables of a model for a controller, resampled onto its grid."""
    from volcal.compensate.formats import (
        DEFAULT_SIGN,
        FORMATS,
        MANIFEST,
        CompensationOptions,
        write_compensation,
    )
    from volcal.compensate.source import load_errors
    from volcal.compensate.tables import sign_factor
    from volcal.io.paths import check_output_folder

    fmt = format.lower()
    if fmt not in FORMATS:
        raise VolcalInputError(f"unknown format {format!r}: expected one of {', '.join(FORMATS)}")
    if sign is not None:
        sign_factor(sign)
        if sign != DEFAULT_SIGN[fmt]:
            console.print(f"[yellow]--sign {sign} overrides the {fmt} convention "
                          f"({DEFAULT_SIGN[fmt]}): the table values are negated with respect "
                          "to what the controller expects by default[/yellow]")
        else:
            console.print(f"--sign {sign} is the {fmt} default (nothing overridden)")
    check_output_folder(output, "compensation", lambda p: (p / MANIFEST).is_file())
    reversal = None
    if session is not None:
        from volcal.compensate.bidirectional import reversal_from_session

        reversal = reversal_from_session(session)
    ref = None if reference_mm is None else tuple(parse_vector(reference_mm, "--reference-mm"))
    opts = CompensationOptions(sign, spacing, max_points, ref, unit_um, magnification,
                               max_increment, squareness,
                               tuple(parse_vector(tool_offset, "--tool-offset")), linuxcnc_type,
                               reversal)
    errors = load_errors(model)
    files = write_compensation(errors, fmt, output, opts, model.name)
    console.print(f"wrote {fmt} tables ({sign or DEFAULT_SIGN[fmt]}, {spacing:g} mm): "
                  f"{', '.join(files)} -> {output}")


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("compensate")(compensate)
