"""The rotary axis the simulated laser reads: the virtual axis ``volcal simulate`` draws.

A rotary test's truth is not in the machine's error table: ``volcal simulate --seed S``
draws each rotary axis (:func:`volcal.measure.rotary.random_rotary_axis`) and the
calibrator's mounting from the simulation's random generator, in the session's order
(:meth:`volcal.kinds.rotary.RotaryKind.simulate`), and writes them in
``truth/setup.toml``. The simulated laser (``--laser sim:seed=S``) runs that simulation on
a copy of the session with ``volcal simulate``'s default options, so that it reads the
same axis: a capture of the rotary test reproduces ``volcal simulate``'s truth, as a
capture of a linear test reproduces its machine (``truth/machine.csv``).

The reading is the angular interferometer's on the rotary calibrator: the axis' angular
positioning error (actual - commanded angle) at the control's actual angle, approached
in the direction of the axis' last turn (the reversal of a ``'-'`` approach), plus the
eccentric mounting's term, counted from the first target (the calibrator zeroed there)
[urad] (:func:`volcal.measure.rotary.rotary_exact`).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

from volcal import defaults as D

__all__ = ["RotaryTruth", "rotary_truths", "simulated_setups"]


@dataclass(frozen=True)
class RotaryTruth:
    """What the calibrator of one rotary test reads (module docstring).

    Attributes
    ----------
    setup : RotarySetup
        The axis' errors and the mounting (:class:`volcal.measure.rotary.RotarySetup`).
    reference_urad : float
        The reading at the first target in its direction (the calibrator's zero) [urad].
    """

    setup: Any
    reference_urad: float

    def reading(self, angle_deg: float, direction: str) -> float:
        """The calibrator's reading at an actual angle [urad].

        Parameters
        ----------
        angle_deg : float
            The axis' actual angle [deg] (a full-circle axis: any turn of it).
        direction : str
            ``'+'`` or ``'-'``: the direction of the axis' last turn.

        Returns
        -------
        float
            Error at that angle minus the error at the first target [urad].
        """
        return _error(self.setup, angle_deg, direction) - self.reference_urad


def _error(setup: Any, angle_deg: float, direction: str) -> float:
    from volcal.measure.rotary import rotary_error_urad

    e = setup.axis
    a = float(angle_deg)
    if e.modulo:  # one turn of the circle: the error is periodic (zero smooth term at the ends)
        a = e.range_deg[0] + (a - e.range_deg[0]) % 360.0
    v = rotary_error_urad(e, [a], [direction]) + setup.mounting_urad([a])
    return float(v[0])


def _is_rotary(m: Any) -> bool:
    return "target_deg" in m.columns and m.meta.get("axis") in ("a", "b", "c")


def rotary_truths(session: Any, machine: Any, seed: int) -> dict[str, RotaryTruth]:
    """The truth of every rotary test of ``session``, as ``volcal simulate`` draws it.

    Parameters
    ----------
    session : Session
        The planned session (not changed: a copy is simulated).
    machine : MachineErrors
        The virtual machine (its ``rotary`` axes when it carries them).
    seed : int
        ``volcal simulate --seed``.

    Returns
    -------
    dict of str to RotaryTruth
        By measurement id.
    """
    from volcal.measure.rotary import RotarySetup

    s, setups = simulated_setups(session, machine, seed, _is_rotary)
    out: dict[str, RotaryTruth] = {}
    for m in s.measurements:
        st = setups.get(m.id)
        if _is_rotary(m) and isinstance(st, RotarySetup):
            d0 = str(m.columns["direction"][0]) if "direction" in m.columns else "+"
            out[m.id] = RotaryTruth(st, _error(st, float(m.columns["target_deg"][0]), d0))
    return out


def simulated_setups(session: Any, machine: Any, seed: int, pick: Any
                     ) -> tuple[Any, dict[str, Any]]:
    """``volcal simulate --seed``'s hidden set-ups, up to the last measurement picked.

    Parameters
    ----------
    session : Session
        The planned session (not changed: a copy is simulated).
    machine : MachineErrors
        The virtual machine.
    seed : int
        ``volcal simulate --seed``.
    pick : callable
        True for a measurement whose set-up is wanted: the simulation runs the session's
        measurements up to the last one picked (the random draws before it), with
        ``volcal simulate``'s default options.

    Returns
    -------
    session : Session
        The simulated copy (its measurements up to the last picked).
    setups : dict of str to object
        :func:`volcal.measure.simulate.simulate_session`'s set-ups by measurement id
        (empty when none is picked).
    """
    from volcal.measure.simulate import SimulationOptions, simulate_session

    last = max((i for i, m in enumerate(session.measurements) if pick(m)), default=-1)
    s = copy.deepcopy(session)
    s.measurements = s.measurements[:last + 1]  # the draws before the last one picked
    if last < 0:
        return s, {}
    opts = SimulationOptions(noise_um=D.SIM_NOISE_UM,
                             mirror_misalignment_urad=D.SIM_MIRROR_URAD,
                             drift_um_per_h=D.SIM_DRIFT_UM_PER_H, seed=int(seed))
    return s, simulate_session(s, machine, opts)
