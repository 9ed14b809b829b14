"""Simulate a session on a virtual machine: exact readings, set-up errors, noise, drift.

The machine's truth (error table and every set-up error) is kept beside the session in
``truth/`` so that solvers can be checked against it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from volcal.errors import ParameterError
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.measure.readings import SetupErrors
from volcal.model.errorfunctions import MachineErrors
from volcal.session.errortable import error_table_csv, error_table_toml
from volcal.session.format import Session
from volcal.session.kinds import kind_of, kinds

if TYPE_CHECKING:
    from volcal.measure.optics import OpticSetup

__all__ = ["SimulationOptions", "simulate_session", "truth_files"]


@dataclass(frozen=True)
class SimulationOptions:
    """How a session is simulated.

    Attributes
    ----------
    noise_um : float
        Standard deviation of the repeatability noise of each reading [um].
    mirror_misalignment_urad : float
        Magnitude of the residual mirror misalignment after alignment to the beam [urad]
        (random direction perpendicular to the beam, flat-mirror tests).
    beam_misalignment_urad : float
        Residual beam misalignment after alignment to the actual motion [urad].
    drift_um_per_h : float
        Linear drift of the readings (thermal, say) [um/h].
    dwell_s : float
        Time between readings [s] (fills the ``time_s`` column).
    reversal : bool
        Apply the machine's reversal to readings approached in the negative direction.
    seed : int, optional
        Seed of the noise and set-up errors.
    axis_correction_um : callable, optional
        A controller's correction of the commanded positions active (a 3-D grid of
        vectors, :meth:`volcal.compensate.readback.WrittenTables.correction`): commanded
        positions ``(m, 3)`` [mm] -> the error it removes there ``(m, 3)`` [um]; the axes
        go that much less far, so the tool point's error left is the machine's error at
        the shifted position minus it. Laser tests only (:mod:`volcal.kinds.laser`).
    """

    noise_um: float = 0.5
    mirror_misalignment_urad: float = 20.0
    beam_misalignment_urad: float = 0.0
    drift_um_per_h: float = 0.0
    dwell_s: float = 4.0
    reversal: bool = True
    seed: int | None = 0
    axis_correction_um: Callable[[Any], Any] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        """Reject values no simulation can use (negative, NaN, infinite)."""
        for option, v in (("{noise_um=}", self.noise_um),
                          ("{mirror_misalignment_urad=}", self.mirror_misalignment_urad),
                          ("beam misalignment ", self.beam_misalignment_urad),
                          ("{drift_um_per_h=}", self.drift_um_per_h), ("dwell ", self.dwell_s)):
            if not np.isfinite(v):
                raise ParameterError(f"{option}{v}: expected a finite number")
            if option != "{drift_um_per_h=}" and v < 0:
                raise ParameterError(f"{option}{v}: must not be negative")
        if self.seed is not None and self.seed < 0:
            raise ParameterError(f"{{seed=}}{self.seed}: must not be negative")


def simulate_session(session: Session, machine: MachineErrors,
                     options: SimulationOptions | None = None,
                     tracker=None) -> dict[str, SetupErrors | OpticSetup | None]:
    """Fill every measurement's deviations from the virtual machine, in place.

    Each measurement is simulated by its kind (:meth:`volcal.kinds.Kind.simulate`), in
    the session's order, from one random generator.

    Parameters
    ----------
    session : Session
        Planned session (deviations may be empty); modified in place.
    machine : MachineErrors
        The virtual machine (truth).
    options : SimulationOptions, optional
        Noise and set-up errors.
    tracker : volcal.measure.multilateration.TrackerOptions, optional
        The virtual tracking interferometer of multilateration measurements (station
        set-up error, length noise); ``options.noise_um`` is then the machine's
        repeatability per coordinate of the tool point.

    Returns
    -------
    dict of str to SetupErrors, OpticSetup or None
        The set-up errors drawn for each measurement (part of the truth; OpticSetup of a
        direct optic, None where the kind has none).
    """
    o = options or SimulationOptions()
    rng = np.random.default_rng(o.seed)
    setups: dict[str, SetupErrors | OpticSetup | None] = {}
    shared: dict[str, Any] = {"stations": {}, "optics": {}, "tracker": tracker,
                              "path": session.path}
    present = {m.kind for m in session.measurements}
    for k in kinds():  # once per kind present (the optics group their reference lines)
        if k.name in present:
            k.prepare(session)
    for m in session.measurements:
        setups[m.id] = kind_of(m.kind).simulate(m, machine, rng, o, shared)
    return setups


def truth_files(machine: MachineErrors, setups: dict[str, SetupErrors | OpticSetup | None],
                options: SimulationOptions) -> dict[str, str]:
    """Text files of the simulation truth, to be written in ``SESSION/truth/``.

    Parameters
    ----------
    machine : MachineErrors
        The virtual machine.
    setups : dict of str to SetupErrors, OpticSetup or None
        Set-up errors per measurement (OpticSetup of a direct optic, None: no set-up).
    options : SimulationOptions
        The simulation options.

    Returns
    -------
    dict of str to str
        Relative path -> content.
    """
    from volcal.measure.optics import OpticSetup

    doc = {
        "format": "volcal-truth/1",
        "noise_um": o_float(options.noise_um),
        "mirror_misalignment_urad": o_float(options.mirror_misalignment_urad),
        "beam_misalignment_urad": o_float(options.beam_misalignment_urad),
        "drift_um_per_h": o_float(options.drift_um_per_h),
        "seed": -1 if options.seed is None else int(options.seed),
        "setup": {mid: s.to_truth() if hasattr(s, "to_truth") else  # a kind's own set-up
                  {"mirror_tilt_urad": [float(v) for v in s.mirror_tilt],
                        "beam_tilt_urad": [float(v) for v in s.beam_tilt],
                        **({"station_mm": [float(v) for v in s.station_mm]}
                           if hasattr(s, "station_mm") else {}),
                        **({"reference_urad": {k: float(v) for k, v in s.nuisances.items()},
                            "direction_tilt_urad": [float(v) for v in s.direction_tilt]}
                           if isinstance(s, OpticSetup) else {})}
                  for mid, s in setups.items() if s is not None},  # None: no set-up
    }
    return {
        "truth/machine.csv": error_table_csv(machine),
        "truth/machine.toml": error_table_toml(machine),
        "truth/setup.toml": toml_dumps(doc),
    }


def o_float(v: float) -> float:
    """Plain float for TOML.

    Parameters
    ----------
    v : float
        A number, possibly a numpy scalar, which ``tomli_w`` cannot write.

    Returns
    -------
    float
    """
    return float(v)
