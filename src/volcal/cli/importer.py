"""``volcal import``: a laser's CSV export -> a linear measurement of a session."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from volcal.cli._common import parse_travel, parse_vector

console = Console(soft_wrap=True)  # no line breaks inside paths


def import_(
    csv_file: Annotated[Path, typer.Argument(metavar="CSV", help="The laser's CSV export.")],
    map: Annotated[str, typer.Option(
        "--map", help="Columns: target=..,deviation=.. or reading=.., optional run=.., "
        "direction=.., time=.., air_temperature_c=.. ...")],
    axis: Annotated[str, typer.Option(help="Measured axis X, Y or Z.")],
    session: Annotated[Path, typer.Option(help="Session folder (created if missing).")],
    id: Annotated[str, typer.Option("--id", help="Measurement id.")],
    line_mm: Annotated[str, typer.Option(
        help="Machine position x,y,z of the line [mm]; its axis coordinate is added to the "
        "targets.")] = "0,0,0",
    units: Annotated[str, typer.Option(
        help="Unit of target/reading columns: mm, um, in or auto (header, else mm).")] = "auto",
    deviation_units: Annotated[str, typer.Option(
        help="Unit of the deviation column: um, nm, mm, in, uin or auto.")] = "auto",
    optics: Annotated[str, typer.Option(help="retroreflector or flat_mirror.")
                      ] = "retroreflector",
    tool_offset: Annotated[str, typer.Option(help="Target on the tool x,y,z [mm].")] = "0,0,0",
    travel: Annotated[str | None, typer.Option(
        help="Travel of a NEW session, xmin:xmax,ymin:ymax,zmin:zmax [mm].")] = None,
    chain: Annotated[str, typer.Option(help="Chain of a new session.")] = "XYFZ",
    name: Annotated[str, typer.Option(help="Machine name of a new session.")] = "machine",
    replace: Annotated[bool, typer.Option(help="Replace a measurement with this id.")] = False,
) -> None:
    """Add a linear measurement from a laser CSV export to a session (atomically)."""
    from volcal.importer.laser_csv import import_csv, parse_mapping
    from volcal.io.paths import check_output_folder

    if not session.exists():
        check_output_folder(session, "session")

    r = import_csv(csv_file, parse_mapping(map), axis, parse_vector(line_mm, "--line-mm"),
                   session, id, units, deviation_units, optics,
                   parse_vector(tool_offset, "--tool-offset"),
                   None if travel is None else parse_travel(travel), chain, name, replace)
    for note in r.notes:
        console.print(f"[cyan]units/notes:[/] {note}", highlight=False)
    what = "created session" if r.created else "added to"
    console.print(f"{r.measurement.n} readings of {r.measurement.id} ({axis.upper()}) -> "
                  f"{what} {r.session}")


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("import")(import_)
