"""The timed part program of the simulated control: moves, dwells and the operator stop.

:func:`program_timeline` times a measurement's program of the linear axes (the step list
:func:`volcal.program.steps.build_steps` writes it from), :func:`rotary_timeline` a rotary
test's (:func:`volcal.program.rotary.rotary_moves`): every move with a trapezoidal velocity
profile (feed, acceleration), every dwell, the operator stop. The positions of a rotary
test's timeline are X, Y, Z [mm] and the rotary axis' angle [deg] (its feed in deg/min,
its acceleration in deg/s^2: the same numbers).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from volcal.capture.plan import PlannedMeasurement

__all__ = ["Segment", "move_along", "move_time", "program_timeline", "rotary_timeline"]


@dataclass(frozen=True)
class Segment:
    """One piece of the simulated program: a move, a dwell or a stop.

    Attributes
    ----------
    t0, t1 : float
        Start and end, seconds from the program's start [s].
    p0, p1 : ndarray, shape (3,) or (4,)
        Position at the start and the end: X, Y, Z [mm] (and a rotary test's angle
        [deg]).
    kind : str
        ``'move'``, ``'dwell'`` or ``'stop'``.
    """

    t0: float
    t1: float
    p0: NDArray[np.float64]
    p1: NDArray[np.float64]
    kind: str


def move_time(d: float, v: float, a: float) -> float:
    """Duration of a trapezoidal (or triangular) move of length ``d`` [s].

    Parameters
    ----------
    d : float
        Length of the move [mm or deg].
    v : float
        Feed [mm/s or deg/s].
    a : float
        Acceleration [mm/s^2 or deg/s^2].

    Returns
    -------
    float
    """
    if d <= 0:
        return 0.0
    if d >= v * v / a:
        return d / v + v / a
    return 2.0 * math.sqrt(d / a)


def move_along(d: float, v: float, a: float, t: float) -> float:
    """Distance covered after ``t`` seconds of that move [mm or deg].

    Parameters
    ----------
    d : float
        Length of the move [mm or deg].
    v : float
        Feed [mm/s or deg/s].
    a : float
        Acceleration [mm/s^2 or deg/s^2].
    t : float
        Time since the move's start [s].

    Returns
    -------
    float
    """
    T = move_time(d, v, a)
    t = min(max(t, 0.0), T)
    if d >= v * v / a:
        ta = v / a
        if t < ta:
            return 0.5 * a * t * t
        if t > T - ta:
            r = T - t
            return d - 0.5 * a * r * r
        return 0.5 * a * ta * ta + v * (t - ta)
    th = T / 2.0
    if t < th:
        return 0.5 * a * t * t
    r = T - t
    return d - 0.5 * a * r * r


class _Timeline:
    """Segments laid one after another from a start position (each program's timeline)."""

    def __init__(self, here: NDArray[np.float64], accel: float) -> None:
        self.segs: list[Segment] = []
        self.t = 0.0
        self.p = np.asarray(here, float).copy()
        self.accel = accel

    def move(self, q: NDArray[np.float64], v: float) -> None:
        """A move to ``q`` at the feed ``v`` [mm/s or deg/s]; none when already there."""
        d = float(np.linalg.norm(q - self.p))
        if d > 1e-12:
            dt = move_time(d, v, self.accel)
            self.segs.append(Segment(self.t, self.t + dt, self.p.copy(), q.copy(), "move"))
            self.t, self.p = self.t + dt, q.copy()

    def rest(self, seconds: float, kind: str) -> None:
        """Standing still ``seconds`` [s]: a ``'dwell'`` or the operator's ``'stop'``."""
        self.segs.append(Segment(self.t, self.t + seconds, self.p.copy(), self.p.copy(), kind))
        self.t += seconds


def program_timeline(pm: PlannedMeasurement, here: NDArray[np.float64], accel: float,
                     stop_s: float) -> list[Segment]:
    """The segments of the measurement's program, starting from position ``here``.

    Parameters
    ----------
    pm : PlannedMeasurement
    here : ndarray, shape (3,)
        Position when the program starts [mm].
    accel : float
        Acceleration [mm/s^2].
    stop_s : float
        Length of the operator stop [s].

    Returns
    -------
    list of Segment
    """
    tl = _Timeline(here, accel)
    v_default = pm.options.feed / 60.0

    def move(q: NDArray[np.float64], feed: float | None) -> None:
        tl.move(q, (feed or pm.options.feed) / 60.0 if feed else v_default)

    for st in pm.steps:
        if st.kind == "start" and st.position is not None:
            q = np.asarray(st.position, float)
            up = tl.p.copy()
            up[2] = pm.options.safe_z_mm
            move(up, st.feed)
            xy = up.copy()
            xy[:2] = q[:2]
            move(xy, st.feed)
            move(q, st.feed)
        elif st.kind == "stop":
            tl.rest(stop_s, "stop")
        elif st.kind == "move" and st.position is not None:
            move(np.asarray(st.position, float), st.feed)
        elif st.kind == "dwell":
            tl.rest(float(st.seconds or 0.0), "dwell")
    return tl.segs



def rotary_timeline(pm: PlannedMeasurement, here: NDArray[np.float64], accel: float,
                    stop_s: float) -> list[Segment]:
    """The segments of a rotary test's program, starting from ``here``.

    Z goes up to the safe height, the rotary axis turns to the first target (absolute)
    and on by the program's turns; the operator stop stands where the program writes it
    (after the overrun before the first reading), a dwell at each reading.

    Parameters
    ----------
    pm : PlannedMeasurement
        A rotary test's (``pm.rotary`` set).
    here : ndarray, shape (4,)
        X, Y, Z [mm] and the rotary axis' angle [deg] when the program starts.
    accel : float
        Acceleration [mm/s^2, deg/s^2].
    stop_s : float
        Length of the operator stop [s].

    Returns
    -------
    list of Segment
    """
    mv = pm.rotary
    if mv is None:
        raise ValueError(f"{pm.id} is not a rotary test")
    tl = _Timeline(here, accel)
    v = pm.options.feed / 60.0
    p = tl.p
    tl.move(np.array([p[0], p[1], pm.options.safe_z_mm, p[3]]), v)
    p = tl.p
    tl.move(np.array([p[0], p[1], p[2], mv.start_deg]), v)
    for k, (kind, value, _row) in enumerate(mv.items):
        if k == mv.stop:
            tl.rest(stop_s, "stop")
        if kind == "turn":
            tl.move(tl.p + np.array([0.0, 0.0, 0.0, value]), v)
        elif kind == "dwell":
            tl.rest(float(value), "dwell")
    return tl.segs


def rtest_timeline(pm: PlannedMeasurement, here: NDArray[np.float64], accel: float,
                   stop_s: float) -> list[Segment]:
    """The segments of an R-test's program, starting from ``here``.

    The blocks of :func:`volcal.program.r_test.rtest_program_path`: Z up to the safe
    height, the rotary axes to the first pose, X Y then Z above the sphere, the nest
    lowered onto it, the operator stop (the sensors zeroed), then the following moves
    through every intermediate point with a dwell at each pose, and back. A move runs at
    the program's feed along the path of all the axes (mm and deg alike, a rehearsal's
    timing).

    Parameters
    ----------
    pm : PlannedMeasurement
        An R-test's (``pm.path`` set).
    here : ndarray, shape (3 + r,)
        X, Y, Z [mm] and the rotary axes [deg] when the program starts.
    accel : float
        Acceleration [mm/s^2, deg/s^2].
    stop_s : float
        Length of the operator stop [s].

    Returns
    -------
    list of Segment
    """
    if pm.path is None:
        raise ValueError(f"{pm.id} is not an R-test")
    from volcal.program.r_test import FOLLOW_FEED_MAX_MM_MIN

    tl = _Timeline(here, accel)
    v = min(pm.options.feed, FOLLOW_FEED_MAX_MM_MIN) / 60.0
    for kind, q, _ in pm.path:
        q = np.where(np.isnan(q), tl.p, q)
        if kind == "move":
            tl.move(q, v)
        else:
            tl.rest(stop_s if kind == "stop" else float(pm.options.dwell_s), kind)
    return tl.segs
