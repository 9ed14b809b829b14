"""``volcal plan`` and ``volcal simulate``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.console import Console

from volcal import defaults as D
from volcal.cli._common import parse_travel, parse_vector
from volcal.errors import VolcalInputError

console = Console(soft_wrap=True)  # no line breaks inside paths


def plan(
    travel: str = typer.Option("0:800,0:600,0:500", help="Travel limits x,y,z as min:max "
                               "[mm]. With --add: the session's."),
    chain: str = typer.Option("XYFZ", help="Kinematic chain from workpiece to tool, F = frame. "
                              "With --add: the session's."),
    steps: int = typer.Option(10, help="Increments per test."),
    tests: str = typer.Option("step-diagonal,diagonal,linear",
                              help="Comma-separated: step-diagonal, diagonal, linear, "
                              "face-diagonal, face-step-diagonal, multilateration, direct "
                              "(direct optics: straightness, angular, level, optical squares; "
                              "docs/formats.md); one axis or plane: linear:x, "
                              "face-diagonal:xy, face-step-diagonal:yz."),
    runs: int = typer.Option(5, help="Bidirectional runs per linear test (ISO 230-2)."),
    step_orders: str = typer.Option("xyz", help="Axis orders of the step diagonals, e.g. xyz,yxz."),
    tool_offset: str = typer.Option("0,0,0", help="Target point on the tool x,y,z [mm]."),
    name: str = typer.Option("VMC-1", help="Machine name. With --add: the session's."),
    iso_spacing: bool = typer.Option(True, help="Unequally spaced linear-test targets "
                                     "(ISO 230-2:2014, 5.2); --no-iso-spacing for the "
                                     "equally spaced step grid."),
    step_target: str = typer.Option("flat_mirror", help="Target of the step diagonals: "
                                    "flat_mirror, retroreflector or retroreflector_mirror."),
    overrun_mm: float = typer.Option(5.0, help="Keep linear-test targets this far inside "
                                     "the travel, room for the ISO 230-2 overrun of the part "
                                     "programs (same default as `volcal program`) [mm]."),
    abbe_offset_mm: float = typer.Option(150.0, help="Target offset from the spindle for "
                                         "the Abbe lines no machine move can offset [mm]."),
    grid: str = typer.Option("9,7,6", help="Multilateration: grid points along x,y,z."),
    stations: str = typer.Option("4", help="Multilateration: number of default stations "
                                 "(3-8), or pivots 'x,y,z;x,y,z;...' [mm]."),
    tool_offsets: str = typer.Option("0,0,-100;100,100,-100", help="Multilateration: "
                                     "reflector offsets on the tool 'x,y,z;x,y,z' [mm]."),
    output: Path | None = typer.Option(None, "-o", "--output", help="Session folder to write "
                                       "(a new or empty folder; an existing session only "
                                       "with --replace)."),
    add: Path | None = typer.Option(None, "--add", help="Existing session folder: append the "
                                    "tests with fresh ids (its travel, chain and name are "
                                    "used; its measurements and readings are untouched)."),
    replace: bool = typer.Option(False, "--replace", help="With -o: replace an existing "
                                 "session; its session.toml, measurement CSVs and truth/ are "
                                 "moved to OUTPUT/backup/<UTC time>/."),
) -> None:
    """Write a session skeleton: the commanded poses of every test, deviations empty.

    Never replaces an existing session unless --replace is given (the old files are then
    kept in backup/<time>/); --add appends tests to an existing session instead.
    """
    from volcal.io.paths import check_output_folder
    from volcal.plan.extend import existing_session, refusal, replace_session
    from volcal.plan.planner import plan_session
    from volcal.session.format import write_session

    if (output is None) == (add is None):
        raise VolcalInputError("give -o/--output FOLDER (a new session) or --add FOLDER (tests "
                               "added to an existing session)" + (", not both" if output
                                                                 else ""))
    if add is not None:
        if replace:
            raise VolcalInputError("--replace belongs to -o (a new session); --add never "
                                   "replaces anything")
        _add(add, tests, steps, runs, step_orders, tool_offset, step_target, iso_spacing,
             overrun_mm, abbe_offset_mm, grid, stations, tool_offsets)
        return
    assert output is not None
    old = existing_session(output) if output.is_dir() else None
    if old is None:
        check_output_folder(output, "session")
    elif not replace:
        raise refusal(old, str(output))
    s = plan_session(parse_travel(travel), chain, steps,
                     [t.strip() for t in tests.split(",") if t.strip()], runs,
                     [o.strip() for o in step_orders.split(",") if o.strip()],
                     parse_vector(tool_offset, "--tool-offset"), name,
                     step_target=step_target,
                     iso_spacing=iso_spacing, linear_margin_mm=overrun_mm,
                     abbe_tool_offset_mm=abbe_offset_mm,
                     multilateration=_multilateration_options(grid, stations, tool_offsets))
    n = sum(m.n for m in s.measurements)
    if old is None:
        write_session(s, output, keep_existing=True)
    else:
        rel = replace_session(s, output, old)
        console.print(f"replaced the session in {output}; the old session.toml and "
                      f"{len(old.files)} measurement files are kept in {output / rel}/",
                      highlight=False)
    console.print(f"planned {len(s.measurements)} measurements, {n} readings -> {output}")


def _add(folder: Path, tests: str, steps: int, runs: int, step_orders: str, tool_offset: str,
         step_target: str, iso_spacing: bool, overrun_mm: float, abbe_offset_mm: float,
         grid: str, stations: str, tool_offsets: str) -> None:
    """``volcal plan --add``: plan the tests on the session's machine and append them."""
    from volcal.plan.extend import add_planned_tests

    r = add_planned_tests(folder, [t.strip() for t in tests.split(",") if t.strip()], steps,
                          runs, [o.strip() for o in step_orders.split(",") if o.strip()],
                          parse_vector(tool_offset, "--tool-offset"), step_target,
                          iso_spacing=iso_spacing, linear_margin_mm=overrun_mm,
                          abbe_tool_offset_mm=abbe_offset_mm,
                          multilateration=_multilateration_options(grid, stations,
                                                                   tool_offsets))
    n = sum(m.n for m in r.added)
    ids = ", ".join(m.id for m in r.added)
    console.print(f"added {len(r.added)} measurements, {n} readings to {folder} (now "
                  f"{r.n_before + len(r.added)}): {ids}", highlight=False)
    if r.renamed:
        console.print("ids already in the session were not reused: "
                      + ", ".join(f"{a} -> {b}" for a, b in r.renamed.items()), highlight=False)


