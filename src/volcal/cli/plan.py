"""``volcal plan`` and ``volcal simulate``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.console import Console

from volcal.cli._common import parse_travel, parse_vector
from volcal.errors import VolcalInputError

console = Console(soft_wrap=True)  # no line breaks inside paths


def _unmeasured_session(folder: Path) -> bool:
    """True for a planned session without any reading (safe to plan again)."""
    from volcal.session.format import read_session

    try:
        s = read_session(folder, require_deviation=False)
    except VolcalInputError:
        return False
    return all(m.deviation is None for m in s.measurements)


def plan(
    travel: str = typer.Option("0:800,0:600,0:500", help="Travel limits x,y,z as min:max [mm]."),
    chain: str = typer.Option("XYFZ", help="Kinematic chain from workpiece to tool, F = frame."),
    steps: int = typer.Option(10, help="Increments per test."),
    tests: str = typer.Option("step-diagonal,diagonal,linear",
                              help="Comma-separated: step-diagonal, diagonal, linear, "
                              "face-diagonal, face-step-diagonal, multilateration, direct "
                              "(direct optics: straightness, angular, level, optical "
                              "squares; docs/formats.md)."),
    runs: int = typer.Option(5, help="Bidirectional runs per linear test (ISO 230-2)."),
    step_orders: str = typer.Option("xyz", help="Axis orders of the step diagonals, e.g. xyz,yxz."),
    tool_offset: str = typer.Option("0,0,0", help="Target point on the tool x,y,z [mm]."),
    name: str = typer.Option("VMC-1", help="Machine name."),
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
    output: Path = typer.Option(..., "-o", "--output", help="Session folder to write."),
) -> None:
    """Write a session skeleton: the commanded poses of every test, deviations empty."""
    from volcal.io.paths import check_output_folder
    from volcal.plan.planner import plan_session
    from volcal.session.format import write_session

    check_output_folder(output, "planned session", _unmeasured_session)
    s = plan_session(parse_travel(travel), chain, steps,
                     [t.strip() for t in tests.split(",") if t.strip()], runs,
                     [o.strip() for o in step_orders.split(",") if o.strip()],
                     parse_vector(tool_offset, "--tool-offset"), name,
                     step_target=step_target,
                     iso_spacing=iso_spacing, linear_margin_mm=overrun_mm,
                     abbe_tool_offset_mm=abbe_offset_mm,
                     multilateration=_multilateration_options(grid, stations, tool_offsets))
    write_session(s, output, keep_existing=True)  # a re-plan keeps the folder's other files
    n = sum(m.n for m in s.measurements)
    console.print(f"planned {len(s.measurements)} measurements, {n} readings -> {output}")


def simulate(
    session: Path = typer.Argument(..., help="Session folder (planned or measured)."),
    seed: int = typer.Option(0, min=0, help="Seed of the virtual machine and of the noise."),
    noise_um: float = typer.Option(0.5, help="Repeatability noise per reading [um]."),
    mirror_urad: float = typer.Option(20.0, help="Residual mirror misalignment [urad]."),
    drift_um_per_h: float = typer.Option(0.0, help="Linear drift of the readings [um/h]."),
    machine: Path | None = typer.Option(None, help="Error table ERRORS.csv (default: random)."),
    reversal_um: float = typer.Option(0.0, help="Max reversal of a random machine's axes [um]."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Replace readings that "
                                   "`volcal simulate` did not write (measured ones); a backup "
                                   "of the replaced files is kept in SESSION/backup/<time>/."),
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
    from volcal.session.provenance import simulated_provenance

    s.provenance = simulated_provenance(
        s, seed=seed, noise_um=float(noise_um), mirror_urad=float(mirror_urad),
        drift_um_per_h=float(drift_um_per_h),
        machine=str(machine) if machine is not None else f"random (seed {seed})")
    backup = backup_name(session) if measured else None
    write_session(s, session, truth_files(vm, setups, opts), keep_existing=True, backup=backup)
    if backup is not None:
        console.print(f"replaced the readings of {len(measured)} measurements; the old files "
                      f"are kept in {Path(session) / backup}/", highlight=False)
    console.print(f"simulated {len(s.measurements)} measurements on '{vm.name}' "
                  f"(noise {noise_um} um, mirror {mirror_urad} urad); truth in {session}/truth/")


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
