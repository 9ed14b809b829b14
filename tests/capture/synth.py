"""Synthetic control and laser streams for the trigger rule's tests.

A 1-axis program along X: from ``home`` the machine moves (constant acceleration, feed)
to each target, reached from its planned side, and dwells there. The control is sampled
at ``rate`` Hz with white noise; the laser reads the actual displacement [um] plus the
true error of the target plus white noise. Options add what a shop floor adds: polling
gaps, an overshoot at the end of each move, a creeping reading during chosen dwells, a
long wait before the program starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from volcal.capture.plan import PlannedDwell
from volcal.capture.samples import ControlSample, LaserSample


@dataclass
class Program:
    """Targets [mm], approach signs, the dwell [s] and what the stream does."""

    targets: list[float]
    signs: list[int]
    dwell_s: float = 3.0
    feed_mm_s: float = 20.0
    accel: float = 200.0
    overrun_mm: float = 2.0
    home: float = -10.0
    wait_s: float = 2.0          # standing at home before the program starts
    rate: float = 50.0           # samples per second of each signal
    control_noise_mm: float = 0.0002
    laser_noise_um: float = 0.05
    overshoot_mm: float = 0.0
    creep_um_s: dict[int, float] = field(default_factory=dict)   # reading -> creep
    gaps: list[tuple[float, float, str]] = field(default_factory=list)  # t0, t1, which
    flags: bool = True
    errors_um: list[float] | None = None
    seed: int = 0
    lines: bool = False          # the control reports the program line (as LinuxCNC does)

    def dwells(self) -> list[PlannedDwell]:
        out = []
        for i, (x, s) in enumerate(zip(self.targets, self.signs, strict=True)):
            out.append(PlannedDwell(i, np.array([x, 0.0, 0.0]), np.array([float(s), 0, 0]),
                                    self.dwell_s, 1, "+" if s > 0 else "-",
                                    (100 + 2 * i, 101 + 2 * i) if self.lines else ()))
        return out

    def error(self, i: int) -> float:
        if self.errors_um is None:
            return 2.0 * math.sin(i) + 0.5 * i
        return self.errors_um[i]

    def waypoints(self) -> np.ndarray:
        """Where the program stops without a reading: home and the approach points."""
        pts = [[self.home, 0, 0]]
        for seg in self.segments():
            if seg[0] == "move" and seg[4] is None:
                pts.append([seg[3], 0, 0])
        return np.array(pts, float)

    def segments(self) -> list[tuple]:
        """(kind, t0, t1, x0 or x, x1, reading)."""
        segs: list[tuple] = []
        t, x = 0.0, self.home
        segs.append(("wait", t, t + self.wait_s, x, x, None))
        t += self.wait_s

        def move(x1: float, reading: int | None) -> None:
            nonlocal t, x
            d = abs(x1 - x)
            if d < 1e-12:
                return
            v, a = self.feed_mm_s, self.accel
            T = d / v + v / a if d >= v * v / a else 2 * math.sqrt(d / a)
            segs.append(("move", t, t + T, x, x1, reading))
            t, x = t + T, x1

        for i, (xt, s) in enumerate(zip(self.targets, self.signs, strict=True)):
            if not (s * (xt - x) > 1e-9):  # approach from the planned side
                move(xt - s * self.overrun_mm, None)
            move(xt, i)
            segs.append(("dwell", t, t + self.dwell_s, xt, xt, i))
            t += self.dwell_s
        segs.append(("end", t, t + 3.0, x, x, None))
        return segs

    def dwell_intervals(self) -> dict[int, tuple[float, float]]:
        return {s[5]: (s[1], s[2]) for s in self.segments() if s[0] == "dwell"}

    def truth(self) -> list[float]:
        return [self.error(i) for i in range(len(self.targets))]

    def stream(self) -> list[ControlSample | LaserSample]:
        """Both signals, merged in time order."""
        rng = np.random.default_rng(self.seed)
        segs = self.segments()
        t_end = segs[-1][2]
        out: list[ControlSample | LaserSample] = []
        n = int(t_end * self.rate)
        last_move_end = None
        for k in range(n):
            t = k / self.rate
            seg = next(s for s in segs if s[1] <= t < s[2]) if t < t_end else segs[-1]
            kind, t0, t1, x0, x1, reading = seg
            moving = kind == "move"
            running = kind not in ("wait", "end")
            if moving:
                d = abs(x1 - x0)
                v, a = self.feed_mm_s, self.accel
                T = t1 - t0
                tt = t - t0
                if d >= v * v / a:
                    ta = v / a
                    s = (0.5 * a * tt * tt if tt < ta else
                         d - 0.5 * a * (T - tt) ** 2 if tt > T - ta else
                         0.5 * a * ta * ta + v * (tt - ta))
                else:
                    s = 0.5 * a * tt * tt if tt < T / 2 else d - 0.5 * a * (T - tt) ** 2
                x = x0 + math.copysign(s, x1 - x0)
                last_move_end = (t1, math.copysign(1.0, x1 - x0))
            else:
                x = x0
                if self.overshoot_mm > 0 and last_move_end is not None and kind == "dwell":
                    dt = t - last_move_end[0]
                    x += last_move_end[1] * self.overshoot_mm * math.exp(-dt / 0.15) * \
                        math.cos(2 * math.pi * 3.0 * dt)
            e = 0.0
            if reading is not None and kind == "dwell":
                e = self.error(reading) + self.creep_um_s.get(reading, 0.0) * (t - t0)
            elif reading is not None:
                e = self.error(reading)
            xc = x + rng.normal(0, self.control_noise_mm)
            lv = 1000.0 * (x - self.home) + e + rng.normal(0, self.laser_noise_um)
            dropped = {w for (g0, g1, w) in self.gaps if g0 <= t < g1}
            if "control" not in dropped:
                pos = {"X": xc, "Y": 0.0, "Z": 0.0}
                # the line of the move being made or last made (LinuxCNC's motion_line)
                line = (100 + 2 * reading if reading is not None else 99) if self.lines else None
                out.append(ControlSample(t, pos, moving if self.flags else None,
                                         running if self.flags else None, line=line))
            if "laser" not in dropped:
                out.append(LaserSample(t + 0.5 / self.rate, lv, "um"))
        out.sort(key=lambda s: s.time_s)
        return out


def run(rule, stream):
    """Feed a stream; the events in order."""
    events = []
    for s in stream:
        if isinstance(s, ControlSample):
            events += rule.feed_control(s)
        else:
            events += rule.feed_laser(s)
    return events


def deviation(p: Program, values: dict[int, float]) -> dict[int, float]:
    """Laser reading minus commanded displacement, as the capture writes it [um]."""
    return {i: v - 1000.0 * (p.targets[i] - p.home) for i, v in values.items()}
