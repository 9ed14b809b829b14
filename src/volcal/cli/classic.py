"""``volcal classic ...``: the seeds' classic solvers (``docs/classic.md``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from volcal.cli._common import (
    is_stdout,
    message_console,
    print_session_notes,
    print_table,
    write_output,
)
from volcal.errors import VolcalInputError

console = Console(soft_wrap=True)  # no line breaks inside paths
classic_app = typer.Typer(help="The seeds' classic solvers: Abbe lines, body diagonals, "
                          "sequential step diagonal (docs/classic.md).", no_args_is_help=True)


def _parse_offsets(text: str) -> np.ndarray:
    rows = [r for r in text.split(";") if r.strip()]
    out = []
    for r in rows:
        try:
            v = [float(s) for s in r.split(",")]
        except ValueError:
            raise VolcalInputError(f"--offsets {text!r}: {r!r} is not two numbers a,b [mm]"
                                   ) from None
        if len(v) != 2 or not all(np.isfinite(v)):
            raise VolcalInputError(f"--offsets {text!r}: {r!r} must be two finite numbers a,b "
                                   "[mm] (the two other axes, alphabetical)")
        out.append(v)
    return np.array(out).reshape(-1, 2)


def _axis(text: str) -> int:
    if text.upper() not in ("X", "Y", "Z"):
        raise VolcalInputError(f"--axis {text!r}: expected X, Y or Z")
    return "XYZ".index(text.upper())


def _print_solution(axis: int, targets, pos, rot, title: str) -> None:
    from volcal.classic.abbe import rotation_names

    a = "XYZ"[axis]
    r1, r2 = rotation_names(axis)
    tab = Table(title=title)
    for h in (f"{a.lower()} [mm]", f"E{a}{a} [um]", f"{r1} [urad]", f"{r2} [urad]"):
        tab.add_column(escape(h), justify="right")
    for q, p, (u, v) in zip(targets, pos, rot, strict=True):
        tab.add_row(f"{q:g}", f"{p:.3f}", f"{u:.2f}", f"{v:.2f}")
    print_table(console, tab)


def abbe(
    files: list[Path] = typer.Argument(..., help="3 or more linear measurement CSVs of one axis."),
    axis: str = typer.Option(..., help="Measured axis X, Y or Z."),
    offsets: str | None = typer.Option(
        None, help="Abbe offset of each file from the reference line, 'a,b;a,b;...' [mm], "
        "the two other axes in alphabetical order (X: y,z; Y: x,z; Z: x,y). Default: "
        "from the files' positions and --chain."),
    chain: str | None = typer.Option(None, help="Chain code, needed without --offsets."),
    output: Path | None = typer.Option(None, "-o", "--output", help="CSV to write; - writes "
                                       "it to standard output."),
) -> None:
    """Positioning and the two tilts (pitch, yaw) from lines at different Abbe offsets."""
    from volcal.classic.abbe import abbe_lines
    from volcal.classic.lines import abbe_csv, lever_offsets, lines_from_files

    k = _axis(axis)
    if output is not None and not is_stdout(output):
        from volcal.io.paths import check_output_file, first_line_is

        check_output_file(output, own=first_line_is(*(abbe_csv(j, np.zeros(0), np.zeros(0),
                                                                np.zeros((0, 2))).strip()
                                                       for j in range(3))))
    if len(files) < 3:
        raise VolcalInputError(f"need at least 3 files at different Abbe offsets, got {len(files)}")
    targets, devs, points = lines_from_files(files, k)
    if offsets is not None:
        off = _parse_offsets(offsets)
        if off.shape[0] != len(files):
            raise VolcalInputError(f"--offsets gives {off.shape[0]} offsets for {len(files)} files")
    else:
        if chain is None:
            raise VolcalInputError("give --offsets, or --chain to take the Abbe offsets from the "
                                   "files' positions")
        off = lever_offsets(points, np.zeros(3), chain, k)
    try:
        pos, rot = abbe_lines(devs, off, k)
    except ValueError as exc:
        raise VolcalInputError(str(exc)) from None
    if output is not None:
        write_output(output, abbe_csv(k, targets, pos, rot))
        message_console(output).print(f"{len(files)} lines of {'XYZ'[k]} -> "
                                      + ("standard output" if is_stdout(output)
                                         else str(output)), highlight=False)
    else:
        _print_solution(k, targets, pos, rot, f"Abbe lines of {'XYZ'[k]}")


def abbe_session_cmd(
    session: Path = typer.Argument(..., help="Measured session folder."),
    output: Path | None = typer.Option(None, "-o", "--output",
                                       help="Folder for abbe-x.csv, abbe-y.csv, abbe-z.csv."),
) -> None:
    """Abbe-line solution for every axis from a session's linear measurements."""
    from volcal.classic.lines import abbe_session
    from volcal.io.atomic import write_text
    from volcal.session.format import read_session

    if output is not None:
        from volcal.io.paths import check_output_folder

        check_output_folder(output, "Abbe-line", lambda p: any(p.glob("abbe-?.csv")))
    s = read_session(session)
    print_session_notes(s)
    results = abbe_session(s)
    if not results:
        raise VolcalInputError("the session has no linear measurements", session)
    for r in results:
        a = "XYZ"[r.axis]
        if r.positioning_um is None:
            console.print(f"[yellow]{a}:[/] not solved: {escape(r.message)}", highlight=False)
            continue
        if output is not None:
            path = output / f"abbe-{a.lower()}.csv"
            write_text(path, r.to_csv())
            console.print(f"{a}: {len(r.ids)} lines ({', '.join(r.ids)}) -> {path}")
        else:
            _print_solution(r.axis, r.targets_mm, r.positioning_um, r.rotations_urad,
                            f"Abbe lines of {a}: {', '.join(r.ids)}")


