"""A simulated control and laser: the demo, the tests, and a rehearsal without a machine.

``--control sim[:KEY=V,...]`` executes the measurement's part program (the same step list
:func:`volcal.program.steps.build_steps` writes the program from) on a simulated clock:
the start positioning (Z to the safe height, then X and Y, then Z down), the operator
stop (``stop_s`` seconds, the program paused), then every move with a trapezoidal
velocity profile (feed, acceleration ``accel``) and every dwell. Keys:

============  =======  ==========================================================
key           default  meaning
============  =======  ==========================================================
``accel``     500      acceleration of every axis move [mm/s^2]
``noise``     0.0001   servo noise of the actual positions, standard deviation [mm]
``overshoot`` 0        overshoot at the end of each move [mm] (damped, 3 Hz, 0.2 s)
``stop_s``    1        length of the operator stop before the first reading [s]
``flags``     1        report ``in_motion`` and ``program_running`` (0: positions only,
                       like a control that exposes no state)
``seed``      0        seed of the servo noise
``home``      -        position before the first program, ``x/y/z`` [mm] (default:
                       the middle of the X and Y travel at the safe Z)
============  =======  ==========================================================

Each measurement's program starts when the capture turns to it; after a kill, the
program runs again from its start (the rule passes over the readings already recorded).

``--laser sim[:KEY=V,...]`` reads volcal's virtual machine at the control's actual
position (the latest control sample): the displacement along the beam since the first
target plus the machine's exact reading error at the nearest planned target
(:meth:`volcal.session.kinds.Kind.exact`), plus white noise; a direct optic reads its
error alone. Keys: ``seed`` (the random machine's and the noise's, default 0),
``noise`` (standard deviation [um or urad], default 0.05), ``machine`` (an error table
``ERRORS.csv`` instead of the random machine), ``rate`` (readings per second, default
50), ``creep`` (drift of the reading during each dwell [um/s], default 0).
"""

from __future__ import annotations

import math
import random
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.capture.plan import PlannedMeasurement
from volcal.capture.samples import ControlSample, LaserSample
from volcal.capture.sources import (
    SourceContext,
    SourceSpec,
    options,
    register_control,
    register_laser,
)
from volcal.errors import VolcalInputError

__all__ = ["Segment", "SimulatedControl", "SimulatedLaser", "program_timeline"]


@dataclass(frozen=True)
class Segment:
    """One piece of the simulated program: a move, a dwell or a stop.

    Attributes
    ----------
    t0, t1 : float
        Start and end, seconds from the program's start [s].
    p0, p1 : ndarray, shape (3,)
        Position at the start and the end [mm].
    kind : str
        ``'move'``, ``'dwell'`` or ``'stop'``.
    """

    t0: float
    t1: float
    p0: NDArray[np.float64]
    p1: NDArray[np.float64]
    kind: str


def _move_time(d: float, v: float, a: float) -> float:
    """Duration of a trapezoidal (or triangular) move of length ``d`` [s]."""
    if d <= 0:
        return 0.0
    if d >= v * v / a:
        return d / v + v / a
    return 2.0 * math.sqrt(d / a)


def _along(d: float, v: float, a: float, t: float) -> float:
    """Distance covered after ``t`` seconds of that move [mm]."""
    T = _move_time(d, v, a)
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
    segs: list[Segment] = []
    t = 0.0
    p = np.asarray(here, float).copy()
    v_default = pm.options.feed / 60.0

    def move(q: NDArray[np.float64], feed: float | None) -> None:
        nonlocal t, p
        d = float(np.linalg.norm(q - p))
        if d <= 1e-12:
            return
        dt = _move_time(d, (feed or pm.options.feed) / 60.0 if feed else v_default, accel)
        segs.append(Segment(t, t + dt, p.copy(), q.copy(), "move"))
        t, p = t + dt, q.copy()

    for st in pm.steps:
        if st.kind == "start" and st.position is not None:
            q = np.asarray(st.position, float)
            up = p.copy()
            up[2] = pm.options.safe_z_mm
            move(up, st.feed)
            xy = up.copy()
            xy[:2] = q[:2]
            move(xy, st.feed)
            move(q, st.feed)
        elif st.kind == "stop":
            segs.append(Segment(t, t + stop_s, p.copy(), p.copy(), "stop"))
            t += stop_s
        elif st.kind == "move" and st.position is not None:
            move(np.asarray(st.position, float), st.feed)
        elif st.kind == "dwell":
            dt = float(st.seconds or 0.0)
            segs.append(Segment(t, t + dt, p.copy(), p.copy(), "dwell"))
            t += dt
    return segs


