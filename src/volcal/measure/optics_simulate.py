"""Simulated direct-optics readings: exact model, set-up errors, noise of realistic size.

Used by :func:`volcal.measure.simulate.simulate_session` for the ``straightness`` and
``angular`` kinds. Each measurement gets (``docs/formats.md``, "Direct optics"):

* a reference set-up: a line of its own a slope of :data:`REFERENCE_SLOPE_URAD` (one
  standard deviation), a reference group one rotation of :data:`REFERENCE_SLOPE_URAD` per
  component shared by its lines, and an optical square its true deviation, drawn from
  its certificate (``square_deviation_urad`` +- ``u_square_urad``);
* a misalignment of the optic's sensitive direction of :data:`DIRECTION_TILT_URAD`
  (perpendicular to it, random azimuth);
* noise: ``NOMINAL_NOISE[target]`` (straightness 0.5 um, angular optics 0.2 urad, level
  and roll optics 1 urad) times ``noise_um / 0.5`` (the simulation's displacement noise
  relative to its default), plus 1 % of the reading for straightness.
"""

from __future__ import annotations

import numpy as np

from volcal.measure.optics import NOMINAL_NOISE, OpticSetup, optic_direction, optic_exact
from volcal.measure.readings import perpendicular_basis
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import UM
from volcal.session.format import Measurement

__all__ = ["DIRECTION_TILT_URAD", "REFERENCE_SLOPE_URAD", "STRAIGHTNESS_GAIN_NOISE",
           "simulate_optic"]

REFERENCE_SLOPE_URAD = 50.0
"""Standard deviation of a reference optic's set-up slope or rotation [urad] (a straight
line aligned to 0.05 mm over a metre)."""
DIRECTION_TILT_URAD = 1000.0
"""Misalignment of an optic's sensitive direction or axis [urad] (1 mrad, 0.06 degree)."""
STRAIGHTNESS_GAIN_NOISE = 0.01
"""Reading-proportional noise of straightness optics (1 % of the reading, one standard
deviation) [-]."""


def simulate_optic(m: Measurement, machine: MachineErrors, rng: np.random.Generator,
                   noise_um: float, dwell_s: float, drift_um_per_h: float, reversal: bool,
                   shared: dict[str, float]) -> OpticSetup:
    """Fill one straightness or angular measurement's readings, in place.

    Parameters
    ----------
    m : Measurement
        The measurement (``meta['_reference']`` set by
        :func:`volcal.session.optics.annotate_references`).
    machine : MachineErrors
        The virtual machine.
    rng : numpy.random.Generator
        Random source.
    noise_um : float
        The simulation's displacement noise [um]; the optic's noise scales with
        ``noise_um / 0.5``.
    dwell_s : float
        Time between readings [s].
    drift_um_per_h : float
        Drift of straightness readings [um/h].
    reversal : bool
        Apply the machine's reversal to rows approached in the negative direction.
    shared : dict of str to float
        Reference nuisances already drawn (a group's rotation and square), updated.

    Returns
    -------
    OpticSetup
        The set-up errors drawn (simulation truth).
    """
    from volcal.measure.optics import reference_columns

    nuis: dict[str, float] = {}
    for name in reference_columns(m):
        if name not in shared:
            if name.endswith(":square"):
                ref = m.meta["_reference"]
                shared[name] = float(rng.normal(ref["square_deviation_urad"],
                                                ref["u_square_urad"]))
            else:
                shared[name] = float(rng.normal(0.0, REFERENCE_SLOPE_URAD))
        nuis[name] = shared[name]
    B = perpendicular_basis(optic_direction(m))
    phi = rng.uniform(0, 2 * np.pi)
    setup = OpticSetup(nuisances=nuis,
                       direction_tilt=DIRECTION_TILT_URAD * (np.cos(phi) * B[0]
                                                             + np.sin(phi) * B[1]))
    q_act = m.positions.copy()
    if reversal and m.direction is not None and m.axis is not None:
        q_act[:, m.axis] += np.where(m.direction == "+", 0.5, -0.5) * machine.reversal[m.axis] * UM
    dev = optic_exact(machine, m, setup, q_act)
    time_s = np.arange(m.n) * dwell_s
    scale = noise_um / 0.5
    sd = np.full(m.n, NOMINAL_NOISE[m.target] * scale)
    if m.kind == "straightness":
        dev = dev + drift_um_per_h * time_s / 3600.0
        sd = np.hypot(sd, STRAIGHTNESS_GAIN_NOISE * np.abs(dev) * (scale > 0))
    if scale > 0:
        noise = rng.normal(0.0, 1.0, m.n) * sd
        dev = dev + noise - noise[0]
    dev = dev - dev[0]
    if m.meta.get("slope_removed"):
        u = m.positions[:, m.axis] - m.positions[0, m.axis]
        G = np.column_stack([np.ones(m.n), u])
        dev = dev - G @ np.linalg.lstsq(G, dev, rcond=None)[0]
    m.deviation = dev
    m.columns["time_s"] = time_s
    m.columns.pop("status", None)
    return setup
