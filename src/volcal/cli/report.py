"""``volcal report``: the HTML and PDF calibration report of a session."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.markup import escape

from volcal import defaults as D
from volcal.cli._common import note_moved, print_session_notes

console = Console(soft_wrap=True)  # no line breaks inside paths
err_console = Console(stderr=True, soft_wrap=True)  # warnings: standard error


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
    certificate: bool = typer.Option(False, "--certificate", help="Also write the calibration "
                                     "certificate (certificate.pdf, .html, .json); automatic "
                                     "when session.toml has [calibration] keys or "
                                     "[[equipment]]."),
    as_left: Path | None = typer.Option(None, "--as-left", help="Session measured after the "
                                        "compensation tables were loaded: the certificate "
                                        "pairs its measured results with SESSION's "
                                        "(as-found)."),
    tables: Path | None = typer.Option(None, "--tables", help="Compensation folder loaded "
                                       "between SESSION and --as-left, named on the "
                                       "certificate by its manifest (not applied)."),
    strict: bool = typer.Option(False, "--strict", help="Refuse to issue a certificate with "
                                "equipment whose calibration was due before the date of "
                                "measurement."),
    decision_rule: str = typer.Option(D.DECISION_RULE, help="simple (pass when value <= T) or "
                                      "guarded (pass at or below T - w, conditional up to "
                                      "T; w = U from --budget, or --guard-band-um)."),
    guard_band_um: float | None = typer.Option(None, help="Guard band w of the guarded "
                                               "rule [um]."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML): U of every ISO "
                                       "230-2 parameter and target (tables, ± U error bars "
                                       "in the plots), the budget tables; the guard band of "
                                       "the guarded rule; the certificate's U."),
    angle_units: str = typer.Option("urad", "--angle-units", help="Rotary axes: urad or "
                                    "arcsec for the angles of the report."),
    rotary_tolerance_urad: str | None = typer.Option(
        None, "--rotary-tolerance-urad", help="Tolerance of the accuracy A of each rotary "
        "axis [urad], e.g. C=25,A=30: the verdict of the rotary section and certificate."),
    location_tolerance_um: float | None = typer.Option(
        None, "--location-tolerance-um", help="With probe_sphere tests: tolerance of the "
        "largest range of the sphere centre's deviation per path [um] (an ISO 10791-6-style "
        "test, judged by --decision-rule)."),
    history: str | None = typer.Option(None, "--history", help="Calibration history (URL or "
                                       "SQLite file, as `volcal history --db`): add a section "
                                       "with the machine's previous calibration and the "
                                       "change since then."),
    replace: bool = typer.Option(False, "--replace", help="The output folder holds files "
                                 "volcal did not write there (a signed scan, notes): move "
                                 "them into OUTPUT/backup/<UTC time>/ instead of refusing."),
) -> None:
    """Write the calibration report of a session as self-contained HTML and as PDF."""
    from volcal.cli.evaluate import _acceptance
    from volcal.report.rotary import parse_rotary_tolerance
    from volcal.session.format import read_session
    from volcal.standards.iso230_2_rotary import check_units
    from volcal.standards.tolerance import parse_tolerance
    from volcal.steps.report import check_report_inputs
    from volcal.steps.report import report as report_step

    check_units(angle_units)
    rot_tol = parse_rotary_tolerance(rotary_tolerance_urad)
    tol = None if tolerance_um is None else parse_tolerance(tolerance_um)
    from volcal.identify.location_evaluation import location_tolerance

    if tol is None and location_tolerance_um is not None:  # the rule judges it alone
        from volcal.cli.evaluate import _checked_rule

        loc_tol = location_tolerance(location_tolerance_um,
                                     _checked_rule(decision_rule, guard_band_um), guard_band_um)
    else:
        tol = _acceptance(tol, decision_rule, guard_band_um, budget)
        loc_tol = location_tolerance(location_tolerance_um, decision_rule, guard_band_um)
    bud = None
    if budget is not None:
        from volcal.uncertainty.budget import read_budget

        bud = tol.budget if tol is not None and getattr(tol, "budget", None) is not None \
            else read_budget(budget)
    moved = check_report_inputs(output, history=history, replace=replace)
    if moved is not None:
        note_moved(output, moved)
    s = read_session(session)
    print_session_notes(s)
    s2 = None
    if as_left is not None:
        s2 = read_session(as_left)
        print_session_notes(s2)
    done = report_step(s, output=output, model=model, title=title, edition=edition,
                       tolerance=tol, compensation=compensation, history=history,
                       force=force, certificate=certificate, as_left=s2, tables=tables,
                       strict=strict, budget=bud, budget_file=budget, moved=moved,
                       status=console.status, angle_units=angle_units,
                       rotary_tolerance_urad=rot_tol,
                       location_tolerance=loc_tol)
    for w in done.warnings:
        err_console.print(f"[yellow]warning[/] {escape(w)}", highlight=False)
    files = done.files
    console.print(f"report: {files.html} and {files.pdf} ({files.pdf_pages} pages, "
                  f"{len(files.figures)} figures)", soft_wrap=True)
    if done.certificate is not None:
        c = done.certificate
        console.print(f"certificate {done.report_id}: {output / c.pdf.name} "
                      f"({c.pdf_pages} pages), {output / c.json.name}", soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("report")(report_cmd)
