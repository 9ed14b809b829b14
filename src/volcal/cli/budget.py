"""``volcal budget``: the uncertainty budget file (template, check, table at a length)."""

from __future__ import annotations

from pathlib import Path

import typer


def budget_cmd(
    file: Path | None = typer.Argument(None, help="Budget file (TOML) to check and show; "
                                       "with --template, the file to write."),
    template: bool = typer.Option(False, "--template", help="Write the documented template "
                                  "(typical data-sheet defaults, stated as such)."),
    output: Path | None = typer.Option(None, "-o", "--output", help="With --template: "
                                       "write to this file (refuses to overwrite) instead "
                                       "of printing (same as giving FILE)."),
    length_mm: float = typer.Option(1000.0, help="With FILE: length from the datum of the "
                                    "budget shown [mm]."),
) -> None:
    """Write the budget template, or check a budget and show it at a length."""
    from volcal.errors import VolcalInputError

    if template:
        from volcal.uncertainty.budget import template_text

        if file is not None and output is not None and file != output:
            raise VolcalInputError("--template writes one file: give FILE or -o FILE")
        output = output if output is not None else file
        if output is None:
            typer.echo(template_text(), nl=False)
            return
        if output.exists():
            raise VolcalInputError("exists already: volcal never overwrites a budget file "
                                   "(choose another name)", output)
        from volcal.io.atomic import write_text

        write_text(output, template_text())
        typer.echo(f"budget template: {output}")
        return
    if file is None:
        raise VolcalInputError("give a budget FILE to check, or --template")
    _show(file, length_mm)


def _show(file: Path, length_mm: float) -> None:
    import math

    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from volcal.uncertainty.budget import read_budget
    from volcal.uncertainty.laser import LaserModel
    from volcal.uncertainty.propagation import Propagator

    if not (math.isfinite(length_mm) and length_mm >= 0):
        from volcal.errors import VolcalInputError

        raise VolcalInputError(f"--length-mm {length_mm:g}: expected a finite length >= 0 "
                               "from the datum [mm]")
    b = read_budget(file)
    prop = Propagator()
    laser = LaserModel(b, prop)
    e = prop.estimate(laser.length_term(length_mm) + laser.dead_path())
    console = Console(soft_wrap=True)
    t = Table(title=f"{file}: instrument and environment budget of a reading at "
              f"{length_mm:g} mm from the datum (repeatability comes from the data)")
    for col in ("contributor", "distribution", "u(x)", "unit", "c", "u_i [um]", "share"):
        t.add_column(col, justify="right")
    for c in e.components:
        t.add_row(escape(c.label), c.distribution,
                  "" if c.u_input is None else f"{c.u_input:.3g}", escape(c.unit),
                  "" if c.sensitivity is None else f"{c.sensitivity:.4g}", f"{c.u:.4f}",
                  f"{100 * c.share:.1f} %")
    console.print(t)
    console.print(f"u = {e.u:.4f} um, U = {e.k:.2f} u = {e.U:.4f} um (95 %)", highlight=False)
    from volcal.uncertainty.budget import OPTIC_KEYS

    t = Table(title=escape(f"{file}: direct optics ([optics]; one scale error per "
                           f"{b.values['optics.scale_correlation']})"))
    for col in ("optic", "u scale [%]", "u one reading", "distribution", "source"):
        t.add_column(col, justify="right")
    for target, (ks, kr) in OPTIC_KEYS.items():
        unit = "um" if target == "straightness_optics" else "urad"
        t.add_row(target.replace("_", " "), f"{b.inputs[ks].u:.3g}",
                  f"{b.inputs[kr].u:.3g} {unit}", b.inputs[ks].distribution,
                  "data-sheet default" if ks in b.defaulted else "budget file")
    from volcal.cli._common import print_table

    print_table(console, t)
    for n in b.notes:
        console.print(f"note: {escape(n)}", highlight=False)


def register(app: typer.Typer) -> None:
    """Add ``volcal budget`` to the app."""
    app.command("budget")(budget_cmd)
