"""A simulated control and laser: the demo, the tests, and a rehearsal without a machine.

``--control sim[:KEY=V,...]`` executes the measurement's part program (the same step list
:func:`volcal.program.steps.build_steps` writes the program from) on a simulated clock:
the start positioning (Z to the safe height, then X and Y, then Z down), the operator
stop (``stop_s`` seconds, the program paused), then every move with a trapezoidal
velocity profile (feed, acceleration ``accel``) and every dwell
(:mod:`volcal.capture.timeline`). A rotary test's program turns its rotary axis (Z up,
the turn to the first target, the overrun, the operator stop, the incremental turns and
dwells of :func:`volcal.program.rotary.rotary_moves`): the control then reports the
axis' angle by its letter (``C`` [deg]) beside X, Y, Z, and keeps reporting it. An
R-test's program (:func:`volcal.program.r_test.rtest_program_path`) moves all its axes,
the linear ones following the rotary ones, with a dwell at each pose
(:func:`volcal.capture.timeline.rtest_timeline`). Keys:

============  =======  ==========================================================
key           default  meaning
============  =======  ==========================================================
``accel``     500      acceleration of every axis move [mm/s^2] (a turn: [deg/s^2])
``noise``     0.0001   servo noise of the actual positions, standard deviation [mm]
                       (an angle: [deg])
``overshoot`` 0        overshoot at the end of each move [mm] (damped, 3 Hz, 0.2 s)
``stop_s``    1        length of the operator stop before the first reading [s]
``flags``     1        report ``in_motion`` and ``program_running`` (0: positions only,
                       like a control that exposes no state)
``seed``      0        seed of the servo noise
``home``      -        position before the first program, ``x/y/z`` [mm] (default:
                       the middle of the X and Y travel at the safe Z), or
                       ``x/y/z/angle`` with the rotary axes' angle [deg] (default 0)
``wrap``      0        1: report a full-circle rotary axis' angle modulo 360 (0..360,
                       as LinuxCNC's ``WRAPPED_ROTARY``); 0: counting on (362 past 360)
============  =======  ==========================================================

Each measurement's program starts when the capture turns to it; after a kill, the
program runs again from its start (the rule passes over the readings already recorded).

``--laser sim[:KEY=V,...]`` reads volcal's virtual machine at the control's actual
position (the latest control sample): the displacement along the beam since the first
target plus the machine's exact reading error at the nearest planned target
(:meth:`volcal.session.kinds.Kind.exact`), plus white noise; a direct optic reads its
error alone. A rotary test's calibrator reads the virtual rotary axis' angular
positioning error at the control's actual angle, approached in the direction of its last
turn, counted from the first target (:mod:`volcal.capture.virtual_rotary`: the axis
``volcal simulate --seed`` draws). An R-test's nest sends three channels: the sphere's
displacement ``volcal simulate --seed`` would read at the control's actual pose, zeroed
at the first pose (:mod:`volcal.capture.virtual_rtest`), each with its own noise.
Keys: ``seed`` (the random machine's and the noise's, default 0), ``noise`` (standard
deviation [um or urad], default 0.05), ``machine`` (an error table ``ERRORS.csv`` instead
of the random machine), ``rate`` (readings per second, default 50), ``creep`` (drift of
the reading during each dwell [um/s or urad/s], default 0; not an R-test's), ``unit``
(the unit of the values sent: ``um``, ``mm``, ``nm``... for a length, ``urad``,
``arcsec``, ``mrad``... for an angle; default ``um`` or ``urad``,
:data:`volcal.capture.samples.ANGULAR_UNITS`).
"""

from __future__ import annotations

import bisect
import math
import random
import zlib
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.capture.samples import ANGULAR_UNITS, LINEAR_UNITS, ControlSample, LaserSample
from volcal.capture.sources import (
    SourceContext,
    SourceSpec,
    options,
    register_control,
    register_laser,
)
from volcal.capture.timeline import (
    Segment,
    move_along,
    move_time,
    program_timeline,
    rotary_timeline,
    rtest_timeline,
)
from volcal.errors import VolcalInputError

