"""``volcal import``: a laser's CSV export -> a measurement of a session."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from volcal import defaults as D
from volcal.cli._common import parse_travel, parse_vector
from volcal.cli._options import cli_spelling

console = Console(soft_wrap=True)  # no line breaks inside paths
err_console = Console(stderr=True, soft_wrap=True)  # warnings: standard error

HELP = """Add a measurement from a laser CSV export to a session (atomically).

Two ways:

* a new linear measurement: --axis X --id linear-x9 [--line-mm x,y,z] (the session is
created with --travel if it does not exist);

* the readings of a planned measurement (linear, diagonal, step diagonal, straightness,
angular, rotary; from ``volcal plan``): --measurement diag-ppp. Angle readings in urad, arcsec,
mm/m, um/m, mrad or deg (header or --deviation-units); --sign - for optics that read the
workpiece side relative to the tool side; --slope-removed when the vendor took the slope
out of a straightness. The file must hold one reading per planned
pose, in the planned order; its targets (distance from the first pose along the beam, a
rotary test's angles) are checked against the plan.

Layouts (--map, see docs/formats.md "Laser exports"):

* long, one reading per row: --map target=Pos,deviation=Error[,run=Run,direction=Dir]
(runs and directions are inferred from the order of the targets when not given);

* wide, one column per run (certificates): a pattern in deviation= or reading=,
--map "target=Target,deviation=Run*"; run numbers and directions come from the
headers (Run 1, Run 1 +, Run 1 -, 1 up, 1 down, R1 Fwd, R1 Rev ...);

* per-step step diagonal, one row per step: --map "target=Pos,deviation=dX|dY|dZ"
(the readings after each single-axis move, in the plan's axis order) with
--measurement.

The header block above the table (Date, Operator, Air temperature, Air pressure,
Humidity, Material temperature) goes to [calibration] date/operator and the
measurement's environment table; labels other than these are named with --map
date=..,operator=..,air_temperature_c=..,air_pressure_pa=..,humidity_pct=..,
material_temperature_c=.. (a label of the header block, or a column of the table).
One line per field read is printed.

A Renishaw dynamic capture (FILE.rtx, one quantity sampled at a fixed rate) fills a
planned measurement without --map: --measurement ID [--dwell-s 4] [--units mm]
[--deviation-units mrad] [--sign -]; the reading at each planned pose is the mean of the
samples of its dwell (docs/formats.md "Dynamic capture").
"""


def import_(
    csv_file: Annotated[Path, typer.Argument(metavar="FILE", help="The laser's CSV export, "
                                             "or a Renishaw dynamic capture (.rtx).")],
    session: Annotated[Path | None, typer.Option(
        help="Session folder (created if missing); required.")] = None,
    map: Annotated[str | None, typer.Option(
        "--map", help="Columns (CSV exports; not for .rtx): target=..,deviation=.. or "
        "reading=.., optional run=.., "
        "direction=.., time=.., air_temperature_c=.. ...; deviation=Run* (a pattern): a "
        "wide table, one column per run; deviation=A|B|C: a per-step step-diagonal table. "
        "Header block: date=.., operator=.., air_temperature_c=.., air_pressure_pa=.., "
        "humidity_pct=.., material_temperature_c=.. name its labels.")] = None,
    axis: Annotated[str | None, typer.Option(
        help="Measured axis X, Y or Z of a new linear measurement.")] = None,
    id: Annotated[str | None, typer.Option("--id", help="Id of a new measurement.")] = None,
    measurement: Annotated[str | None, typer.Option(
        help="Id of a planned measurement to fill (linear, diagonal, step_diagonal).")
                           ] = None,
    line_mm: Annotated[str, typer.Option(
        help="Machine position x,y,z of the line [mm]; its axis coordinate is added to the "
        "targets.")] = "0,0,0",
    units: Annotated[str, typer.Option(
        help="Unit of target/reading columns: mm, um, in or auto (header, else mm).")
                     ] = D.IMPORT_UNITS,
    deviation_units: Annotated[str, typer.Option(
        help="Unit of the deviation columns: um, nm, mm, in, uin or auto; angles: urad, "
        "arcsec, mm/m, um/m, mrad, deg.")
                               ] = D.IMPORT_DEVIATION_UNITS,
    optics: Annotated[str, typer.Option(help="retroreflector or flat_mirror.")
                      ] = D.IMPORT_OPTICS,
    tool_offset: Annotated[str, typer.Option(help="Target on the tool x,y,z [mm].")] = "0,0,0",
    travel: Annotated[str | None, typer.Option(
        help="Travel of a NEW session, xmin:xmax,ymin:ymax,zmin:zmax [mm].")] = None,
    chain: Annotated[str, typer.Option(help="Chain of a new session.")] = D.IMPORT_CHAIN,
    name: Annotated[str, typer.Option(help="Machine name of a new session.")] = D.IMPORT_NAME,
    replace: Annotated[bool, typer.Option(help="Replace a measurement with this id (or the "
                                                "readings of --measurement).")] = False,
    sign: Annotated[str, typer.Option(
        help="Direct optics: + (the export reads the tool side relative to the workpiece "
        "side, volcal's sign) or - (the workpiece side relative to the tool side).")
                    ] = D.IMPORT_SIGN,
    slope_removed: Annotated[bool, typer.Option(
        help="Straightness: the instrument took the slope out (recorded; not allowed in a "
        "reference group).")] = False,
    dwell_s: Annotated[float, typer.Option(
        help="Renishaw dynamic capture (.rtx): the part program's dwell at each target [s] "
        "(volcal program --dwell-s); the reading at each pose is the mean of its dwell.")
                       ] = D.IMPORT_DWELL_S,
) -> None:
    """Add a measurement from a laser CSV export to a session (see HELP)."""
    from volcal.steps.importer import import_ as step

    r = step(csv_file, session=session, map=map, axis=axis, id=id, measurement=measurement,
             line_mm=parse_vector(line_mm, "--line-mm"), units=units,
             deviation_units=deviation_units, optics=optics,
             tool_offset=parse_vector(tool_offset, "--tool-offset"),
             travel=None if travel is None else parse_travel(travel), chain=chain, name=name,
             replace=replace, sign=sign, slope_removed=slope_removed, dwell_s=dwell_s)
    i = r.result
    for note in i.notes:
        console.print(f"[cyan]units/notes:[/] {escape(note)}", highlight=False)
    for line in i.header:
        console.print(f"[cyan]header:[/] {escape(line)}", highlight=False)
    for note in i.header_notes:
        console.print(f"[yellow]header:[/] {escape(note)}", highlight=False)
    where = "created session" if i.created else "added to"
    console.print(f"{i.measurement.n} readings of {r.what} -> {where} {i.session}")
    for w in r.warnings:
        err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("import", help=HELP)(cli_spelling(import_))
