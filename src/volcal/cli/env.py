"""``volcal env``: air refractive index and environment helpers."""

from __future__ import annotations

import typer

env_app = typer.Typer(help="Environment: refractive index of air.", no_args_is_help=True)


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

    n = refractive_index(temperature_c, pressure_pa, humidity_pct, wavelength_nm, formula,
                         co2_ppm)
    typer.echo(f"{float(n):.9f}")


def register(app: typer.Typer) -> None:
    """Add the ``env`` command group to the app."""
    app.add_typer(env_app, name="env")
