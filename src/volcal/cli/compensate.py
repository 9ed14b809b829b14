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
        "--format", help="fanuc, siemens, heidenhain, csv, isg (volumetric blocks), grid (3-D).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Folder for the tables.")],
    sign: Annotated[str | None, typer.Option(
        help="Required: error (table = actual - commanded) or correction (= -error); see "
        "docs/compensation.md for what each controller expects.")] = None,
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
) -> None:
    """Write compensation tables of a model for a controller, resampled onto its grid."""
    from volcal.compensate.formats import MANIFEST, CompensationOptions, write_compensation
    from volcal.compensate.source import load_errors
    from volcal.compensate.tables import sign_factor
    from volcal.io.paths import check_output_folder

    if sign is None:
        raise VolcalInputError("--sign is required: 'error' (actual - commanded) or "
                               "'correction' (-error); see docs/compensation.md")
    sign_factor(sign)
    check_output_folder(output, "compensation", lambda p: (p / MANIFEST).is_file())
    ref = None if reference_mm is None else tuple(parse_vector(reference_mm, "--reference-mm"))
    opts = CompensationOptions(sign, spacing, max_points, ref, unit_um, magnification,
                               max_increment, squareness,
                               tuple(parse_vector(tool_offset, "--tool-offset")))
    if locals().get("session") is not None:  # --session: the model must belong to it
        _check_session(model, locals()["session"], bool(locals().get("force", False)))
    errors = load_errors(model)
    files = write_compensation(errors, format.lower(), output, opts, model.name)
    console.print(f"wrote {format} tables ({sign}, {spacing:g} mm): {', '.join(files)} -> {output}")


def _check_session(model: Path, session: Path, force: bool) -> None:
    from volcal.identify.modelfile import check_model_file_session

    for d in check_model_file_session(model, session, force):
        console.print(f"[yellow]warning[/] --force: {d}", highlight=False)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("compensate")(compensate)
