"""The trigger rule: when a reading is taken, fed the samples of the control and the laser.

A point is accepted when

1. the capture is **armed**: the program has started (the control reported a running
   program, or the axes moved: ``in_motion`` or a position change larger than the target
   window since the capture began); nothing is taken before;
2. the program is not paused (``program_running`` is not False: an ``M0`` stop or a feed
   hold of a control that reports it) and the axes do not move (``in_motion`` is not True);
3. the control stands at the **expected** planned target: every axis within
   ``window_mm`` of it, reached from the planned **approach direction** (the last
   ``approach_mm`` of the path points within 60 degrees of the programmed move); a rotary
   test compares its rotary axis' angle (``window_deg``, ``approach_deg``; modulo 360 on
   a full-circle axis, :mod:`volcal.capture.frame`) and its approach direction (the sign
   of the last turn: ISO 230-2's bidirectional runs with the program's overrun). A rest at
   the expected target from the wrong side, at another reading's target, or a rest as long
   as the programmed dwell where the plan has none, is refused
   (:class:`CaptureMismatch`, naming the planned and the seen positions); a stop at an
   approach, overrun or start point is no reading and is passed over;
4. **both signals are stable for** ``stable_s`` seconds, tested against their noise: over
   the trailing ``stable_s`` window (which must lie inside the dwell, after the last
   control sample paused or in motion: an R-test's operator stop, where the sphere is put
   in the nest and the sensors zeroed, stands at its first pose and is no part of the
   dwell that follows it; a control that reports no program status cannot show that
   stop, and there the reading of a dwell the program reaches through an operator stop,
   :attr:`PlannedDwell.after_stop`, is the **last** stable window before the machine
   leaves: the dwell after the cycle start ends the stop), the means of its two
   halves differ by at most ``k_sigma`` standard errors (``k_sigma * sigma * sqrt(1/n1 +
   1/n2)``: catches creep and settling), and no sample lies farther than ``k_sigma + 2``
   sigma from the window's mean (catches a jump); ``sigma`` is the signal's noise,
   estimated robustly from the successive differences of the samples taken at rest
   (``1.4826 * MAD / sqrt(2)``, pooled over the capture, never below the floor
   ``laser_noise`` / ``control_noise_mm``), not the first sample's value;
5. the window holds at least ``min_samples`` samples of each signal and no gap longer
   than ``max_gap_s`` (shorter polling gaps are tolerated; a longer one starts the window
   again).

The accepted value is the mean of the laser samples of the window, the position the mean
of the control's. Each programmed dwell gives **exactly one** event: the accepted point,
or, when the control leaves the target before a stable window was found, ``missed``
(never a guess). The control has left a dwell when it moves, the program pauses, or an
axis lies beyond the window by more than ``k_sigma`` times its noise at rest (jitter
across the window's edge is no departure). A rest at the *next* target after a polling
gap that swallowed a whole dwell records that dwell as missed too.

After a resume (``done`` lists the readings already recorded) the rule expects the first
reading not recorded: the program may have gone on while the capture was down. If the
machine stands at the program's start pose (its operator stop) or dwells at the first
reading, the program was started again: the rule follows it from there and passes over
the readings already recorded (:class:`Replayed`, never written again). Until one of
the two happens, the program's other stops are passed over (with a note), not refused.
On a full-circle rotary axis only the start pose says so: the first target (0 deg) is
also the pass' last (360 deg), reached from the same side.
When the control reports the program line and the dwells know theirs
(:attr:`PlannedDwell.lines`, from ``--programs``), the line names the dwell the machine
stands in: a later run's dwell at the same target is never taken for the missing one.

The rule is pure: no clock, no input or output; :mod:`volcal.capture.runner` feeds it.

References
----------
Keysight (Agilent) 5530 Dynamic Calibrator user's guide, "Automatic triggering": target
window, trigger dwell. ISO 230-2:2014, 5.3 (approach directions of the standard cycle).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.capture.frame import LINEAR, Frame
from volcal.capture.plan import PlannedDwell
from volcal.capture.samples import ControlSample, LaserSample, to_base_unit
from volcal.errors import ParameterError, VolcalInputError

__all__ = ["Accepted", "CaptureMismatch", "Missed", "Note", "Replayed", "TriggerEvent",
           "TriggerParams", "TriggerRule", "noise_sigma", "is_stable"]


@dataclass(frozen=True)
class TriggerParams:
    """Parameters of the trigger rule (see the module's docstring).

    Attributes
    ----------
    window_mm : float
        Target window: every axis within this distance of the planned target [mm].
    stable_s : float
        Time both signals must be stable before a point is accepted (the "trigger dwell")
        [s]; at most 3/4 of the programmed dwell.
    k_sigma : float
        Stability threshold in standard errors of the noise.
    laser_noise : float
        Floor of the laser's noise standard deviation [um or urad] (its resolution).
    control_noise_mm : float
        Floor of the control position's noise standard deviation [mm].
    max_gap_s : float
        Longest gap between two samples of one signal inside a stable window [s].
    min_samples : int
        Fewest samples of each signal in a stable window.
    approach_mm : float
        Length of path looked back to find the approach direction [mm] (longer than an
        overshoot, shorter than the overrun).
    window_deg : float
        Target window of a rotary test: the rotary axis within this angle of the
        commanded one [deg].
    control_noise_deg : float
        Floor of the control's angle noise [deg] (a rotary test).
    approach_deg : float
        Angle looked back to find the approach direction of a rotary test [deg] (longer
        than an overshoot, shorter than the overrun ``volcal program`` turns, 2 deg).
    """

    window_mm: float = 0.010
    stable_s: float = 1.0
    k_sigma: float = 4.0
    laser_noise: float = 0.01
    control_noise_mm: float = 0.0005
    max_gap_s: float = 0.5
    min_samples: int = 5
    approach_mm: float = 0.2
    window_deg: float = 0.005
    control_noise_deg: float = 0.0005
    approach_deg: float = 0.2

    def check(self, program_dwell_s: float | None = None) -> None:
        """Raise :class:`~volcal.errors.ParameterError` for a value the rule cannot use.

        Parameters
        ----------
        program_dwell_s : float, optional
            The programmed dwell [s]: ``stable_s`` must fit in 3/4 of it.
        """
        for name in ("window_mm", "stable_s", "k_sigma", "laser_noise", "control_noise_mm",
                     "max_gap_s", "approach_mm", "window_deg", "control_noise_deg",
                     "approach_deg"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ParameterError(f"{{{name}=}}{v!r}: expected a positive number")
        if not (isinstance(self.min_samples, int) and self.min_samples >= 3):
            raise ParameterError(f"{{min_samples=}}{self.min_samples!r}: expected >= 3")
        if self.max_gap_s >= self.stable_s:
            raise ParameterError(f"{{max_gap_s=}}{self.max_gap_s:g} s must be shorter than "
                                 f"{{stable_s=}}{self.stable_s:g} s")
        if program_dwell_s is not None and self.stable_s > 0.75 * program_dwell_s:
            raise ParameterError(
                f"{{stable_s=}}{self.stable_s:g} s does not fit in the programmed dwell of "
                f"{program_dwell_s:g} s (at most 3/4 of it): program a longer dwell "
                "(volcal program --dwell-s) or shorten the stable time")


@dataclass(frozen=True)
class Accepted:
    """A point accepted for ``reading``.

    Attributes
    ----------
    reading : int
        Data row (0-based).
    time_s : float
        End of the stable window [s].
    value : float
        Mean laser reading over the window [um or urad, ``unit``].
    unit : str
        ``'um'`` or ``'urad'``.
    sigma : float
        The laser noise the window was tested against [um or urad].
    n : int
        Laser samples averaged.
    position_mm : tuple of float
        Mean control position over the window, in the measurement's frame: X, Y, Z [mm],
        or the rotary axis' angle [deg] (:class:`volcal.capture.frame.Frame`).
    window_s : tuple of float
        Start and end of the window [s].
    values : tuple of float
        A reading of several channels (an R-test's three sensors): each channel's mean
        [``unit``], ``value`` the first; empty for one channel.
    """

    reading: int
    time_s: float
    value: float
    unit: str
    sigma: float
    n: int
    position_mm: tuple[float, ...]
    window_s: tuple[float, float]
    values: tuple[float, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """As a journal object."""
        d = {"reading": self.reading, "t": self.time_s, "value": self.value,
             "unit": self.unit, "sigma": self.sigma, "n": self.n,
             "pos": list(self.position_mm), "window": list(self.window_s)}
        if self.values:
            d["values"] = list(self.values)
        return d


@dataclass(frozen=True)
class Missed:
    """A programmed dwell without a stable reading: recorded ``missed``, never guessed."""

    reading: int
    time_s: float
    reason: str

    def to_json(self) -> dict[str, Any]:
        """As a journal object."""
        return {"reading": self.reading, "t": self.time_s, "reason": self.reason}


@dataclass(frozen=True)
class Replayed:
    """The dwell of a reading already recorded (a program run again after a resume)."""

    reading: int
    time_s: float

    def to_json(self) -> dict[str, Any]:
        """As a journal object."""
        return {"reading": self.reading, "t": self.time_s}


@dataclass(frozen=True)
class Note:
    """Something the technician should know (a dwell passed over, a gap)."""

    time_s: float
    text: str

    def to_json(self) -> dict[str, Any]:
        """As a journal object."""
        return {"t": self.time_s, "text": self.text}


TriggerEvent = Accepted | Missed | Replayed | Note


class CaptureMismatch(VolcalInputError):
    """The machine stands where the plan has no reading, or reached it from the wrong side."""


def noise_sigma(diffs: NDArray[np.float64], floor: float) -> float:
    """Noise standard deviation from successive differences, robustly (MAD).

    Parameters
    ----------
    diffs : ndarray
        Differences of successive samples of a signal at rest.
    floor : float
        Smallest value returned (the signal's resolution).

    Returns
    -------
    float
        ``max(floor, 1.4826 * median(|d - median(d)|) / sqrt(2))``: white noise of
        standard deviation s gives differences of standard deviation s*sqrt(2); a slow
        creep shifts the median of the differences and is left out. Differences of
        exactly zero (a sample repeated because the source was polled faster than it
        updates) are left out.
    """
    d = np.asarray(diffs, float)
    d = d[d != 0.0]  # a repeated sample (a source polled faster than it updates) says nothing
    if d.size < 4:
        return floor
    mad = float(np.median(np.abs(d - np.median(d))))
    return max(floor, 1.4826 * mad / math.sqrt(2.0))


def is_stable(times: NDArray[np.float64], values: NDArray[np.float64], sigma: float,
              t0: float, t1: float, p: TriggerParams) -> bool:
    """Whether a signal is stable over the window ``[t0, t1]`` (rule items 4 and 5).

    Parameters
    ----------
    times, values : ndarray
        The samples in the window [s], [signal's unit].
    sigma : float
        The signal's noise standard deviation [signal's unit].
    t0, t1 : float
        The window [s].
    p : TriggerParams

    Returns
    -------
    bool
    """
    n = times.size
    if n < p.min_samples:
        return False
    edges = np.concatenate([[t0], times, [t1]])
    if float(np.max(np.diff(edges))) > p.max_gap_s:
        return False
    half = times < 0.5 * (t0 + t1)
    n1, n2 = int(half.sum()), int((~half).sum())
    if n1 < 2 or n2 < 2:
        return False
    m1, m2 = float(values[half].mean()), float(values[~half].mean())
    if abs(m2 - m1) > p.k_sigma * sigma * math.sqrt(1.0 / n1 + 1.0 / n2):
        return False
    return float(np.max(np.abs(values - values.mean()))) <= (p.k_sigma + 2.0) * sigma


class _Signal:
    """Recent samples of one signal (scalar or vector) and its pooled noise differences."""

    def __init__(self, horizon_s: float, dim: int) -> None:
        self.t: deque[float] = deque()
        self.v: deque[NDArray[np.float64]] = deque()
        self.horizon = horizon_s
        self.diffs: deque[NDArray[np.float64]] = deque(maxlen=512)
        self.dim = dim
        self._added = 0
        self._pooled: tuple[int, tuple[float, ...], NDArray[np.float64]] | None = None

    def add(self, t: float, v: NDArray[np.float64], max_gap: float, pool: bool) -> bool:
        """Append; True when a gap longer than ``max_gap`` preceded the sample."""
        gap = bool(self.t) and t - self.t[-1] > max_gap
        if pool and self.t and not gap:
            self.diffs.append(v - self.v[-1])
            self._added += 1
        self.t.append(t)
        self.v.append(v)
        while self.t and self.t[0] < t - self.horizon:
            self.t.popleft()
            self.v.popleft()
        return gap

    def window(self, t0: float, t1: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        t = np.fromiter(self.t, float, len(self.t))
        sel = (t >= t0) & (t <= t1)
        v = (np.array(self.v, float).reshape(-1, self.dim) if self.v
             else np.zeros((0, self.dim)))
        return t[sel], v[sel]

    def sigma(self, floor: float | NDArray[np.float64], local: NDArray[np.float64]
              ) -> NDArray[np.float64]:
        """Per-component noise: pooled differences at rest, else the window's own.

        Parameters
        ----------
        floor : float or ndarray, shape (dim,)
            The smallest value [signal's unit], or one per component (a mixed frame).
        local : ndarray, shape (n, dim)
            The window's samples.

        Returns
        -------
        ndarray, shape (dim,)
        """
        fl = np.broadcast_to(np.asarray(floor, float), (self.dim,))
        key = tuple(float(v) for v in fl)
        if len(self.diffs) >= 16:  # the pooled estimate, renewed every 16 differences
            c = self._pooled
            if c is None or c[1] != key or self._added - c[0] >= 16:
                pooled = np.array(self.diffs, float).reshape(-1, self.dim)
                c = (self._added, key,
                     np.array([noise_sigma(pooled[:, j], fl[j]) for j in range(self.dim)]))
                self._pooled = c
            return c[2]
        d = np.diff(local, axis=0)
        return np.array([noise_sigma(d[:, j], fl[j]) for j in range(self.dim)])


class TriggerRule:
    """The trigger rule as a state machine fed samples (see the module's docstring).

    Parameters
    ----------
    dwells : sequence of PlannedDwell
        The programmed dwells in the program's order.
    params : TriggerParams
    waypoints : ndarray, shape (k, 3), optional
        Points where the program stops without a reading (start, approach, overrun) [mm].
    unit : str
        The unit of the readings: ``'um'`` (displacements) or ``'urad'`` (angles).
    done : collection of int, optional
        Readings already recorded (a resumed capture).
    label : str
        The measurement's id, for the messages.
    start : ndarray, shape (3,), optional
        The program's start pose [mm] (its operator stop). After a resume, the machine
        standing there means the program was started again: the rule follows it from
        the first reading.
    frame : Frame
        The coordinates compared (:data:`volcal.capture.frame.LINEAR`, a rotary axis'
        angle, or an R-test's pose of every axis, each within the window of its unit):
        ``dwells``' targets and approaches, ``waypoints`` and ``start`` are in them.
    channels : int
        Values of each laser sample (3: an R-test nest's sensors, each tested stable).
    """

    def __init__(self, dwells: Sequence[PlannedDwell], params: TriggerParams | None = None,
                 waypoints: NDArray[np.float64] | None = None, unit: str = "um",
                 done: Collection[int] = (), label: str = "",
                 start: NDArray[np.float64] | None = None, frame: Frame = LINEAR,
                 channels: int = 1) -> None:
        self.start = None if start is None else np.asarray(start, float)
        self.p = params or TriggerParams()
        self.p.check(min((d.seconds for d in dwells), default=None))
        self.frame = frame
        n = len(frame.axes)
        self._window: float | NDArray[np.float64]
        self._cnoise: float | NDArray[np.float64]
        self._window, self._cnoise, self._approach = (
            (self.p.window_deg, self.p.control_noise_deg, self.p.approach_deg)
            if frame.rotary else (self.p.window_mm, self.p.control_noise_mm,
                                  self.p.approach_mm))
        if frame.mixed:
            self._window = frame.per_axis(self.p.window_mm, self.p.window_deg)
            self._cnoise = frame.per_axis(self.p.control_noise_mm, self.p.control_noise_deg)
        self.channels = int(channels)
        self.dwells = list(dwells)
        self.waypoints = (np.zeros((0, n)) if waypoints is None
                          else np.asarray(waypoints, float).reshape(-1, n))
        self.unit = unit
        self.label = label
        self.done: set[int] = {int(i) for i in done}
        self.cursor = self._next_undone(0)
        self._may_replay = bool(self.done) and self.cursor > 0
        horizon = 2.0 * self.p.stable_s + self.p.max_gap_s
        self._ctrl = _Signal(horizon, n)
        self._laser = _Signal(horizon, self.channels)
        self._path: deque[NDArray[np.float64]] = deque(maxlen=4096)
        self._first_pos: NDArray[np.float64] | None = None
        self._pos: NDArray[np.float64] | None = None
        self._moving: bool | None = None
        self._running: bool | None = None
        self.armed = False
        self._dwell: int | None = None        # the reading whose dwell the machine is in
        self._decided = False                 # that dwell already gave its event
        self._in_window_since: float | None = None
        self._rest_since: float | None = None
        self._blocked_at: float | None = None  # the last sample paused, moving or unarmed
        self._status_seen = False             # the control reports its program's status
        self._held: Accepted | None = None    # the latest window of a dwell after a stop
        self._unsettled_at: float | None = None  # the sensors changed after it, at rest
        self._held_noted: set[int] = set()    # the readings whose hold was said (a Note)
        self._passed = False                  # the current rest is passed over
        self._ctrl_gap = False                # a control gap since the last dwell
        self._line: int | None = None         # the program line the control reports
        self._by_line = {ln: k for k, d in enumerate(self.dwells) for ln in d.lines}
        self.last_time = 0.0

    # ---------------------------------------------------------------- state
    @property
    def complete(self) -> bool:
        """Every planned reading is recorded (accepted or missed)."""
        return self.cursor >= len(self.dwells)

    @property
    def expected(self) -> PlannedDwell | None:
        """The dwell the rule waits for."""
        return None if self.complete else self.dwells[self.cursor]

    @property
    def in_dwell(self) -> int | None:
        """The reading whose dwell the machine stands in, if any."""
        return self._dwell

    def laser_sigma(self) -> float:
        """The laser noise estimate now [um or urad]."""
        _, v = self._laser.window(self.last_time - self.p.stable_s, self.last_time)
        return float(self._laser.sigma(self.p.laser_noise, v)[0])

    def _index(self, d: PlannedDwell) -> int:
        return next(i for i, e in enumerate(self.dwells) if e is d)

    def _next_undone(self, i: int) -> int:
        while i < len(self.dwells) and self.dwells[i].reading in self.done:
            i += 1
        return i

    # ---------------------------------------------------------------- feeding
    def feed_control(self, s: ControlSample) -> list[TriggerEvent]:
        """Feed one control sample.

        Parameters
        ----------
        s : ControlSample

        Returns
        -------
        list of TriggerEvent
            The events it decided (usually none).
        """
        if s.status not in ("ok", "ended") or self.complete:
            return []
        p = self.frame.follow(self.frame.read(s.positions), self._pos)
        t = float(s.time_s)
        self.last_time = max(self.last_time, t)
        if self._first_pos is None:
            self._first_pos = p
        self._moving, self._running = s.in_motion, s.program_running
        self._status_seen = self._status_seen or s.program_running is not None
        self._line = s.line
        if not self.armed and (s.program_running is True or s.in_motion is True
                               or bool(np.any(np.abs(p - self._first_pos) > self._window))):
            self.armed = True
        if not self._path or float(np.linalg.norm(p - self._path[-1])) \
                >= self._approach / 20.0:
            self._path.append(p)
        if self._ctrl.add(t, p, self.p.max_gap_s, pool=self._dwell is not None):
            self._ctrl_gap = True
        self._pos = p
        return self._evaluate(t)

    def feed_laser(self, s: LaserSample) -> list[TriggerEvent]:
        """Feed one laser sample.

        Parameters
        ----------
        s : LaserSample

        Returns
        -------
        list of TriggerEvent
            The events it decided (usually none).
        """
        if s.status != "ok" or self.complete or not all(map(math.isfinite, s.values)):
            return []
        if len(s.values) != self.channels:
            raise VolcalInputError(
                f"the laser sends {len(s.values)} value(s) per reading; "
                f"{self.label or 'the'} measurement needs {self.channels}"
                + (" (an R-test: the nest's three sensors, e.g. a stream line 'dx,dy,dz' "
                   "with channels=3)" if self.channels == 3 else ""))
        conv = [to_base_unit(float(x), s.unit) for x in s.values]
        if any(base != self.unit for _, base in conv):
            raise VolcalInputError(f"the laser sends {s.unit!r} readings; {self.label or 'the '}"
                                   f"{' ' if self.label else ''}measurement needs "
                                   f"{'a length' if self.unit == 'um' else 'an angle'}")
        t = float(s.time_s)
        self.last_time = max(self.last_time, t)
        self._laser.add(t, np.array([v for v, _ in conv]), self.p.max_gap_s,
                        pool=self._dwell is not None)
        return self._evaluate(t)

    # ---------------------------------------------------------------- the rule
    def _near(self, target: NDArray[np.float64], slack: float | NDArray[np.float64] = 0.0
              ) -> bool:
        assert self._pos is not None
        return bool(np.all(np.abs(self.frame.delta(self._pos, target))
                           <= self._window + slack))

    def _noise_slack(self, t: float) -> NDArray[np.float64]:
        """How far past the window the control's noise may carry a machine at rest.

        ``k_sigma`` times the control's noise per axis (pooled at rest, never below the
        floor): a machine in a dwell has left it only beyond the window by more than
        that (its jitter across the window's edge is no departure).
        """
        _, v = self._ctrl.window(t - self.p.stable_s, t)
        floor = np.broadcast_to(np.asarray(self._cnoise, float), (len(self.frame.axes),))
        if v.shape[0] < 3:
            return self.p.k_sigma * floor
        return self.p.k_sigma * self._ctrl.sigma(self._cnoise, v)

    def _ctrl_stable(self, t0: float, t1: float) -> tuple[bool, NDArray[np.float64]]:
        tt, v = self._ctrl.window(t0, t1)
        n = len(self.frame.axes)
        if tt.size == 0:
            return False, np.full(n, np.nan)
        sig = self._ctrl.sigma(self._cnoise, v)
        ok = all(is_stable(tt, v[:, j], float(sig[j]), t0, t1, self.p) for j in range(n))
        return ok, v.mean(axis=0)

    def _approach_seen(self) -> NDArray[np.float64] | None:
        assert self._pos is not None
        for q in reversed(self._path):
            d = self._pos - q
            n = float(np.linalg.norm(d))
            if n >= self._approach:
                return d / n
        return None

    def _where(self, d: PlannedDwell) -> str:
        row = f"row {d.reading + 2}"
        run = "" if d.run is None else f", run {d.run}"
        return f"{self.label + ' ' if self.label else ''}reading {d.reading + 1} ({row}{run})"

    def _evaluate(self, t: float) -> list[TriggerEvent]:
        if self.complete or self._pos is None:
            return []
        if self._dwell is not None:
            return self._in_dwell(t)
        d = self.dwells[self.cursor]
        if self._near(d.target):
            self._in_window_since = (t if self._in_window_since is None
                                     else self._in_window_since)
        else:
            self._in_window_since = None
        if (self._may_replay and self.start is not None and self._near(self.start)
                and (self._running is False or self._ctrl_stable(t - self.p.stable_s, t)[0])):
            self._may_replay = False  # the program was started again: follow it from reading 1
            self.cursor = 0
            self._in_window_since = None
            return [Note(t, f"{self.label}: the program stands at its start pose: the capture "
                            "follows it from its first reading and keeps the readings "
                            "already recorded")]
        if not self.armed or self._running is False or self._moving is True:
            self._rest_since, self._passed = None, False
            self._blocked_at = t  # a reading's window starts after it (the dwell's own)
            return []
        ok, _ = self._ctrl_stable(t - self.p.stable_s, t)
        if not ok:
            self._rest_since, self._passed = None, False
            return []
        if self._rest_since is None:
            self._rest_since = t - self.p.stable_s
        if self._passed:
            return []
        return self._classify(t)

    def _direction_ok(self, d: PlannedDwell, seen: NDArray[np.float64] | None) -> bool:
        return d.approach is None or (seen is not None and float(seen @ d.approach) >= 0.5)

    def _classify(self, t: float) -> list[TriggerEvent]:
        assert self._pos is not None
        d = self.dwells[self.cursor]
        seen = self._approach_seen()
        events: list[TriggerEvent] = []
        j = self._by_line.get(self._line) if self._line is not None else None
        if self._may_replay and j is not None and self._near(self.dwells[j].target):
            return self._resume_at(j, t)  # the control names the dwell it stands in
        if self._near(d.target) and self._direction_ok(d, seen):
            return self._enter(d, t)
        first = self.dwells[0]
        if (self._may_replay and not self._by_line and self.frame.period is None
                and self._near(first.target) and self._direction_ok(first, seen)):
            # (not on a full circle: its first target, 0 deg, is 360 deg too, read at the
            # end of the pass from the same side: the program's start pose says it restarted)
            events.append(Note(t, f"{self.label}: the program runs again from its first "
                                  "reading; the readings already recorded are kept"))
            return events + self._enter(first, t)
        if self._near(d.target) and not self._may_replay:
            if seen is None:
                self._passed = True
                return [Note(t, f"{self._where(d)}: passed over, the approach to it was not "
                                "seen (the capture started at the target)")]
            raise CaptureMismatch(
                f"{self._where(d)}: the plan reaches {self._fmt(d.target)}"
                f"{self._dir(d.approach)}; the control reached it moving "
                f"{self._vec(seen)}. The program on the control is not the planned one "
                "(approach and overrun moves differ): write it with volcal program")
        if self.waypoints.size and bool(np.any(np.all(
                np.abs(self.frame.delta(self._pos, self.waypoints)) <= self._window, axis=1))):
            self._passed = True  # a stop at a start, approach or overrun point
            return []
        if self._may_replay:  # resumed: wait for the program to reach the first missing
            self._passed = True  # reading or to start again; its other stops are passed
            return [Note(t, f"{self.label}: resumed, waiting for reading {d.reading + 1} or "
                            f"the program's start; the control stands at "
                            f"{self._fmt(self._pos)}")]
        nxt = self.cursor + 1
        if (nxt < len(self.dwells) and self._ctrl_gap and self._near(self.dwells[nxt].target)
                and self._direction_ok(self.dwells[nxt], seen)):
            events.append(Missed(d.reading, t, "no control samples during its dwell (a "
                                               "polling gap longer than the dwell)"))
            self.done.add(d.reading)
            self.cursor = nxt
            return events + self._enter(self.dwells[nxt], t)
        other = [e for e in self.dwells if self._near(e.target)]
        rest = t - (self._rest_since if self._rest_since is not None else t)
        if other or rest >= max(d.seconds, self.p.stable_s):
            what = (f"the target of {self._where(other[0])}" if other
                    else "a position the program has no reading at")
            raise CaptureMismatch(
                f"{self._where(d)}: the plan expects {self._fmt(d.target)}"
                f"{self._dir(d.approach)}; the control stands at {self._fmt(self._pos)}, "
                f"{what}. Run the measurement's own program from its start (volcal "
                "program), or resume the capture where the program stands")
        return events

    def _resume_at(self, j: int, t: float) -> list[TriggerEvent]:
        """A resumed capture: the control's program line says the machine dwells at ``j``."""
        d = self.dwells[j]
        if j == self.cursor:
            return self._enter(d, t)
        if d.reading in self.done:  # the program was run again from an earlier line
            return [Note(t, f"{self.label}: the program runs again from reading "
                            f"{d.reading + 1} (line {self._line}); the readings already "
                            "recorded are kept")] + self._enter(d, t)
        self._passed = True  # the program is past the first missing reading: wait
        return [Note(t, f"{self.label}: resumed, waiting for reading "
                        f"{self.dwells[self.cursor].reading + 1} or the program's start; "
                        f"the program dwells at reading {d.reading + 1} (line {self._line})")]

    def _enter(self, d: PlannedDwell, t: float) -> list[TriggerEvent]:
        tracked = self.dwells[self.cursor]  # the target _in_window_since was kept for
        self._dwell = self._index(d)
        self.cursor = self._dwell
        self._may_replay = False
        self._decided = False
        self._ctrl_gap = False
        if self._in_window_since is None or d is not tracked:
            self._in_window_since = self._rest_since
        return self._in_dwell(t)

    def _in_dwell(self, t: float) -> list[TriggerEvent]:
        assert self._dwell is not None
        d = self.dwells[self._dwell]
        leaving = (self._moving is True or self._running is False
                   or (not self._near(d.target)  # the noise margin only when it matters
                       and not self._near(d.target, self._noise_slack(t))))
        if leaving:
            events: list[TriggerEvent] = []
            if not self._decided:
                events.append(self._leave_held(d, t))
            self._held, self._unsettled_at = None, None
            self._dwell = None
            self._in_window_since = None
            self._rest_since, self._passed = None, False
            events += self._evaluate(t) if not self.complete else []
            return events
        if self._decided:
            return []
        t0 = t - self.p.stable_s
        start = self._in_window_since if self._in_window_since is not None else t
        if t0 < start or (self._blocked_at is not None and t0 <= self._blocked_at):
            return []  # (an operator stop just before the dwell is no part of it)
        ok, pos = self._ctrl_stable(t0, t)
        if not ok:
            return []
        lt, lv = self._laser.window(t0, t)
        sig = (self._laser.sigma(self.p.laser_noise, lv) if lv.size
               else np.full(self.channels, math.inf))
        if lv.size == 0 or not all(is_stable(lt, lv[:, j], float(sig[j]), t0, t, self.p)
                                   for j in range(self.channels)):
            if self._held is not None and self._unsettled_at is None:
                self._unsettled_at = t  # the sensors change with the machine at rest
            return []
        mean = lv.mean(axis=0)
        ev = Accepted(d.reading, t, float(mean[0]), self.unit, float(sig.max()), int(lt.size),
                      tuple(float(v) for v in pos), (t0, t),
                      tuple(float(v) for v in mean) if self.channels > 1 else ())
        if d.after_stop and not self._status_seen:
            # the operator stop and the dwell after it look alike here: hold the latest
            # window, taken when the machine leaves (the dwell ends what the stop began)
            first = self._held is None and d.reading not in self._held_noted
            self._held, self._unsettled_at = ev, None
            if not first:
                return []
            self._held_noted.add(d.reading)
            return [Note(t, f"{self._where(d)}: the program stops at this pose (M0) and the "
                            "control reports no program status: the reading is the last "
                            "stable window before the machine leaves the pose")]
        self._decided = True
        return [self._record(d, ev)]

    def _leave_held(self, d: PlannedDwell, t: float) -> TriggerEvent:
        """The machine leaves ``d``: its held window (a dwell after a stop), else missed.

        The window is taken when the sensors did not change after it, but for the last
        ``max_gap_s`` before the control's sample showed the machine leaving (the laser
        sees the motion first); a longer change at rest is the sensors zeroed after the
        window (in the operator stop), and no stable window followed: missed.
        """
        held, since = self._held, self._unsettled_at
        if held is None:
            return self._missed(d, t)
        if since is not None and t - since > self.p.max_gap_s:
            return self._record(d, Missed(
                d.reading, t, f"the sensors changed {t - since:.3g} s before the machine left "
                f"(zeroed after the operator stop?) and did not stand still again for "
                f"{self.p.stable_s:g} s"))
        return self._record(d, held)

    def _missed(self, d: PlannedDwell, t: float) -> TriggerEvent:
        lt, lv = self._laser.window(t - self.p.stable_s, t)
        if lv.size == 0:
            why = "no laser reading during the dwell"
        else:
            sig = float(self._laser.sigma(self.p.laser_noise, lv).max())
            why = (f"the readings never stood still for {self.p.stable_s:g} s (last "
                   f"{self.p.stable_s:g} s: spread {float(np.ptp(lv)):.3g} {self.unit} against a "
                   f"noise of {sig:.3g} {self.unit})")
        return self._record(d, Missed(d.reading, t, why))

    def _record(self, d: PlannedDwell, ev: Accepted | Missed) -> TriggerEvent:
        """Advance past ``d``; a reading recorded before is replayed, not recorded again."""
        already = d.reading in self.done
        self.done.add(d.reading)
        self.cursor = self._index(d) + 1  # the program's next dwell
        if already:
            return Replayed(d.reading, ev.time_s)
        return ev

    # ---------------------------------------------------------------- words
    def _fmt(self, p: NDArray[np.float64]) -> str:
        return self.frame.fmt(p)

    @staticmethod
    def _vec(u: NDArray[np.float64]) -> str:
        return "(" + ", ".join(f"{v + 0.0:+.3f}" for v in np.round(u, 3)) + ")"

    def _dir(self, u: NDArray[np.float64] | None) -> str:
        return "" if u is None else f" approached along {self._vec(u)}"
