"""``volcal program``: measuring part programs for every planned measurement."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from volcal import defaults as D
from volcal.cli._options import cli_spelling

console = Console(soft_wrap=True)  # no line breaks inside paths
err_console = Console(stderr=True, soft_wrap=True)  # warnings: standard error


def program(
    session: Annotated[Path, typer.Argument(help="Session folder (planned or measured).")],
    dialect: Annotated[str, typer.Option(
        help="Controller dialect: fanuc, linuxcnc, siemens or heidenhain.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Folder for the programs.")],
    dwell_s: Annotated[float, typer.Option(help="Dwell at each reading pose [s].")
        ] = D.PROG_DWELL_S,
    feed: Annotated[float, typer.Option(help="Feed of every move [mm/min] (max 10000).")
                     ] = D.PROG_FEED,
    overrun_mm: Annotated[float, typer.Option(help="ISO 230-2 overrun before reversals [mm].")
                          ] = D.PROG_OVERRUN_MM,
    decimals: Annotated[int, typer.Option(help="Decimals of the coordinates [mm].")
        ] = D.PROG_DECIMALS,
    safe_z_mm: Annotated[float, typer.Option(
        help="Z of the first retract in machine coordinates (G53/SUPA/M91) [mm].")
            ] = D.PROG_SAFE_Z_MM,
    first_number: Annotated[int, typer.Option(
        min=1, max=9999, help="Fanuc program number (O word) of the first.")
    ] = D.PROG_FIRST_NUMBER,
    replace: Annotated[bool, typer.Option(
        "--replace", help="The output folder holds files its index does not list (volcal "
        "did not write them): move them into OUTPUT/backup/<UTC time>/ instead of "
        "refusing.")] = False,
) -> None:
    """Write one part program per measurement: planned poses in order, a dwell at each."""
    from volcal.cli._common import note_moved
    from volcal.steps.program import program as step

    r = step(session, dialect=dialect, output=output, dwell_s=dwell_s, feed=feed,
             overrun_mm=overrun_mm, decimals=decimals, safe_z_mm=safe_z_mm,
             first_number=first_number, replace=replace,
             on_moved=lambda rel: note_moved(output, rel))
    for w in r.notes:
        err_console.print(f"[yellow]note:[/] {escape(w)}", highlight=False)
    console.print(f"wrote {r.n_programs} {dialect} programs -> {r.folder}")


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("program")(cli_spelling(program))
