"""``volcal report``: the HTML and PDF calibration report of a session."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.markup import escape

from volcal import defaults as D
from volcal.cli._common import print_session_notes

console = Console(soft_wrap=True)  # no line breaks inside paths


def report_cmd(
    session: Path = typer.Argument(..., help="Measured session folder."),
    model: Path | None = typer.Option(None, help="Identified model (MODEL.json from `volcal "
                                      "identify`); identified now with default options if "
                                      "omitted."),
    output: Path = typer.Option(..., "-o", "--output", help="Report folder to write "
                                "(report.html, report.pdf, figures/)."),
    compensation: Path | None = typer.Option(None, help="Folder written by `volcal "
                                             "compensate` for this machine: its tables, read "
                                             "back from the files, give the 'after'. Tables "
                                             "written for another machine are refused "
                                             "(--force to use them)."),
    edition: str = typer.Option(D.EDITION, help="ISO 230-2 edition of the positioning tables."),
    title: str | None = typer.Option(None, help="Report title (default from the machine name)."),
    force: bool = typer.Option(False, "--force", help="Use --model even if it was identified "
                               "from another session (name, chain, travel or readings differ), "
                               "and --compensation tables written for another machine."),
    tolerance_um: str | None = typer.Option(
        None, help="Tolerance for a pass/fail verdict before and after compensation [um]: "
        "a number (largest volumetric error), X=10,Y=10,Z=8 (ISO 230-2 accuracy A per "
        "axis) or both (X=10,Y=10,Z=8,V=15); X.E=.. for another ISO 230-2 parameter."),
    decision_rule: str = typer.Option("simple", help="simple (pass when value <= T) or "
                                      "guarded (pass at or below T - w, conditional up to "
                                      "T; w = U from --budget, or --guard-band-um)."),
    guard_band_um: float | None = typer.Option(None, help="Guard band w of the guarded "
                                               "rule [um]."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML): U of the "
                                       "toleranced ISO 230-2 parameters."),
) -> None:
    """Write the calibration report of a session as self-contained HTML and as PDF."""
    from volcal.cli.evaluate import _acceptance
    from volcal.io.paths import check_output_folder
    from volcal.report.pipeline import collect_inputs
    from volcal.report.sections import build_report
    from volcal.report.writer import write_report
    from volcal.session.format import read_session
    from volcal.standards.tolerance import parse_tolerance

    tol = None if tolerance_um is None else parse_tolerance(tolerance_um)
    tol = _acceptance(tol, decision_rule, guard_band_um, budget)
    check_output_folder(output, "report", lambda p: (p / "report.html").is_file())
    s = read_session(session)
    print_session_notes(s)
    if compensation is not None:  # refuse another machine's tables before any work
        from volcal.compensate.manifest import check_manifest, read_manifest
        from volcal.session.identity import MachineIdentity

        check_manifest(read_manifest(compensation), compensation, MachineIdentity.of(s),
                       None, force)
    if model is not None:
        from volcal.identify.modelfile import check_model_session, load_model

        result = load_model(model)
        for d in check_model_session(result, s, force, model):
            console.print(f"[yellow]warning[/] --force: {d}", highlight=False)
    else:
        from volcal.identify import identify

        with console.status("identifying the machine's errors..."):
            result = identify(s)
    with console.status("evaluating and writing the report..."):
        inputs = collect_inputs(s, result, edition=edition, compensation=compensation,
                                tolerance=tol, force=force,
                                model_label=("the model identified now" if model is None
                                             else str(model)))
        files = write_report(build_report(inputs, title), output)
    if inputs.compensation is not None:
        for w in inputs.compensation.warnings:
            console.print(f"[yellow]warning[/] {escape(w)}", highlight=False)
    console.print(f"report: {files.html} and {files.pdf} ({files.pdf_pages} pages, "
                  f"{len(files.figures)} figures)", soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("report")(report_cmd)
