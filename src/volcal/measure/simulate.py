"""Simulate a session on a virtual machine: exact readings, set-up errors, noise, drift.

The machine's truth (error table and every set-up error) is kept beside the session in
``truth/`` so that solvers can be checked against it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from volcal.errors import ParameterError, VolcalInputError
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.measure.readings import SetupErrors, perpendicular_basis, reading_exact
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import UM
from volcal.session.errortable import error_table_csv, error_table_toml
from volcal.session.format import DEVIATION_ABS_MAX_UM, Session

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
    """

    noise_um: float = 0.5
    mirror_misalignment_urad: float = 20.0
    beam_misalignment_urad: float = 0.0
    drift_um_per_h: float = 0.0
    dwell_s: float = 4.0
    reversal: bool = True
    seed: int | None = 0

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


def _random_perp(rng: np.random.Generator, n: np.ndarray, magnitude: float) -> np.ndarray:
    if magnitude == 0:
        return np.zeros(3)
    B = perpendicular_basis(n)
    phi = rng.uniform(0, 2 * np.pi)
    return magnitude * (np.cos(phi) * B[0] + np.sin(phi) * B[1])


def simulate_session(session: Session, machine: MachineErrors,
                     options: SimulationOptions | None = None,
                     tracker=None) -> dict[str, SetupErrors]:
    """Fill every measurement's deviations from the virtual machine, in place.

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
    dict of str to SetupErrors
        The set-up errors drawn for each measurement (part of the truth).
    """
    o = options or SimulationOptions()
    rng = np.random.default_rng(o.seed)
    setups = {}
    stations: dict = {}
    optics_shared: dict[str, float] = {}
    if any(m.kind in ("straightness", "angular") for m in session.measurements):
        from volcal.session.optics import annotate_references

        annotate_references(session.measurements, session.references)
    for m in session.measurements:
        if m.kind in ("straightness", "angular"):
            from volcal.measure.optics_simulate import simulate_optic

            setups[m.id] = simulate_optic(m, machine, rng, o.noise_um, o.dwell_s,
                                          o.drift_um_per_h, o.reversal, optics_shared)
            continue
        if m.kind == "multilateration":
            from volcal.measure.multilateration import simulate_tracker

            setups[m.id] = simulate_tracker(m, machine, rng, o.noise_um, o.dwell_s,
                                            o.drift_um_per_h, stations, tracker)
            continue
        setup = SetupErrors(
            mirror_tilt=_random_perp(rng, m.beam_direction, o.mirror_misalignment_urad)
            if m.target in ("flat_mirror", "retroreflector_mirror") else np.zeros(3),
            beam_tilt=_random_perp(rng, m.beam_direction, o.beam_misalignment_urad),
        )
        q_act = m.positions.copy()
        if o.reversal and m.direction is not None and m.kind == "linear":
            k = m.axis
            sign = np.where(m.direction == "+", 0.5, -0.5)
            q_act[:, k] += sign * machine.reversal[k] * UM
        dev = reading_exact(machine, m, setup, q_act)
        time_s = np.arange(m.n) * o.dwell_s
        dev = dev + o.drift_um_per_h * time_s / 3600.0
        if o.noise_um > 0:
            noise = rng.normal(0.0, o.noise_um, m.n)
            dev = dev + noise - noise[0]
        m.deviation = dev - dev[0]
        big = np.abs(m.deviation) > DEVIATION_ABS_MAX_UM
        if big.any():  # never write a file its own reader refuses
            where = (session.path / m.file) if session.path is not None else m.file
            raise VolcalInputError(
                f"simulated deviation {m.deviation[big][0]:.6g} um is absurd (> "
                f"{DEVIATION_ABS_MAX_UM:g} um): the poses of {m.id!r} do not run from the "
                "first row along its beam direction (rows out of order?)", where,
                int(np.argmax(big)) + 2, "x_mm")
        m.columns["time_s"] = time_s
        m.columns.pop("status", None)  # every row now has a reading (no missed capture)
        setups[m.id] = setup
    return setups


def truth_files(machine: MachineErrors, setups: dict[str, SetupErrors],
                options: SimulationOptions) -> dict[str, str]:
    """Text files of the simulation truth, to be written in ``SESSION/truth/``.

    Parameters
    ----------
    machine : MachineErrors
        The virtual machine.
    setups : dict of str to SetupErrors
        Set-up errors per measurement.
    options : SimulationOptions
        The simulation options.

    Returns
    -------
    dict of str to str
        Relative path -> content.
    """
    doc = {
        "format": "volcal-truth/1",
        "noise_um": o_float(options.noise_um),
        "mirror_misalignment_urad": o_float(options.mirror_misalignment_urad),
        "beam_misalignment_urad": o_float(options.beam_misalignment_urad),
        "drift_um_per_h": o_float(options.drift_um_per_h),
        "seed": -1 if options.seed is None else int(options.seed),
        "setup": {mid: {"mirror_tilt_urad": [float(v) for v in s.mirror_tilt],
                        "beam_tilt_urad": [float(v) for v in s.beam_tilt],
                        **({"station_mm": [float(v) for v in s.station_mm]}
                           if hasattr(s, "station_mm") else {}),
                        **({"reference_urad": {k: float(v) for k, v in s.nuisances.items()},
                            "direction_tilt_urad": [float(v) for v in s.direction_tilt]}
                           if hasattr(s, "nuisances") else {})}
                  for mid, s in setups.items()},
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