def _float(opts: dict[str, str], key: str, default: float, where: str) -> float:
    if key not in opts:
        return default
    try:
        v = float(opts[key])
    except ValueError:
        v = math.nan
    if not math.isfinite(v) or v < 0:
        raise VolcalInputError(f"source {where!r}: {key}={opts[key]!r} is not a number >= 0")
    return v


def _gauss(seed: int, mid: str, tick: int, salt: int, sigma: float, n: int = 1
           ) -> list[float]:
    """Deterministic normal draws keyed by (seed, measurement, time tick, salt)."""
    key = ((seed * 7919 + salt) * 4294967311 + zlib.crc32(mid.encode())) * 10**13 + tick
    r = random.Random(key)
    return [r.gauss(0.0, sigma) for _ in range(n)]


class SimulatedControl:
    """The ``sim`` control source (see the module's docstring)."""

    KEYS = ("accel", "noise", "overshoot", "stop_s", "flags", "seed", "home")

    def __init__(self, spec: SourceSpec, ctx: SourceContext) -> None:
        o = options(spec.argument, spec.text, self.KEYS)
        self.ctx = ctx
        self.accel = _float(o, "accel", 500.0, spec.text) or 500.0
        self.noise = _float(o, "noise", 0.0001, spec.text)
        self.overshoot = _float(o, "overshoot", 0.0, spec.text)
        self.stop_s = _float(o, "stop_s", 1.0, spec.text)
        self.flags = _float(o, "flags", 1.0, spec.text) != 0
        self.seed = int(_float(o, "seed", 0.0, spec.text))
        self.home: NDArray[np.float64] | None = None
        if "home" in o:
            try:
                self.home = np.array([float(v) for v in o["home"].split("/")], float)
            except ValueError:
                self.home = None
            if self.home is None or self.home.shape != (3,):
                raise VolcalInputError(f"source {spec.text!r}: home={o['home']!r} is not "
                                       "x/y/z [mm]")
        self._mid: str | None = None
        self._segs: list[Segment] = []
        self._t0 = 0.0
        self._last_t: float | None = None
        self._pos: NDArray[np.float64] | None = None

    def open(self) -> None:
        """Nothing to connect."""

    def close(self) -> None:
        """Nothing to release."""

    def _start(self, mid: str) -> None:
        pm = next(p for p in self.ctx.measurements if p.id == mid)
        if self._pos is None:
            if self.home is not None:
                self._pos = self.home
            else:
                tr = np.asarray(self.ctx.session.travel, float)
                self._pos = np.array([tr[0].mean(), tr[1].mean(), pm.options.safe_z_mm])
        self._segs = program_timeline(pm, self._pos, self.accel, self.stop_s)
        self._mid, self._t0 = mid, self.ctx.clock.now()

    def _at(self, tr: float) -> tuple[NDArray[np.float64], bool, bool, bool]:
        """Position, moving, running, ended at ``tr`` seconds into the program."""
        for k, s in enumerate(self._segs):
            if tr < s.t1:
                if s.kind == "move":
                    d = float(np.linalg.norm(s.p1 - s.p0))
                    f = _along(d, self._v(s), self.accel, tr - s.t0) / d
                    return s.p0 + f * (s.p1 - s.p0), True, True, False
                p = s.p1.copy()
                prev = next((q for q in reversed(self._segs[:k]) if q.kind == "move"), None)
                if self.overshoot > 0 and prev is not None:
                    dt = tr - prev.t1
                    u = (prev.p1 - prev.p0) / np.linalg.norm(prev.p1 - prev.p0)
                    p = p + u * self.overshoot * math.exp(-dt / 0.2) * math.cos(
                        2 * math.pi * 3.0 * dt)
                return p, False, s.kind != "stop", False
        end = self._segs[-1].p1 if self._segs else np.zeros(3)
        return end.copy(), False, False, True

    def _v(self, s: Segment) -> float:
        d = float(np.linalg.norm(s.p1 - s.p0))
        # the feed that gives this segment's duration (every move of a program shares it)
        for v in (self.ctx.measurements[0].options.feed / 60.0,):
            if abs(_move_time(d, v, self.accel) - (s.t1 - s.t0)) < 1e-9:
                return v
        return d / max(s.t1 - s.t0, 1e-12)

    def poll(self) -> ControlSample | None:
        """The actual position now (one sample per clock tick)."""
        mid = self.ctx.current()
        if mid is None:
            return None
        if mid != self._mid:
            self._start(mid)
        t = self.ctx.clock.now()
        if self._last_t is not None and t <= self._last_t:
            return None
        self._last_t = t
        tr = t - self._t0
        p, moving, running, ended = self._at(tr)
        self._pos = p
        if self.noise > 0:
            p = p + np.array(_gauss(self.seed, mid, round(tr * 1e6), 1, self.noise, 3))
        pos = {a: float(v) for a, v in zip("XYZ", p, strict=True)}
        if not self.flags:
            return ControlSample(t, pos, status="ended" if ended else "ok")
        return ControlSample(t, pos, moving, running, "ended" if ended else "ok")


