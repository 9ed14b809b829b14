"""``volcal env``: air refractive index and environment helpers."""

from __future__ import annotations

from pathlib import Path

import typer

env_app = typer.Typer(help="Environment: refractive index of air, drift check.",
                      no_args_is_help=True)


@env_app.command("refractive-index")
def refractive_index_cmd(
    temperature_c: float = typer.Option(..., help="Air temperature [degC]."),
    pressure_pa: float = typer.Option(..., help="Air pressure [Pa]."),
    humidity_pct: float = typer.Option(..., help="Relative humidity [%]."),
    wavelength_nm: float = typer.Option(632.9912, help="Vacuum wavelength [nm]."),
    formula: str = typer.Option("ciddor", help="edlen (modified, Birch & Downs) or ciddor."),
    co2_ppm: float = typer.Option(450.0, help="CO2 mole fraction [umol/mol]."),
) -> None:
    """Print the refractive index of air n (NIST EMToolbox formulation)."""
    from volcal.environment.refractive import refractive_index
    from volcal.errors import VolcalInputError

    try:
        n = refractive_index(temperature_c, pressure_pa, humidity_pct, wavelength_nm, formula,
                             co2_ppm)
    except VolcalInputError as exc:  # the equations name their inputs as a table's columns
        if exc.column is None:
            raise
        option = "--" + exc.column.replace("_", "-")
        hint = (" (in Pa: 1013.25 hPa is 101325 Pa)"
                if exc.column == "pressure_pa" and 500 <= pressure_pa <= 1100 else "")
        text = exc.message.removeprefix(f"{exc.column} = ")
        raise VolcalInputError(f"{option} {text}{hint}" if text != exc.message
                               else f"{option}: {text}{hint}") from None
    typer.echo(f"{float(n):.9f}")


@env_app.command("drift")
def drift_cmd(
    file: Path = typer.Argument(..., help="Measurement CSV (x_mm,y_mm,z_mm,deviation_um and "
                                "optionally time_s), with repeated readings at the start point."),
    limit_um: float = typer.Option(1.0, min=0.0, help="Largest acceptable span of the "
                                   "start-point readings [um]."),
) -> None:
    """Drift check from the readings taken back at the start point (e.g. between runs)."""
    from volcal.environment.drift import drift_check
    from volcal.errors import VolcalInputError
    from volcal.session.format import read_measurement_csv

    pos, dev, cols = read_measurement_csv(file)
    try:
        r = drift_check(pos, dev, cols.get("time_s"), limit_um)
    except VolcalInputError as exc:
        raise VolcalInputError(exc.message, file) from None
    rate = "" if r.rate_um_per_h != r.rate_um_per_h else f", rate {r.rate_um_per_h:.3f} um/h"
    typer.echo(f"{r.n} readings at the start point: span {r.span_um:.3f} um, first to last "
               f"{r.drift_um:+.3f} um{rate}; limit {r.limit_um:g} um: "
               f"{'OK' if r.ok else 'EXCEEDED'}")
    if not r.ok:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Add the ``env`` command group to the app."""
    app.add_typer(env_app, name="env")
