"""``volcal plan`` and ``volcal simulate``."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.markup import escape

from volcal import defaults as D
from volcal.cli._common import parse_travel, parse_vector
from volcal.cli._options import cli_spelling
from volcal.errors import VolcalInputError

console = Console(soft_wrap=True)  # no line breaks inside paths


def _text(v: Iterable[float]) -> str:
    """A default as the command line's text: ``(0.0, 0.0, 0.0)`` -> ``'0,0,0'``."""
    return ",".join(f"{x:g}" for x in v)


def plan(
    travel: str = typer.Option("0:800,0:600,0:500", help="Travel limits x,y,z as min:max "
                               "[mm]. With --add: the session's."),
    chain: str = typer.Option(D.CHAIN, help="Kinematic chain from workpiece to tool, F = "
                              "frame. With --add: the session's."),
    steps: int = typer.Option(D.PLAN_STEPS, help="Increments per test."),
    tests: str = typer.Option(",".join(D.PLAN_TESTS),
                              help="Comma-separated: step-diagonal, diagonal, linear, "
                              "face-diagonal, face-step-diagonal, multilateration, direct "
                              "(direct optics: straightness, angular, level, optical squares; "
                              "docs/formats.md), rotary (a rotary axis, ISO 230-2), "
                              "probe_sphere, r_test (a trunnion's location errors, volcal "
                              "locate); one axis or plane: linear:x, face-diagonal:xy, "
                              "face-step-diagonal:yz, rotary:c, probe_sphere:cb. Case and "
                              "'-' or '_' do not matter."),
    runs: int = typer.Option(D.PLAN_RUNS, help="Bidirectional runs per linear test "
                             "(ISO 230-2)."),
    step_orders: str = typer.Option(",".join(D.PLAN_STEP_ORDERS),
                                    help="Axis orders of the step diagonals, e.g. xyz,yxz."),
    tool_offset: str = typer.Option(_text(D.PLAN_TOOL_OFFSET_MM),
                                    help="Target point on the tool x,y,z [mm]."),
    name: str = typer.Option(D.PLAN_NAME, help="Machine name. With --add: the session's."),
    iso_spacing: bool = typer.Option(True, help="Unequally spaced linear-test targets "
                                     "(ISO 230-2:2014, 5.2); --no-iso-spacing for the "
                                     "equally spaced step grid."),
    step_target: str = typer.Option(D.PLAN_STEP_TARGET, help="Target of the step diagonals: "
                                    "flat_mirror, retroreflector or retroreflector_mirror."),
    overrun_mm: float = typer.Option(D.PROG_OVERRUN_MM, help="Keep linear-test targets this "
                                     "far inside the travel, room for the ISO 230-2 overrun "
                                     "of the part programs (same default as `volcal "
                                     "program`) [mm]."),
    abbe_offset_mm: float = typer.Option(D.PLAN_ABBE_OFFSET_MM, help="Target offset from the "
                                         "spindle for the Abbe lines no machine move can "
                                         "offset [mm]."),
    grid: str = typer.Option(_text(D.ML_GRID), help="Multilateration: grid points along "
                             "x,y,z."),
    stations: str = typer.Option(str(D.ML_STATIONS), help="Multilateration: number of "
                                 "default stations (3-8), or pivots 'x,y,z;x,y,z;...' [mm]."),
    tool_offsets: str = typer.Option(";".join(map(_text, D.ML_TOOL_OFFSETS_MM)),
                                     help="Multilateration: reflector offsets on the tool "
                                     "'x,y,z;x,y,z' [mm]."),
    targets: str | None = typer.Option(None, "--targets", help="Rotary tests: target angles "
                                       "[deg], comma-separated (default: the ISO 230-2 "
                                       "spread over the axis' range)."),
    rotary_axes: str | None = typer.Option(None, "--rotary-axes", help="The machine's rotary "
                                           "axes name:min:max[:modulo|limited] [deg], e.g. "
                                           "c:0:360:modulo,a:-120:30:limited (default for "
                                           "rotary:a|b|c: a full circle); probe_sphere and "
                                           "r_test keep within a limited axis."),
    output: Path | None = typer.Option(None, "-o", "--output", help="Session folder to write "
                                       "(a new or empty folder; an existing session only "
                                       "with --replace)."),
    add: Path | None = typer.Option(None, "--add", help="Existing session folder: append the "
                                    "tests with fresh ids (its travel, chain and name are "
                                    "used; its measurements and readings are untouched)."),
    replace: bool = typer.Option(False, "--replace", help="With -o: replace an existing "
                                 "session; its session.toml, measurement CSVs, truth/ and "
                                 "capture journal (capture/) are moved to OUTPUT/backup/<UTC "
                                 "time>/."),
) -> None:
    """Write a session skeleton: the commanded poses of every test, deviations empty.

    Never replaces an existing session unless --replace is given (the old files are then
    kept in backup/<time>/); --add appends tests to an existing session instead.
    """
    from volcal.steps import plan as step

    if (output is None) == (add is None):
        raise VolcalInputError("give -o/--output FOLDER (a new session) or --add FOLDER (tests "
                               "added to an existing session)" + (", not both" if output
                                                                 else ""))
    common: dict[str, Any] = {
        "tests": tests, "steps": steps, "runs": runs, "step_orders": step_orders,
        "tool_offset": parse_vector(tool_offset, "--tool-offset"), "step_target": step_target,
        "iso_spacing": iso_spacing, "overrun_mm": overrun_mm, "abbe_offset_mm": abbe_offset_mm,
        "targets": targets, "rotary_axes": rotary_axes}
    if add is not None:
        if replace:
            raise VolcalInputError("--replace belongs to -o (a new session); --add never "
                                   "replaces anything")
        a = step.add(add, **common,
                     multilateration=_multilateration_options(grid, stations, tool_offsets))
        r = a.result
        ids = ", ".join(m.id for m in r.added)
        console.print(f"added {len(r.added)} measurements, {a.n_readings} readings to {add} "
                      f"(now {r.n_before + len(r.added)}): {ids}", highlight=False)
        if r.renamed:
            console.print("ids already in the session were not reused: "
                          + ", ".join(f"{a} -> {b}" for a, b in r.renamed.items()),
                          highlight=False)
        return
    assert output is not None
    p = step.plan(parse_travel(travel), chain=chain, name=name, **common,
                  multilateration=_multilateration_options(grid, stations, tool_offsets),
                  output=output, replace=replace)
    if p.backup is not None:
        console.print(f"replaced the session in {output}; the old session.toml and "
                      f"{p.n_backed_up} measurement files are kept in {p.backup}/",
                      highlight=False)
    console.print(f"planned {len(p.session.measurements)} measurements, {p.n_readings} "
                  f"readings -> {output}")