def simulate(
    session: Path = typer.Argument(..., help="Session folder (planned or measured)."),
    seed: int = typer.Option(D.SIM_SEED, min=0, help="Seed of the virtual machine and of the "
                            "noise."),
    noise_um: float = typer.Option(D.SIM_NOISE_UM, help="Repeatability noise per reading [um]."),
    mirror_urad: float = typer.Option(D.SIM_MIRROR_URAD,
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
) -> None:
    """Fill the deviations from a virtual machine; keep its truth in SESSION/truth/.

    Refuses a session holding readings it did not write itself (measured or edited
    since), unless --overwrite is given; then the old files are kept in a backup.
    """
    from volcal.measure.simulate import SimulationOptions, simulate_session, truth_files
    from volcal.measure.virtual import ErrorRanges, random_machine
    from volcal.session.errortable import read_error_table
    from volcal.session.format import read_session, write_session
    from volcal.session.provenance import backup_name, measured_ids

    if not (np.isfinite(reversal_um) and reversal_um >= 0):
        raise VolcalInputError(f"--reversal-um {reversal_um}: expected a finite value >= 0")
    b = None
    if budget is not None:
        from volcal.uncertainty.budget import read_budget

        b = read_budget(budget)
    s = read_session(session, require_deviation=False)
    measured = measured_ids(s)
    if measured and not overwrite:
        shown = ", ".join(measured[:6]) + (f" and {len(measured) - 6} more"
                                           if len(measured) > 6 else "")
        raise VolcalInputError(
            f"holds readings that `volcal simulate` did not write ({shown}): simulating would "
            "overwrite them; nothing was changed. Use --overwrite to replace them (a backup is "
            "kept in backup/)", s.path / "session.toml" if s.path else session)
    if machine is not None:
        vm = read_error_table(machine, chain=s.chain)
        if not machine.with_suffix(".toml").is_file():
            console.print(f"[yellow]note:[/] no {machine.with_suffix('.toml').name} beside "
                          f"{machine.name}: squareness and reversal taken as zero",
                          highlight=False)
        if str(vm.chain) != s.chain:
            console.print(f"[yellow]note:[/] error table chain {vm.chain} differs from the "
                          f"session's {s.chain}; using the session's chain")
            vm.chain = s.chain
            vm.__post_init__()
    else:
        vm = random_machine(s.travel, s.chain, seed,
                            ranges=ErrorRanges(reversal_um=(0.0, reversal_um)),
                            name=f"virtual {s.name}")
    opts = SimulationOptions(noise_um=noise_um, mirror_misalignment_urad=mirror_urad,
                             drift_um_per_h=drift_um_per_h, seed=seed)
    setups = simulate_session(s, vm, opts)
    truth = truth_files(vm, setups, opts)
    if b is not None:
        from volcal.io.tomlfmt import dumps as toml_dumps
        from volcal.measure.systematic import apply_systematic, draw_systematic

        draw = draw_systematic(s, b, np.random.default_rng([seed, 17]))
        apply_systematic(s, draw)
        truth["truth/systematic.toml"] = toml_dumps({"format": "volcal-systematic/1",
                                                     "budget": str(budget), **draw.to_dict()})
    from volcal.session.provenance import simulated_provenance

    s.provenance = simulated_provenance(
        s, seed=seed, noise_um=float(noise_um), mirror_urad=float(mirror_urad),
        drift_um_per_h=float(drift_um_per_h),
        machine=str(machine) if machine is not None else f"random (seed {seed})")
    backup = backup_name(session) if measured else None
    write_session(s, session, truth, keep_existing=True, backup=backup)
    if backup is not None:
        console.print(f"replaced the readings of {len(measured)} measurements; the old files "
                      f"are kept in {Path(session) / backup}/", highlight=False)
    console.print(f"simulated {len(s.measurements)} measurements on '{vm.name}' "
                  f"(noise {noise_um} um, mirror {mirror_urad} urad"
                  + (f", systematic errors drawn from {budget}" if b is not None else "")
                  + f"); truth in {session}/truth/")


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
    app.command("plan")(plan)
    app.command("simulate")(simulate)
