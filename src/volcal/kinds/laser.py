"""The laser readings along a beam: what the linear, diagonal and step-diagonal kinds share.

A retroreflector or a flat mirror on the tool, the laser reading the change of optical path
along the beam (:mod:`volcal.measure.readings`, Soons eq. 2-4); set-up nuisances: a reading
offset, the beam and mirror tilts where visible, a drift where separable
(:func:`volcal.identify.design.laser_rows`).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.session.kinds import Kind, ReadContext, RowBlock

__all__ = ["LaserKind", "simulate_laser"]


class LaserKind(Kind):
    """A laser interferometer reading along a beam (``deviation_um`` [um])."""

    targets: ClassVar[tuple[str, ...]] = ("flat_mirror", "retroreflector",
                                          "retroreflector_mirror")
    default_target: ClassVar[str | None] = "retroreflector"
    systematic: ClassVar[str | None] = "length"
    raw_readings: ClassVar[bool] = True
    referable: ClassVar[bool] = True

    def read(self, entry: dict[str, Any], ctx: ReadContext) -> Any:
        """Read the entry and its CSV (:func:`volcal.session.format.read_laser_entry`).

        Parameters
        ----------
        entry : dict
            The ``[[measurements]]`` entry as parsed.
        ctx : ReadContext
            Its checked keys and the session's context.
        """
        from volcal.session.format import read_laser_entry

        return read_laser_entry(entry, ctx)

    def exact(self, machine: Any, m: Any, setup: Any = None,
              q_actual: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Exact deviations [um] (:func:`volcal.measure.readings.reading_exact`).

        Parameters
        ----------
        machine : MachineErrors
            The (virtual) machine.
        m : Measurement
            The measurement.
        setup : object, optional
            Set-up errors drawn by :meth:`simulate`; None: a perfect set-up.
        q_actual : ndarray, shape (n, 3), optional
            Axis positions actually reached [mm]; default the commanded ones.
        """
        from volcal.measure.readings import reading_exact

        return reading_exact(machine, m, setup, q_actual)

    def rows(self, chain_order: Any, nodes: Any, m: Any, *, drift: bool = False,
             tilts: bool = True) -> RowBlock:
        """Rows, offset, visible tilts, reversal and drift (:func:`laser_rows`).

        Parameters
        ----------
        chain_order : sequence of int
            ``Chain.order``.
        nodes : list of 3 arrays
            Node positions per axis [mm].
        m : Measurement
            The measurement.
        drift : bool
            Add a drift nuisance where it is separable from the geometry.
        tilts : bool
            Add the set-up tilt nuisances where the kind has them.
        """
        from volcal.identify.design import laser_rows

        return RowBlock(*laser_rows(chain_order, nodes, m, drift, tilts))

    def simulate(self, m: Any, machine: Any, rng: np.random.Generator, options: Any,
                 shared: dict[str, Any]) -> Any:
        """Simulated readings with mirror and beam tilts, reversal, drift, noise.

        Parameters
        ----------
        m : Measurement
            The measurement.
        machine : MachineErrors
            The (virtual) machine.
        rng : numpy.random.Generator
            The simulation's random generator.
        options : SimulationOptions
            Noise, misalignments, drift, dwell.
        shared : dict
            State shared by the measurements of one simulation.
        """
        return simulate_laser(self, m, machine, rng, options, shared.get("path"))


def _random_perp(rng: np.random.Generator, n: np.ndarray, magnitude: float) -> np.ndarray:
    from volcal.measure.readings import perpendicular_basis

    if magnitude == 0:
        return np.zeros(3)
    B = perpendicular_basis(n)
    phi = rng.uniform(0, 2 * np.pi)
    return magnitude * (np.cos(phi) * B[0] + np.sin(phi) * B[1])


def simulate_laser(kind: LaserKind, m: Any, machine: Any, rng: np.random.Generator, o: Any,
                   path: Any = None) -> Any:
    """Fill a laser measurement's deviations from the virtual machine, in place.

    Parameters
    ----------
    kind : LaserKind
        The measurement's kind (its :attr:`~volcal.kinds.Kind.bidirectional` readings get
        the machine's reversal).
    m : Measurement
        Planned measurement.
    machine : MachineErrors
        The virtual machine.
    rng : numpy.random.Generator
        Random source (the draws in the documented order: mirror tilt, beam tilt, noise).
    o : SimulationOptions
        Noise, misalignments, drift, dwell, reversal, a controller's grid correction.
    path : Path, optional
        Session folder, for the message of an absurd reading.

    Returns
    -------
    SetupErrors
    """
    from volcal.measure.readings import SetupErrors
    from volcal.model.kinematics import UM
    from volcal.session.format import DEVIATION_ABS_MAX_UM

    setup = SetupErrors(
        mirror_tilt=_random_perp(rng, m.beam_direction, o.mirror_misalignment_urad)
        if m.target in ("flat_mirror", "retroreflector_mirror") else np.zeros(3),
        beam_tilt=_random_perp(rng, m.beam_direction, o.beam_misalignment_urad),
    )
    q_act = m.positions.copy()
    if o.reversal and m.direction is not None and kind.bidirectional:
        k = m.axis
        sign = np.where(m.direction == "+", 0.5, -0.5)
        q_act[:, k] += sign * machine.reversal[k] * UM
    if o.axis_correction_um is not None:  # a 3-D grid active: the controller's shift
        q_act -= np.asarray(o.axis_correction_um(m.positions), dtype=float) * UM
    dev = kind.exact(machine, m, setup, q_act)
    time_s = np.arange(m.n) * o.dwell_s
    dev = dev + o.drift_um_per_h * time_s / 3600.0
    if o.noise_um > 0:
        noise = rng.normal(0.0, o.noise_um, m.n)
        dev = dev + noise - noise[0]
    m.deviation = dev - dev[0]
    big = np.abs(m.deviation) > DEVIATION_ABS_MAX_UM
    if big.any():  # never write a file its own reader refuses
        where = (path / m.file) if path is not None else m.file
        raise VolcalInputError(
            f"simulated deviation {m.deviation[big][0]:.6g} um is absurd (> "
            f"{DEVIATION_ABS_MAX_UM:g} um): the poses of {m.id!r} do not run from the "
            "first row along its beam direction (rows out of order?)", where,
            int(np.argmax(big)) + 2, "x_mm")
    m.columns["time_s"] = time_s
    m.columns.pop("status", None)  # every row now has a reading (no missed capture)
    # the virtual machine is at 20 degC: its readings are referred, as a laser program's
    # with material compensation on (a stale "false" would refer them a second time)
    m.meta["referred_to_20c"] = True
    m.meta.pop("referral", None)
    return setup