def simulate(
    session: Path = typer.Argument(..., help="Session folder (planned or measured)."),
    seed: int = typer.Option(D.SIM_SEED, min=0, help="Seed of the virtual machine and of the "
                            "noise."),
    noise_um: float = typer.Option(D.SIM_NOISE_UM, help="Repeatability noise per reading [um]."),
    mirror_misalignment_urad: float = typer.Option(D.SIM_MIRROR_URAD, "--mirror-urad",
                                                   help="Residual mirror misalignment [urad]."),
    drift_um_per_h: float = typer.Option(D.SIM_DRIFT_UM_PER_H,
                                         help="Linear drift of the readings [um/h]."),
    machine: Path | None = typer.Option(None, help="Error table ERRORS.csv (default: random)."),
    reversal_um: float = typer.Option(D.SIM_REVERSAL_UM,
                                      help="Max reversal of a random machine's axes [um]."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Replace readings that "
                                   "`volcal simulate` did not write (measured ones); a backup "
                                   "of the replaced files is kept in SESSION/backup/<time>/."),
    budget: Path | None = typer.Option(None, help="Uncertainty budget (TOML): draw its "
                                       "systematic errors (wavelength, air per set-up, "
                                       "material per axis, the scale of each direct "
                                       "optic) and apply them to the readings; "
                                       "the draw is kept in SESSION/truth/systematic.toml."),
    compensation: Path | None = typer.Option(None, help="Folder written by `volcal "
                                             "compensate`: the virtual machine runs with "
                                             "these tables active (an as-left measurement); "
                                             "give the machine as found with --machine "
                                             "FOUND/truth/machine.csv (or its --seed)."),
    force: bool = typer.Option(False, "--force", help="With --compensation: apply tables "
                               "written for another machine."),
) -> None:
    """Fill the deviations from a virtual machine; keep its truth in SESSION/truth/.

    Refuses a session holding readings it did not write itself (measured or edited
    since), unless --overwrite is given; then the old files are kept in a backup.
    """
    from volcal.steps import simulate as step

    r = step.simulate(session, machine=machine, seed=seed, noise_um=noise_um,
                      mirror_misalignment_urad=mirror_misalignment_urad,
                      drift_um_per_h=drift_um_per_h, reversal_um=reversal_um, budget=budget,
                      overwrite=overwrite, compensation=compensation, force=force)
    for note in r.notes:
        console.print(f"[yellow]note:[/] {escape(note)}", highlight=False)
    folder = r.session.path or session  # the folder, also where session.toml was named
    backup = step.save(r, folder)
    if backup is not None:
        console.print(f"replaced the readings of {len(r.replaced)} measurements; the old "
                      f"files are kept in {backup}/", highlight=False)
    console.print(f"simulated {len(r.session.measurements)} measurements on '{r.machine.name}' "
                  f"(noise {noise_um} um, mirror {mirror_misalignment_urad} urad"
                  + (f", systematic errors drawn from {budget}" if budget is not None else "")
                  + (f", the tables of {compensation} active" if compensation is not None
                     else "")
                  + f"); truth in {folder}/truth/")


def _multilateration_options(grid: str, stations: str, tool_offsets: str) -> dict:
    """Keyword arguments of the multilateration plan from the CLI strings."""
    try:
        g = [int(v) for v in grid.split(",")]
    except ValueError:
        raise VolcalInputError(f"--grid {grid!r}: expected 3 whole numbers, e.g. 9,7,6") from None
    if len(g) != 3:
        raise VolcalInputError(f"--grid {grid!r}: expected 3 whole numbers, e.g. 9,7,6")
    offs = [parse_vector(o, "--tool-offsets") for o in tool_offsets.split(";") if o.strip()]
    out: dict = {"grid": g, "tool_offsets": offs}
    if ";" in stations or "," in stations:
        out["stations"] = [parse_vector(v, "--stations") for v in stations.split(";")
                           if v.strip()]
    else:
        try:
            n = int(stations)
        except ValueError:
            raise VolcalInputError(f"--stations {stations!r}: expected a count or "
                                   "'x,y,z;x,y,z;...'") from None
        out["n_stations"] = n
    return out


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the app."""
    app.command("plan")(cli_spelling(plan))
    app.command("simulate")(cli_spelling(simulate))