__all__ = ["Segment", "SimulatedControl", "SimulatedLaser", "program_timeline"]


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

    KEYS = ("accel", "noise", "overshoot", "stop_s", "flags", "seed", "home", "wrap")

    def __init__(self, spec: SourceSpec, ctx: SourceContext) -> None:
        o = options(spec.argument, spec.text, self.KEYS)
        self.ctx = ctx
        self.accel = _float(o, "accel", 500.0, spec.text) or 500.0
        self.noise = _float(o, "noise", 0.0001, spec.text)
        self.overshoot = _float(o, "overshoot", 0.0, spec.text)
        self.stop_s = _float(o, "stop_s", 1.0, spec.text)
        self.flags = _float(o, "flags", 1.0, spec.text) != 0
        self.seed = int(_float(o, "seed", 0.0, spec.text))
        self.wrap = _float(o, "wrap", 0.0, spec.text) != 0
        self.home: NDArray[np.float64] | None = None
        if "home" in o:
            try:
                self.home = np.array([float(v) for v in o["home"].split("/")], float)
            except ValueError:
                self.home = None
            if self.home is None or self.home.shape not in ((3,), (4,)):
                raise VolcalInputError(f"source {spec.text!r}: home={o['home']!r} is not "
                                       "x/y/z [mm] or x/y/z/angle [mm, deg]")
        self._mid: str | None = None
        self._segs: list[Segment] = []
        self._ends: list[float] = []
        self._t0 = 0.0
        self._last_t: float | None = None
        self._here: dict[str, float] = {}   # every axis' position where the program left it
        self._axes: tuple[str, ...] = ("X", "Y", "Z")
        self._period: float | None = None
        self._limited: set[str] = set()

    def open(self) -> None:
        """Nothing to connect."""

    def close(self) -> None:
        """Nothing to release."""

    def _start(self, mid: str) -> None:
        pm = next(p for p in self.ctx.measurements if p.id == mid)
        if not self._here:
            if self.home is not None:
                self._here = dict(zip("XYZ", map(float, self.home[:3]), strict=True))
            else:
                tr = np.asarray(self.ctx.session.travel, float)
                self._here = {"X": float(tr[0].mean()), "Y": float(tr[1].mean()),
                              "Z": float(pm.options.safe_z_mm)}
        frame = pm.frame
        self._axes = (frame.axes if frame.mixed else ("X", "Y", "Z", *frame.axes)
                      if frame.rotary else ("X", "Y", "Z"))
        self._period = frame.period
        self._limited = ({a for a, m in zip(frame.axes, frame.modulo, strict=True)
                          if not m and a not in "XYZ"} if frame.mixed
                         else set())  # an R-test's tilting axis: not wrapped
        angle0 = float(self.home[3]) if self.home is not None and self.home.size == 4 else 0.0
        here = np.array([self._here.get(a, angle0) for a in self._axes])
        self._segs = (rtest_timeline(pm, here, self.accel, self.stop_s) if frame.mixed
                      else rotary_timeline(pm, here, self.accel, self.stop_s) if frame.rotary
                      else program_timeline(pm, here, self.accel, self.stop_s))
        self._ends = [s.t1 for s in self._segs]
        self._mid, self._t0 = mid, self.ctx.clock.now()

    def _at(self, tr: float) -> tuple[NDArray[np.float64], bool, bool, bool]:
        """Position, moving, running, ended at ``tr`` seconds into the program."""
        for k in range(bisect.bisect_right(self._ends, tr), len(self._segs)):
            s = self._segs[k]
            if tr < s.t1:
                if s.kind == "move":
                    d = float(np.linalg.norm(s.p1 - s.p0))
                    f = move_along(d, self._v(s), self.accel, tr - s.t0) / d
                    return s.p0 + f * (s.p1 - s.p0), True, True, False
                p = s.p1.copy()
                prev = next((q for q in reversed(self._segs[:k]) if q.kind == "move"), None)
                if self.overshoot > 0 and prev is not None:
                    dt = tr - prev.t1
                    u = (prev.p1 - prev.p0) / np.linalg.norm(prev.p1 - prev.p0)
                    p = p + u * self.overshoot * math.exp(-dt / 0.2) * math.cos(
                        2 * math.pi * 3.0 * dt)
                return p, False, s.kind != "stop", False
        end = self._segs[-1].p1 if self._segs else np.array([self._here[a] for a in self._axes])
        return end.copy(), False, False, True

    def _v(self, s: Segment) -> float:
        d = float(np.linalg.norm(s.p1 - s.p0))
        # the feed that gives this segment's duration (every move of a program shares it)
        feed = self.ctx.measurements[0].options.feed
        for v in (feed / 60.0, min(feed, 1000.0) / 60.0):  # (an R-test's following feed)
            if abs(move_time(d, v, self.accel) - (s.t1 - s.t0)) < 1e-9:
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
        self._here.update(zip(self._axes, map(float, p), strict=True))
        if self.noise > 0:
            p = p + np.array(_gauss(self.seed, mid, round(tr * 1e6), 1, self.noise,
                                    len(self._axes)))
        pos = dict(self._here)  # a rotary axis turned before keeps being reported
        pos.update(zip(self._axes, map(float, p), strict=True))
        if self.wrap:
            for a in pos.keys() - {"X", "Y", "Z"} - self._limited:
                pos[a] = pos[a] % 360.0
        if not self.flags:
            return ControlSample(t, pos, status="ended" if ended else "ok")
        return ControlSample(t, pos, moving, running, "ended" if ended else "ok")


