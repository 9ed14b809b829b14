"""``volcal report``: the HTML and PDF calibration report of a session."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

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
                                             "compensate` from the same model, summarised "
                                             "in the report."),
    edition: str = typer.Option("2014", help="ISO 230-2 edition of the positioning tables."),
    title: str | None = typer.Option(None, help="Report title (default from the machine name)."),
    force: bool = typer.Option(False, "--force", help="Use --model even if it was identified "
                               "from another session (name, chain, travel or readings differ)."),
    tolerance_um: str | None = typer.Option(
        None, help="Tolerance for a pass/fail verdict before and after compensation [um]: "
        "a number (largest volumetric error), X=10,Y=10,Z=8 (ISO 230-2 accuracy A per "
        "axis) or both (X=10,Y=10,Z=8,V=15)."),
) -> None:
    """Write the calibration report of a session as self-contained HTML and as PDF."""
    from volcal.io.paths import check_output_folder
    from volcal.report.pipeline import collect_inputs
    from volcal.report.sections import build_report
    from volcal.report.writer import write_report
    from volcal.session.format import read_session
    from volcal.standards.tolerance import parse_tolerance

    tol = None if tolerance_um is None else parse_tolerance(tolerance_um)
    check_output_folder(output, "report", lambda p: (p / "report.html").is_file())
    s = read_session(session)
    print_session_notes(s)
    if model is not None:
        from volcal.identify.modelfile import check_model_session, load_model

        result = load_model(model)
        result.require_uncertainty("the report (the uncertainty bands of the error functions "
                                   "and of the volumetric error)", model)
        for d in check_model_session(result, s, force, model):
            console.print(f"[yellow]warning[/] --force: {d}", highlight=False)
    else:
        from volcal.identify import identify

        with console.status("identifying the machine's errors..."):
            result = identify(s)
    with console.status("evaluating and writing the report..."):
        files = write_report(build_report(collect_inputs(s, result, edition=edition,
                                                          compensation=compensation,
                                                          tolerance=tol), title),
                             output)
    console.print(f"report: {files.html} and {files.pdf} ({files.pdf_pages} pages, "
                  f"{len(files.figures)} figures)", soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("report")(report_cmd)
