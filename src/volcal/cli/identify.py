"""``volcal identify`` and ``volcal predict``."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from volcal import defaults as D
from volcal.cli._common import (
    is_stdout,
    message_console,
    parse_vector,
    print_session_notes,
    write_output,
)
from volcal.cli._options import cli_spelling

console = Console(soft_wrap=True)  # no line breaks inside paths
err_console = Console(stderr=True, soft_wrap=True)  # warnings: standard error


def identify_cmd(
    session: Path = typer.Argument(..., help="Measured session folder."),
    output: Path = typer.Option(..., "-o", "--output", help="Model file to write (MODEL.json); "
                                "- writes it to standard output."),
    prior: str = typer.Option(D.PRIOR, help="smooth (Bayesian, default) or none (min-norm LS)."),
    noise_um: float | None = typer.Option(None, help="Stated repeatability [um] (default: "
                                          "estimated)."),
    roll: str = typer.Option(D.ROLL, help="estimate, or zero (the rolls EAX, EBY, ECZ "
                             "fixed to zero)."),
    known: Path | None = typer.Option(None, help="CSV of errors measured separately "
                                      "(axis,position_mm and any of EX_um..EC_urad, only "
                                      "the axes measured; or a full error table): those "
                                      "functions are held fixed."),
    known_u: float | None = typer.Option(None, help="Standard uncertainty of the --known "
                                         "functions [um or urad]: use them as priors instead "
                                         "of fixing them."),
    monte_carlo: int = typer.Option(D.MONTE_CARLO, min=0, help="Monte Carlo trials (GUM S1) "
                                    "of the noise "
                                    "propagation to the volumetric error; 0 = off."),
    drift: bool = typer.Option(False, help="Estimate a linear drift per measurement."),
    measurements: str | None = typer.Option(None, help="Comma-separated measurement ids to use."),
    max_nodes: int = typer.Option(D.MAX_NODES, min=3, max=2001, help="Nodes per axis at most "
                                  "(problem "
                                  "size; the parameter count stops growing there)."),
    robust: bool = typer.Option(False, help="Down-weight the readings the outlier check "
                                "flags (weight 1/z^2) and fit again; they stay listed."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML, `volcal budget "
                                       "--template`): its systematic inputs (wavelength, "
                                       "air per set-up, material per axis, the scale "
                                       "of each direct optic) propagated "
                                       "through the fit, kept apart in the model file."),
    estimator_settings: Path | None = typer.Option(
        None, help="Estimator settings (TOML: fields of EstimatorSettings, e.g. "
        "between_readings_factor = 0.0; docs/formats.md); the fields that differ from "
        "volcal's defaults are recorded in the model file (fit.estimator_settings)."),
) -> None:
    """Identify the machine's errors from the session; write MODEL.json."""
    from volcal.identify.modelfile import binary_path
    from volcal.identify.modelwrite import is_binary_part
    from volcal.io.paths import check_output_file
    from volcal.steps.identify import identify as step

    console = message_console(output)  # stderr when the model goes to stdout
    if not is_stdout(output):
        check_output_file(output)
        check_output_file(binary_path(output), own=is_binary_part)  # MODEL.npz, beside it
    with console.status("identifying..."):
        r = step(session, prior=prior, noise_um=noise_um, roll=roll, known=known,
                 known_u=known_u, monte_carlo=monte_carlo, drift=drift,
                 measurements=measurements, max_nodes=max_nodes, robust=robust,
                 budget=budget, settings=estimator_settings)
    print_session_notes(r.session)
    res = r.result
    if is_stdout(output):  # one file on standard output: format 2, everything as text
        import json

        write_output(output, json.dumps(res.to_single_file_dict(), indent=1,
                                        allow_nan=False) + "\n")
    else:
        res.to_json(output)  # MODEL.npz (covariance, readings) first, then MODEL.json
    f = res.fit
    console.print(f"{f['n_readings']} readings, {f['n_parameters']} parameters, "
                  f"residual {f['sigma_residual_um']:.3f} um ({f['method']})")
    for msg in r.messages:
        console.print(f"- {msg}", highlight=False, markup=False)
    if r.systematic is not None:
        u = r.systematic
        console.print(f"volumetric error uncertainty over the measured grid, largest u: noise "
                      f"and prior {u.noise_um:.3f} um, systematic (budget: {u.n_inputs} "
                      f"inputs) {u.systematic_um:.3f} um, both {u.total_um:.3f} um",
                      highlight=False)
    if r.between is not None:
        console.print("between the readings: " + r.between.describe(), highlight=False,
                      markup=False)
    for note in r.notes:
        console.print(f"note: {note}", highlight=False, markup=False)
    console.print("model -> " + ("standard output" if is_stdout(output)
                                 else f"{output} (+ {binary_path(output).name})"),
                  highlight=False)