class SimulatedLaser:
    """The ``sim`` laser source (see the module's docstring)."""

    KEYS = ("seed", "noise", "machine", "rate", "creep")

    def __init__(self, spec: SourceSpec, ctx: SourceContext) -> None:
        o = options(spec.argument, spec.text, self.KEYS)
        self.ctx = ctx
        self.seed = int(_float(o, "seed", 0.0, spec.text))
        self.noise = _float(o, "noise", 0.05, spec.text)
        self.rate = _float(o, "rate", 50.0, spec.text) or 50.0
        self.creep = _float(o, "creep", 0.0, spec.text)
        self.machine_path = Path(o["machine"]) if "machine" in o else None
        self._vm: Any = None
        self._tables: dict[str, tuple[NDArray[np.float64], NDArray[np.float64], bool, str]] = {}
        self._mid: str | None = None
        self._t0 = 0.0
        self._next = 0.0
        self._last_t: float | None = None
        self._rest: tuple[NDArray[np.float64], float] | None = None

    def open(self) -> None:
        """Build the virtual machine."""
        s = self.ctx.session
        if self.machine_path is not None:
            from volcal.session.errortable import read_error_table

            self._vm = read_error_table(self.machine_path, chain=s.chain)
        else:
            from volcal.measure.virtual import random_machine

            self._vm = random_machine(s.travel, s.chain, self.seed, name=f"virtual {s.name}")

    def close(self) -> None:
        """Nothing to release."""

    @property
    def machine(self) -> Any:
        """The virtual machine (:class:`volcal.model.errorfunctions.MachineErrors`)."""
        return self._vm

    def exact(self, mid: str) -> NDArray[np.float64]:
        """Exact readings of measurement ``mid`` at its planned targets [um or urad].

        Parameters
        ----------
        mid : str
            The measurement's id.

        Returns
        -------
        ndarray
            From the first row, in the measurement's unit.
        """
        return self._table(mid)[1]

    def _table(self, mid: str) -> tuple[NDArray[np.float64], NDArray[np.float64], bool, str]:
        if mid not in self._tables:
            from volcal.capture.sessionfile import reading_of
            from volcal.session.kinds import kind_of

            pm = next(p for p in self.ctx.measurements if p.id == mid)
            m = pm.measurement
            r = reading_of(m)
            e = np.asarray(kind_of(m.kind).exact(self._vm, m), float)
            self._tables[mid] = (np.asarray(m.positions, float), e, r.displacement, r.unit)
        return self._tables[mid]

    def poll(self) -> LaserSample | None:
        """The reading now, at ``rate`` readings per second."""
        mid = self.ctx.current()
        c = self.ctx.latest_control()
        if mid is None or c is None:
            return None
        t = self.ctx.clock.now()
        if mid != self._mid:
            self._mid, self._t0, self._next = mid, t, t
        if t + 1e-9 < self._next or (self._last_t is not None and t <= self._last_t):
            return None
        self._last_t = t
        self._next = max(self._next + 1.0 / self.rate, t)
        pos, e, displacement, unit = self._table(mid)
        p = np.array([c.positions[a] for a in "XYZ"], float)
        i = int(np.argmin(np.linalg.norm(pos - p, axis=1)))
        value = float(e[i])
        if displacement:
            pm = next(q for q in self.ctx.measurements if q.id == mid)
            b = np.asarray(pm.measurement.beam_direction, float)
            value += 1000.0 * float((p - pos[0]) @ (b / np.linalg.norm(b)))
        if self.creep > 0:  # drift during a rest: the reading creeps while the axes stand
            if c.in_motion is False and (self._rest is None or
                                         float(np.max(np.abs(self._rest[0] - p))) > 0.005):
                self._rest = (p, t)
            elif c.in_motion is True:
                self._rest = None
            if self._rest is not None:
                value += self.creep * (t - self._rest[1])
        tick = round((t - self._t0) * 1e6)
        if self.noise > 0:
            value += _gauss(self.seed, mid, tick, 2, self.noise)[0]
        return LaserSample(t, value, unit)


register_control("sim", SimulatedControl, "simulated control: the planned program, timed",
                 simulated=True)
register_laser("sim", SimulatedLaser, "simulated laser on volcal's virtual machine")