class SimulatedLaser:
    """The ``sim`` laser source (see the module's docstring)."""

    KEYS = ("seed", "noise", "machine", "rate", "creep", "unit")

    def __init__(self, spec: SourceSpec, ctx: SourceContext) -> None:
        o = options(spec.argument, spec.text, self.KEYS)
        self.ctx = ctx
        self.seed = int(_float(o, "seed", 0.0, spec.text))
        self.noise = _float(o, "noise", 0.05, spec.text)
        self.rate = _float(o, "rate", 50.0, spec.text) or 50.0
        self.creep = _float(o, "creep", 0.0, spec.text)
        self.machine_path = Path(o["machine"]) if "machine" in o else None
        self.unit = o.get("unit")
        if self.unit is not None and self.unit not in LINEAR_UNITS | ANGULAR_UNITS:
            raise VolcalInputError(
                f"source {spec.text!r}: unit={self.unit!r} is not one of "
                f"{', '.join(sorted(set(LINEAR_UNITS) | set(ANGULAR_UNITS)))}")
        self._vm: Any = None
        self._tables: dict[str, tuple[NDArray[np.float64], NDArray[np.float64], bool, str]] = {}
        self._rotary: dict[str, Any] | None = None
        self._rtest: dict[str, Any] | None = None
        self._nest_cache: dict[str, tuple[NDArray[np.float64], NDArray[np.float64],
                                          NDArray[np.float64]]] = {}
        self._mid: str | None = None
        self._t0 = 0.0
        self._next = 0.0
        self._last_t: float | None = None
        self._rest: tuple[NDArray[np.float64], float] | None = None
        self._turn: tuple[float, str] | None = None  # last angle seen, direction of its turn

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

    def rotary_truth(self, mid: str) -> Any:
        """The rotary axis a rotary test reads (:class:`~.virtual_rotary.RotaryTruth`).

        Parameters
        ----------
        mid : str
            A rotary test's id.

        Returns
        -------
        RotaryTruth
            The axis ``volcal simulate --seed`` draws for it (seed = this laser's).
        """
        if self._rotary is None:
            from volcal.capture.virtual_rotary import rotary_truths

            self._rotary = rotary_truths(self.ctx.session, self._vm, self.seed)
        return self._rotary[mid]

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
        pm = next(p for p in self.ctx.measurements if p.id == mid)
        if pm.frame.rotary:
            m, truth = pm.measurement, self.rotary_truth(mid)
            d = m.columns.get("direction")
            return np.array([truth.reading(float(a), "+" if d is None else str(d[i]))
                             for i, a in enumerate(m.columns["target_deg"])])
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

    def _linear(self, mid: str, c: ControlSample) -> tuple[float, str, NDArray[np.float64]]:
        """The reading [um or urad] at the control's position, its unit, the position."""
        pos, e, displacement, unit = self._table(mid)
        p = np.array([c.positions[a] for a in "XYZ"], float)
        i = int(np.argmin(np.linalg.norm(pos - p, axis=1)))
        value = float(e[i])
        if displacement:
            pm = next(q for q in self.ctx.measurements if q.id == mid)
            b = np.asarray(pm.measurement.beam_direction, float)
            value += 1000.0 * float((p - pos[0]) @ (b / np.linalg.norm(b)))
        return value, unit, p

    def _angular(self, mid: str, c: ControlSample
                 ) -> tuple[float, str, NDArray[np.float64]] | None:
        """The calibrator's reading [urad] at the control's actual angle (last turn's way).

        None while the control reports no angle of the axis (its sample of the program
        before; a control of the linear axes only: the trigger rule says so).
        """
        pm = next(q for q in self.ctx.measurements if q.id == mid)
        axis = pm.frame.axes[0]
        if axis not in c.positions:
            return None
        a = float(c.positions[axis])
        last = self._turn or (a, "+")
        d = float(pm.frame.delta(np.array([a]), np.array([last[0]]))[0])
        if abs(d) > 1e-3:  # a turn (not the servo noise of a standing axis)
            last = (a, "+" if d > 0 else "-")
        self._turn = last
        return self.rotary_truth(mid).reading(a, last[1]), "urad", np.array([a])

    def rtest_truth(self, mid: str) -> Any:
        """The sphere an R-test's nest reads (:class:`~.virtual_rtest.RTestTruth`).

        Parameters
        ----------
        mid : str
            An R-test's id.

        Returns
        -------
        RTestTruth
            The set-up ``volcal simulate --seed`` draws for it (seed = this laser's).
        """
        if self._rtest is None:
            from volcal.capture.virtual_rtest import rtest_truths

            self._rtest = rtest_truths(self.ctx.session, self._vm, self.seed)
        return self._rtest[mid]

    def _nest(self, mid: str, c: ControlSample
              ) -> tuple[NDArray[np.float64], str, NDArray[np.float64]] | None:
        """The nest's three readings [um] at the control's actual pose.

        The first-order expansion of the exact readings
        (:meth:`~.virtual_rtest.RTestTruth.reading`) about the nearest planned pose, in
        every axis: exact to the servo noise's second order where a reading is taken (the
        axes at rest at a pose), a continuous value while they move. None while the
        control reports no angle of the test's rotary axes (its sample of the program
        before; a control without them: the trigger rule says so).
        """
        pm = next(q for q in self.ctx.measurements if q.id == mid)
        if any(a not in c.positions for a in pm.frame.axes):
            return None
        p = np.array([c.positions[a] for a in pm.frame.axes], float)
        targets, values, jac = self._nest_table(mid)
        i = int(np.argmin(np.abs(pm.frame.delta(p, targets)
                                 / pm.frame.per_axis(1.0, 0.1)).max(axis=1)))
        return values[i] + jac[i] @ pm.frame.delta(p, targets[i]), "um", p

    def _nest_table(self, mid: str
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Per planned pose: its target, reading [um] and derivatives [um/mm, um/deg].

        The target in the control's axes; the derivatives of the reading by each axis by
        central differences.
        """
        if mid not in self._nest_cache:
            from volcal.session.r_test import rtest_keys

            pm = next(q for q in self.ctx.measurements if q.id == mid)
            truth = self.rtest_truth(mid)
            k = rtest_keys(pm.measurement)
            sign, tcp = float(k["control_angle_sign"]), k["control_kinematics"] == "tcp"
            letters = pm.frame.axes[3:]

            def read(d: Any, p: NDArray[np.float64]) -> NDArray[np.float64]:
                # tcp: X Y Z are the table's coordinates, the joints follow the pose's
                q = d.pose_mm + (p[:3] - d.target[:3]) if tcp else p[:3]
                return np.asarray(truth.reading(q, {a: sign * float(v) for a, v
                                                    in zip(letters, p[3:], strict=True)}))

            targets = np.array([d.target for d in pm.dwells], float)
            values = np.array([read(d, d.target) for d in pm.dwells])
            h = pm.frame.per_axis(1e-3, 1e-3)
            jac = np.zeros((len(pm.dwells), 3, targets.shape[1]))
            for i, d in enumerate(pm.dwells):
                for j in range(targets.shape[1]):
                    e = np.zeros(targets.shape[1])
                    e[j] = h[j]
                    jac[i, :, j] = (read(d, d.target + e) - read(d, d.target - e)) / (2 * h[j])
            self._nest_cache[mid] = (targets, values, jac)
        return self._nest_cache[mid]

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
        frame = next(q for q in self.ctx.measurements if q.id == mid).frame
        if frame.mixed:
            return self._nest_sample(mid, c, t)
        got = self._angular(mid, c) if frame.rotary else self._linear(mid, c)
        if got is None:
            return None
        value, unit, p = got
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
        if self.unit is not None and self.unit != unit:  # the unit the laser declares (a
            table = ANGULAR_UNITS if unit == "urad" else LINEAR_UNITS  # length for an angle:
            return LaserSample(t, value / table.get(self.unit, 1.0), self.unit)  # refused)
        return LaserSample(t, value, unit)


    def _nest_sample(self, mid: str, c: ControlSample, t: float) -> LaserSample | None:
        """An R-test's sample: three channels, each with its own noise."""
        got = self._nest(mid, c)
        if got is None:
            return None
        v = got[0].copy()
        if self.noise > 0:
            v += np.array(_gauss(self.seed, mid, round((t - self._t0) * 1e6), 2, self.noise, 3))
        unit = self.unit or "um"
        if unit not in LINEAR_UNITS:
            raise VolcalInputError(f"the simulated laser: unit={unit!r} for an R-test, whose "
                                   "sensors read lengths (um, mm...)")
        vals = tuple(float(x) / LINEAR_UNITS[unit] for x in v)
        return LaserSample(t, vals[0], unit, channels=vals)


register_control("sim", SimulatedControl, "simulated control: the planned program, timed",
                 simulated=True)
register_laser("sim", SimulatedLaser, "simulated laser on volcal's virtual machine")
