"""Step ``simulate``: readings from a virtual machine, its truth kept (``volcal simulate``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from volcal import defaults as D
from volcal.errors import ParameterError, VolcalInputError
from volcal.steps import _checks

if TYPE_CHECKING:
    from volcal.measure.optics import OpticSetup
    from volcal.measure.simulate import SetupErrors, SimulationOptions
    from volcal.measure.systematic import SystematicDraw
    from volcal.model.errorfunctions import MachineErrors
    from volcal.session.format import Session
    from volcal.uncertainty.budget import Budget

__all__ = ["Simulated", "save", "simulate"]


@dataclass(frozen=True)
class Simulated:
    """What :func:`simulate` did to the session (in memory; :func:`save` writes it).

    Attributes
    ----------
    session : Session
        The session, its readings filled (the same object as given).
    machine : MachineErrors
        The virtual machine (the truth).
    setups : dict
        Measurement id -> its simulated set-up errors.
    options : SimulationOptions
        Noise, misalignment, drift and seed.
    systematic : SystematicDraw or None
        The budget's systematic errors drawn and applied.
    budget : str or None
        The budget as given (recorded in ``truth/systematic.toml``).
    replaced : tuple of str
        Ids of the measured readings replaced (``overwrite=True``).
    notes : tuple of str
        What the user should know (an error table without its ``.toml``...).
    compensation : dict or None
        With compensation tables: their folder, format, sign and the machine as found
        (recorded in ``truth/compensation.toml``); ``machine`` is then the machine with
        the tables active, except for a 3-D grid (``grid = true``): one correction of the
        commanded positions over the work zone, no set of error functions, so
        ``machine`` stays the machine as found and the controller's shift is applied to
        the laser tests' positions (:attr:`SimulationOptions.axis_correction_um`).
    """

    session: Session
    machine: MachineErrors
    setups: dict[str, SetupErrors | OpticSetup | None]
    options: SimulationOptions
    systematic: SystematicDraw | None = None
    budget: str | None = None
    replaced: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    compensation: dict[str, Any] | None = None

    def truth_files(self) -> dict[str, str]:
        """The files of ``truth/`` (relative path -> text), the systematic draw included."""
        from volcal.measure.simulate import truth_files

        out = truth_files(self.machine, self.setups, self.options)
        if self.systematic is not None:
            from volcal.io.tomlfmt import dumps as toml_dumps

            out["truth/systematic.toml"] = toml_dumps({"format": "volcal-systematic/1",
                                                       "budget": self.budget,
                                                       **self.systematic.to_dict()})
        if self.compensation is not None:
            from volcal.io.tomlfmt import dumps as toml_dumps

            out["truth/compensation.toml"] = toml_dumps(
                {"format": "volcal-simulated-compensation/1", **self.compensation})
        return out


def simulate(session: Session | str | Path, *,
             machine: MachineErrors | str | Path | None = None, seed: int = D.SIM_SEED,
             noise_um: float = D.SIM_NOISE_UM,
             mirror_misalignment_urad: float = D.SIM_MIRROR_URAD,
             drift_um_per_h: float = D.SIM_DRIFT_UM_PER_H,
             reversal_um: float = D.SIM_REVERSAL_UM,
             budget: str | Path | Budget | None = None, overwrite: bool = False,
             compensation: str | Path | None = None, force: bool = False) -> Simulated:
    """Fill the readings of a session from a virtual machine.

    Parameters
    ----------
    session : Session, str or Path
        A planned or measured session, or its folder (read with every measurement).
    machine : MachineErrors, str or Path, optional
        The virtual machine, or its error table (``ERRORS.csv``, with ``ERRORS.toml``
        beside it for the squareness and reversal); a random realistic one (seeded) when
        omitted.
    seed : int
        Seed of the random machine and of the noise (>= 0).
    noise_um : float
        Reading noise, standard deviation [um].
    mirror_misalignment_urad : float
        Residual set-up misalignment of the optics, standard deviation [urad].
    drift_um_per_h : float
        Linear drift of the readings [um/h].
    reversal_um : float
        Largest reversal of a random machine's axes [um] (not used with ``machine``).
    budget : str, Path or Budget, optional
        Uncertainty budget: its systematic errors (wavelength, air per set-up, material
        per axis, the scale of each direct optic) drawn once (seeded by ``seed``) and
        applied to the readings.
    overwrite : bool
        Replace readings that a simulation did not write (measured ones); refused
        otherwise.
    compensation : str or Path, optional
        Folder written by ``volcal compensate``: the machine runs with these tables
        active (:func:`volcal.compensate.applied.compensated_machine`), the as-left
        measurement of a virtual machine; ``machine`` is the machine as found (its error
        table ``FOUND/truth/machine.csv``, or the same ``seed`` as the as-found
        simulation). ``truth/`` then holds the machine with the tables active and
        ``truth/compensation.toml``.
    force : bool
        With ``compensation``: apply tables written for another machine (a note instead
        of the refusal).

    Returns
    -------
    Simulated
    """
    from volcal.measure.simulate import SimulationOptions, simulate_session
    from volcal.measure.virtual import ErrorRanges, random_machine
    from volcal.model.errorfunctions import MachineErrors
    from volcal.session.provenance import measured_ids, simulated_provenance

    if not (np.isfinite(reversal_um) and reversal_um >= 0):
        raise ParameterError(f"{{reversal_um=}}{reversal_um}: expected a finite value >= 0")
    if _checks.whole("seed", seed) < 0:
        raise ParameterError(f"{{seed=}}{seed!r}: expected a whole number >= 0")
    if machine is not None and not isinstance(machine, MachineErrors | str | Path):
        raise ParameterError(f"{{machine=}} is a {type(machine).__name__}: expected "
                             "MachineErrors (volcal.session.errortable.read_error_table), "
                             "the path of an error table, or None")
    b = None if budget is None else _checks.budget(budget)
    s = session
    if isinstance(s, str | Path):
        from volcal.session.format import read_session

        if not (Path(s) / "session.toml").is_file() and not Path(s).is_file():
            raise VolcalInputError(
                "no planned session here (no session.toml): `volcal simulate` fills the "
                f"readings of a plan; plan it first (volcal plan -o {s} ...)", s)
        s = read_session(s, require_deviation=False)
    measured = measured_ids(s)
    if measured and not overwrite:
        shown = ", ".join(measured[:6]) + (f" and {len(measured) - 6} more"
                                           if len(measured) > 6 else "")
        raise ParameterError(
            f"holds readings that `volcal simulate` did not write ({shown}): simulating would "
            "overwrite them; nothing was changed. Use {overwrite=True} to replace them (a "
            "backup is kept in backup/)", s.path / "session.toml" if s.path else None)
    notes: list[str] = []
    if isinstance(machine, str | Path):
        vm, label = _error_table(Path(machine), s, notes), str(machine)
    elif machine is not None:
        vm = machine
        label = (f"random (seed {seed})" if machine.name == f"virtual {s.name}"
                 else str(machine.name))
    else:
        vm = random_machine(s.travel, s.chain, seed,
                            ranges=ErrorRanges(reversal_um=(0.0, reversal_um)),
                            name=f"virtual {s.name}")
        label = f"random (seed {seed})"
    applied = shift = None
    if compensation is not None:
        vm, applied, shift = _with_tables(vm, Path(compensation), s, force, notes)
        label += f", tables of {compensation} active"
    opts = SimulationOptions(noise_um=noise_um, mirror_misalignment_urad=mirror_misalignment_urad,
                             drift_um_per_h=drift_um_per_h, seed=seed, axis_correction_um=shift)
    setups = simulate_session(s, vm, opts)
    draw = None
    if b is not None:
        from volcal.measure.systematic import apply_systematic, draw_systematic

        draw = draw_systematic(s, b[0], np.random.default_rng([int(seed), 17]))
        apply_systematic(s, draw)
    s.provenance = simulated_provenance(
        s, seed=int(seed), noise_um=float(noise_um), mirror_urad=float(mirror_misalignment_urad),
        drift_um_per_h=float(drift_um_per_h), machine=label,
        **({} if applied is None else {"compensation": applied["folder"]}))
    return Simulated(s, vm, setups, opts, draw, None if b is None else b[1],
                     tuple(measured), tuple(notes), applied)


def _with_tables(vm: MachineErrors, folder: Path, s: Session, force: bool, notes: list[str]
                 ) -> tuple[MachineErrors, dict[str, Any], Any]:
    """The virtual machine with the tables of ``folder`` active, and their record.

    The third value is a 3-D grid's correction of the commanded positions; None for the
    other tables, which :func:`volcal.compensate.applied.compensated_machine` folds into
    the functions.
    """
    from volcal.compensate.applied import compensated_machine
    from volcal.compensate.manifest import check_manifest, read_manifest
    from volcal.compensate.readback import read_written_tables
    from volcal.session.identity import MachineIdentity

    if not folder.is_dir():
        raise ParameterError(f"{{compensation=}}{folder}: not a folder (the tables that "
                             "`volcal compensate` wrote)")
    manifest = read_manifest(folder)
    notes += check_manifest(manifest, folder, MachineIdentity.of(s), None, force,
                            "the virtual machine")
    tables = read_written_tables(folder, manifest, s.travel)
    record = {"folder": str(folder), "controller_format": tables.controller_format,
              "sign": str(manifest.get("sign", "error")),
              "bidirectional": tables.reverse is not None, "files": list(tables.files),
              "as_found_machine": vm.name,
              "note": "truth/machine.csv is the machine with these tables active"}
    if tables.grid_axes is None:
        return compensated_machine(vm, tables), record, None
    from volcal.kinds.laser import LaserKind
    from volcal.session.kinds import kind_of

    other = [f"{m.id} ({m.kind})" for m in s.measurements
             if not isinstance(kind_of(m.kind), LaserKind)]
    if other:
        raise VolcalInputError(
            f"{tables.controller_format} tables: a 3-D grid of correction vectors shifts the "
            "commanded positions; volcal applies it to the laser tests (linear, diagonal, "
            f"step diagonal) and not to {', '.join(other[:4])}"
            + (f" and {len(other) - 4} more" if len(other) > 4 else "")
            + ": simulate those without --compensation", folder)
    record.update(grid=True, note="truth/machine.csv is the machine as found: the 3-D grid "
                  "is the controller's correction of the commanded positions (interpolated "
                  "trilinearly, held constant outside), not a change of the error functions; "
                  "the as-left machine has no error table (reports show no truth)")
    return vm, record, tables.correction


def _error_table(path: Path, s: Session, notes: list[str]) -> MachineErrors:
    """The virtual machine of an error table, on the session's chain."""
    from volcal.session.errortable import read_error_table

    vm = read_error_table(path, chain=s.chain)
    if not path.with_suffix(".toml").is_file():
        notes.append(f"no {path.with_suffix('.toml').name} beside {path.name}: squareness "
                     "and reversal taken as zero")
    if str(vm.chain) != s.chain:
        notes.append(f"error table chain {vm.chain} differs from the session's {s.chain}; "
                     "using the session's chain")
        vm.chain = s.chain
        vm.__post_init__()
    return vm


def save(simulated: Simulated, folder: str | Path) -> Path | None:
    """Write the simulated session and its ``truth/`` into its folder.

    Parameters
    ----------
    simulated : Simulated
    folder : str or Path
        The session folder; the files of replaced measured readings are kept in
        ``backup/<UTC time>/``.

    Returns
    -------
    Path or None
        The backup folder, when measured readings were replaced.
    """
    from volcal.session.format import write_session
    from volcal.session.provenance import backup_name

    backup = backup_name(folder) if simulated.replaced else None
    write_session(simulated.session, folder, simulated.truth_files(), keep_existing=True,
                  backup=backup)
    return None if backup is None else Path(folder) / backup