def step_diagonal(
    session: Path = typer.Argument(..., help="Measured session folder."),
    output: Path | None = typer.Option(None, "-o", "--output", help="Error table CSV to write."),
) -> None:
    """Wang's sequential step diagonal: positioning, straightness, squareness (angles neglected)."""
    from volcal.classic.step_diagonal import step_diagonal_session
    from volcal.session.errortable import write_error_table
    from volcal.session.format import read_session

    if is_stdout(output):
        raise VolcalInputError("-o -: step-diagonal writes two files (ERRORS.csv and "
                               "ERRORS.toml); give a file name")
    if output is not None:
        from volcal.io.paths import check_output_file

        check_output_file(Path(output).with_suffix(".csv"))
        check_output_file(Path(output).with_suffix(".toml"))
    s = read_session(session)
    print_session_notes(s)
    r = step_diagonal_session(s)
    sq = ", ".join(f"{n} = {v:.2f} urad" for n, v in zip(("EC0Y", "EB0Z", "EA0Z"),
                                                         r.errors.squareness, strict=True))
    console.print(f"{r.n_increments} increments, residual RMS {r.residual_rms_um:.3f} um; {sq}")
    missing = [n for n, ok in r.determined.items() if not ok]
    if missing:
        console.print(f"[yellow]not determined (set to 0):[/] {', '.join(missing)}")
    console.print("assumes angular errors and mirror misalignment are negligible "
                  "(docs/classic.md, section 3)")
    if output is not None:
        path = write_error_table(r.errors, output)
        console.print(f"-> {path} and {path.with_suffix('.toml')}")


def diagonals(
    session: Path = typer.Argument(..., help="Measured session folder."),
) -> None:
    """Quick volumetric check of the body diagonals and Soons' combinations."""
    from volcal.classic.diagonals import diagonal_check, soons_from_measurements
    from volcal.session.format import read_session

    s = read_session(session)
    print_session_notes(s)
    checks = diagonal_check(s.measurements)
    if not checks:
        raise VolcalInputError("the session has no diagonal measurements", session)
    tab = Table(title="Diagonal quick check")
    for h in ("diagonal", "length [mm]", "points", "max |dev| [um]", "range [um]", "end [um]"):
        tab.add_column(escape(h), justify="right")
    for c in checks:
        m = s.get(c.id)
        pts = f"{m.n}/{m.n_planned}" + ("" if m.n == m.n_planned else " incomplete")
        tab.add_row(c.id, f"{c.length_mm:.1f}", pts, f"{c.max_abs_um:.2f}",
                    f"{c.range_um:.2f}", f"{c.end_um:.2f}")
    print_table(console, tab)
    try:
        r = soons_from_measurements(s.measurements)
    except VolcalInputError as exc:
        console.print(f"[yellow]no combinations:[/] {escape(exc.message)}", highlight=False)
        return
    console.print(f"positioning combination n_x dEXX + n_y dEYY + n_z dEZZ = "
                  f"{r.positioning_um:.3f} um")
    console.print("squareness estimates (angular errors neglected): " + ", ".join(
        f"{n} = {v:.2f} urad" for n, v in zip(("EC0Y", "EB0Z", "EA0Z"), r.squareness_urad,
                                              strict=True)))


classic_app.command("abbe")(abbe)
classic_app.command("abbe-session")(abbe_session_cmd)
classic_app.command("step-diagonal")(step_diagonal)
classic_app.command("diagonals")(diagonals)


def optics(
    session: Path = typer.Argument(..., help="Measured session folder."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Each direct optic's own evaluation, no model (same as ``volcal evaluate optics``)."""
    from volcal.cli.evaluate import optics_cmd

    # called as a function: every option is passed (typer's defaults are OptionInfo objects)
    optics_cmd(session, as_json, budget=None, tolerance_um=None, decision_rule="simple",
               guard_band_um=None)


classic_app.command("optics")(optics)


def register(app: typer.Typer) -> None:
    """Add ``volcal classic`` to the app."""
    app.add_typer(classic_app, name="classic")
