"""``volcal locate``: the rotary axes' location errors from probe-on-sphere and R-test tests."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.console import Console

from volcal.cli._common import is_stdout, message_console, write_output
from volcal.cli._options import cli_spelling

console = Console(soft_wrap=True)


def locate_cmd(
    session: Path = typer.Argument(..., help="Session folder with probe_sphere and/or r_test "
                                   "tests."),
    model: Path | None = typer.Option(None, help="The linear axes' errors: a model file "
                                      "(MODEL.json, with its uncertainty as a prior) or an error "
                                      "table (machine.csv, taken as known); default perfect "
                                      "linear axes."),
    measurements: str | None = typer.Option(None, help="Comma-separated probe_sphere and r_test "
                                            "test ids to use."),
    prior_u: float | None = typer.Option(None, help="Standard deviation of a zero-mean prior "
                                         "on each determined location error [um or urad]; "
                                         "default none (least squares)."),
    json_out: bool = typer.Option(False, "--json", help="Write the result as JSON "
                                  "(volcal-location/1)."),
    output: Path | None = typer.Option(None, "-o", "--output", help="File to write the JSON "
                                       "to (with --json); - or none: standard output."),
    linuxcnc_hal: Path | None = typer.Option(None, help="Write LinuxCNC's xyzac-/xyzbc-trt-kins "
                                             "pins (setp lines) to this HAL file, with what "
                                             "the kinematics cannot hold."),
    siemens_tcarr: Path | None = typer.Option(None, help="Write the Siemens swivel data "
                                              "record ($TC_CARR..[n], kinematic type P) of a "
                                              "trunnion to this part program (.MPF), with what "
                                              "it leaves."),
    tool_carrier: int = typer.Option(1, help="With --siemens-tcarr: the record number n."),
    isg_kinematics: Path | None = typer.Option(None, help="Write the ISG/Beckhoff volumetric "
                                               "compensation's location errors (X0C, Y0C, "
                                               "A0C, ... ISG CSV, mm and rad) to this file, "
                                               "with what they leave."),
    z_rot_point_mm: float | None = typer.Option(None, help="With --linuxcnc-hal: the "
                                                "z-rot-point to keep [mm] (default the C "
                                                "pivot's z; only z-rot-point + z-offset "
                                                "enters)."),
) -> None:
    """Identify the rotary axes' location errors from probe-on-sphere and R-test tests."""
    from volcal.io.paths import check_output_file
    from volcal.steps.locate import locate as step
    from volcal.steps.locate import located_json

    # every output checked, and every export made, before the first file is written
    for path in (linuxcnc_hal, siemens_tcarr, isg_kinematics):
        if path is not None:
            check_output_file(path)
    if json_out and output is not None and not is_stdout(output):
        check_output_file(output)
    ids = [x.strip() for x in measurements.split(",")] if measurements else None
    r = step(session, model=model, measurements=ids, prior_u=prior_u)
    exp: Any = r.linuxcnc_trt(z_rot_point_mm) if linuxcnc_hal is not None else None
    texp: Any = r.siemens_tcarr(tool_carrier) if siemens_tcarr is not None else None
    iexp: Any = r.isg_location() if isg_kinematics is not None else None
    if linuxcnc_hal is not None:
        from volcal.compensate.linuxcnc_trt import trt_hal
        from volcal.io.atomic import write_text

        write_text(linuxcnc_hal, trt_hal(exp))
        message_console(output).print(f"{exp.kins} pins -> {linuxcnc_hal}", highlight=False)
        for note in exp.notes[3:]:
            message_console(output).print(f"- {note}", highlight=False, markup=False)
    if siemens_tcarr is not None:
        from volcal.compensate.siemens_tcarr import tcarr_mpf
        from volcal.io.atomic import write_text

        write_text(siemens_tcarr, tcarr_mpf(texp))
        message_console(output).print(f"$TC_CARR..[{tool_carrier}] -> {siemens_tcarr} "
                                      f"(predicted dispersion {texp.residual_um.max():.3f} "
                                      "um)", highlight=False)
    if isg_kinematics is not None:
        from volcal.compensate.isg_location import isg_location_csv
        from volcal.io.atomic import write_text

        write_text(isg_kinematics, isg_location_csv(iexp))
        message_console(output).print(f"ISG location errors ({', '.join(iexp.errors)}) -> "
                                      f"{isg_kinematics} (predicted dispersion "
                                      f"{iexp.residual_um.max():.3f} um)", highlight=False)
        for note in iexp.notes[4:]:
            message_console(output).print(f"- {note}", highlight=False, markup=False)
    if json_out:
        target = output or Path("-")
        write_output(target, located_json(r))
        if not is_stdout(target):
            message_console(target).print(f"location errors -> {target}", highlight=False)
        return
    console.print(r.to_text(), highlight=False, markup=False, end="")


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("locate")(cli_spelling(locate_cmd))