def predict_cmd(
    model: Path = typer.Argument(..., help="Model file (MODEL.json)."),
    points: Path = typer.Option(..., help="CSV with x_mm,y_mm,z_mm."),
    output: Path = typer.Option(..., "-o", "--output", help="CSV to write; - writes it to "
                                "standard output."),
    tool_offset: str = typer.Option(",".join(map("{:g}".format, D.TOOL_OFFSET_MM)),
                                    help="Tool offset x,y,z [mm]."),
    session: Path | None = typer.Option(None, help="Session folder the model should belong "
                                        "to: refused if name, chain, travel or readings "
                                        "differ."),
    force: bool = typer.Option(False, "--force", help="With --session: use the model even if "
                               "it was identified from another session."),
) -> None:
    """Predict the volumetric error and its uncertainty at points."""
    from volcal.io.paths import check_output_file, first_line_is
    from volcal.steps.predict import COLUMNS
    from volcal.steps.predict import predict as step

    console = message_console(output)  # stderr when the CSV goes to stdout
    if not is_stdout(output):
        check_output_file(output, own=first_line_is(",".join(COLUMNS)))
    r = step(model, points, tool_offset=parse_vector(tool_offset, "--tool-offset"),
             session=session, force=force)
    for d in r.warnings:
        err_console.print(f"[yellow]warning[/] --force: {d}", highlight=False)
    write_output(output, r.to_csv())
    console.print(f"{r.points.shape[0]} points -> "
                  + ("standard output" if is_stdout(output) else str(output)), highlight=False)


def advise_cmd(
    session: Path = typer.Argument(..., help="Planned (or measured) session folder."),
    roll: str = typer.Option(D.ROLL, help="estimate, or zero (the rolls EAX, EBY, ECZ "
                             "fixed to zero)."),
    candidates: Path | None = typer.Option(None, help="With probe_sphere tests: a CSV of "
                                           "candidate poses and sphere positions to rank "
                                           "(<axis>_deg columns, optional sphere_x_mm, "
                                           "sphere_y_mm, sphere_z_mm, candidate); default "
                                           "a generated set."),
    top: int = typer.Option(D.ADVISE_TOP, help="With probe_sphere tests: how many ranked "
                            "candidates to list per chain."),
    json_out: bool = typer.Option(False, "--json", help="Write the advice as JSON "
                                  "(volcal-advice/1) to standard output."),
    estimator_settings: Path | None = typer.Option(
        None, help="Estimator settings (TOML, as volcal identify --estimator-settings): "
        "typical_scales is the prior of the advice."),
) -> None:
    """Before measuring: what the planned tests will and will not determine."""
    from volcal.steps.advise import advise as step

    with console.status("analysing the design..."):
        r = step(session, roll=roll, candidates=candidates, top=top,
                 settings=estimator_settings)
    if json_out:
        import json

        typer.echo(json.dumps(r.to_dict(), indent=1, allow_nan=False))
        return
    for msg in r.messages:
        console.print(f"- {msg}", highlight=False, markup=False)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("advise")(cli_spelling(advise_cmd))
    app.command("identify")(cli_spelling(identify_cmd))
    app.command("predict")(cli_spelling(predict_cmd))
