"""Dialect-free program steps of one measurement: moves, dwells and comments.

Every reading of the session becomes one dwell at exactly its commanded pose, in the
session's order. Linear tests get the approach and overrun moves of the ISO 230-2
standard test cycle (ISO 230-2:2014, 5.3 and figure 1): each target is reached from
the side of its approach direction, so a reversal (at the ends of each pass and at the
start of each run) first goes past the target by the overrun and then comes back.
Approach points are kept inside the machine's travel; where that shortens or removes
an overrun the step list says so in a warning.

References
----------
ISO 230-2:2014, Test code for machine tools - Part 2: Determination of accuracy and
repeatability of positioning of numerically controlled axes, 5.3 (standard test cycle).
Optodyne application note (seed 001): an ISO part program that moves step by step and
pauses for each reading.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from volcal.errors import ParameterError, VolcalInputError
from volcal.model.names import AXES
from volcal.session.format import Measurement

MAX_FEED_MM_MIN = 10000.0
"""Highest feed accepted [mm/min]: measuring moves never need rapid traverse."""

MAX_DWELL_S = 999.0
"""Longest dwell accepted [s]."""

_TOL_MM = 1e-9


@dataclass(frozen=True)
class ProgramOptions:
    """Options of a measuring program.

    Parameters
    ----------
    dwell_s : float
        Dwell at each reading pose [s]; the laser captures automatically while the
        machine stands still.
    feed : float
        Feed of every move [mm/min], 0 < feed <= ``MAX_FEED_MM_MIN``.
    overrun_mm : float
        Overrun before a reversal in linear tests [mm] (ISO 230-2 approach).
    decimals : int
        Decimals of the coordinates written (3 = 0.001 mm, the usual input increment).
    safe_z_mm : float
        Z of the retract that starts every program, in machine coordinates [mm]
        (``G53`` / ``SUPA`` / ``M91``); 0 is the reference position, at the top of the Z
        travel on most machining centres.
    overrun_deg : float
        Overrun before a reversal in rotary tests [deg] (:mod:`volcal.program.rotary`;
        there ``feed`` is read in deg/min).
    """

    dwell_s: float = 4.0
    feed: float = 2000.0
    overrun_mm: float = 5.0
    decimals: int = 3
    safe_z_mm: float = 0.0
    overrun_deg: float = 2.0

    def check(self) -> None:
        """Raise :class:`VolcalInputError` for options no machine should run."""
        if not np.isfinite(self.dwell_s) or not 0 < self.dwell_s <= MAX_DWELL_S:
            raise ParameterError(f"{{dwell_s=}}{self.dwell_s}: expected 0 < dwell <= "
                                 f"{MAX_DWELL_S:g} s")
        if not np.isfinite(self.feed) or not 0 < self.feed <= MAX_FEED_MM_MIN:
            raise ParameterError(f"{{feed=}}{self.feed}: expected 0 < feed <= "
                                 f"{MAX_FEED_MM_MIN:g} mm/min (a measuring feed, not rapid)")
        if not np.isfinite(self.overrun_mm) or not 0 <= self.overrun_mm <= 100:
            raise ParameterError(f"{{overrun_mm=}}{self.overrun_mm}: expected 0..100 mm")
        if not np.isfinite(self.safe_z_mm):
            raise ParameterError(f"{{safe_z_mm=}}{self.safe_z_mm}: expected a finite number")
        if not np.isfinite(self.overrun_deg) or not 0 <= self.overrun_deg <= 30:
            raise ParameterError(f"overrun_deg={self.overrun_deg}: expected 0..30 deg")
        if not 0 <= self.decimals <= 5:
            raise ParameterError(f"{{decimals=}}{self.decimals}: expected 0..5")


OPERATOR_STOP_TEXT = ("at the start pose: check the optics and the laser signal, start the "
                      "laser capture, then press cycle start")
"""Message shown at the operator stop before the first reading."""


@dataclass(frozen=True)
class Step:
    """One step of a measuring program.

    Attributes
    ----------
    kind : str
        ``'move'`` (linear move at ``feed``), ``'dwell'`` (stand still for ``seconds``),
        ``'comment'``, ``'start'`` (the safe positioning to ``position``: retract Z in
        machine coordinates, then X and Y, then Z down; written once, first) or
        ``'stop'`` (operator stop with the message ``text``, before the first reading).
    position : tuple of float, optional
        Target of a move [mm].
    feed : float, optional
        Feed of a move [mm/min].
    seconds : float, optional
        Dwell time [s].
    text : str
        Comment text, or the role of a move (``'reading'``, ``'approach'``, ``'overrun'``).
    reading : int, optional
        Row of the session CSV (0-based data row) a dwell belongs to.
    """

    kind: str
    position: tuple[float, float, float] | None = None
    feed: float | None = None
    seconds: float | None = None
    text: str = ""
    reading: int | None = None


@dataclass
class StepList:
    """The steps of one measurement and the warnings found while building them."""

    steps: list[Step] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def setup_comments(m: Measurement) -> list[str]:
    """Comment lines naming the test and the optics set-up.

    Parameters
    ----------
    m : Measurement
        The planned measurement.

    Returns
    -------
    list of str
    """
    b = ", ".join(f"{v:+.4f}" for v in m.beam_direction)
    t = ", ".join(f"{v:g}" for v in m.tool_offset)
    lines = [f"volcal measurement {m.id}: {m.kind.replace('_', ' ')} test, {m.n} readings",
             f"optics: {m.target.replace('_', ' ')} on the tool at offset [{t}] mm",
             f"beam direction (machine axes): [{b}]"]
    from volcal.session.kinds import kind_of

    setup = kind_of(m.kind).program_setup_lines(m)  # a kind's own set-up (direct optics)
    if setup is not None:
        lines[1:3] = setup
    for key in ("axis", "diagonal", "axis_order", "plane", "line_mm", "station_mm"):
        if key in m.meta:
            lines.append(f"{key}: {m.meta[key]}")
    if "notes" in m.meta:
        lines.append(f"notes: {m.meta['notes']}")
    return lines


def _directions(m: Measurement, k: int) -> NDArray[np.str_]:
    """Approach direction of each reading of a linear test along axis ``k``."""
    if m.direction is not None:
        return np.asarray(m.direction)
    q = m.positions[:, k]
    d = np.diff(q)
    out = []
    last = "+"
    for i in range(m.n):
        s = d[i - 1] if i > 0 else (d[0] if d.size else 0.0)
        if abs(s) > _TOL_MM:
            last = "+" if s > 0 else "-"
        out.append(last)
    return np.array(out)


def build_steps(m: Measurement, travel: NDArray[np.float64], options: ProgramOptions
                ) -> StepList:
    """Build the steps that visit every reading pose of ``m`` in order, with a dwell at each.

    Parameters
    ----------
    m : Measurement
        Planned measurement (deviations may be empty).
    travel : ndarray, shape (3, 2)
        Travel limits of X, Y, Z [mm]; every pose and approach point stays inside.
    options : ProgramOptions
        Dwell, feed, overrun and number format.

    Returns
    -------
    StepList
        Steps and warnings (shortened overruns, rounding of poses).

    Raises
    ------
    VolcalInputError
        A pose outside the travel, naming the measurement file and row.
    """
    options.check()
    travel = np.asarray(travel, dtype=float).reshape(3, 2)
    out = StepList()
    for text in setup_comments(m):
        out.steps.append(Step("comment", text=text))
    pos = m.positions
    for i in range(m.n):
        for k in range(3):
            if not (travel[k, 0] - _TOL_MM <= pos[i, k] <= travel[k, 1] + _TOL_MM):
                raise VolcalInputError(
                    f"pose {AXES[k]}={pos[i, k]:g} mm lies outside the travel "
                    f"{travel[k, 0]:g}..{travel[k, 1]:g} mm", m.file, i + 2,
                    f"{AXES[k].lower()}_mm")
    rounded = np.round(pos, options.decimals)
    err = float(np.max(np.abs(rounded - pos))) if m.n else 0.0
    if err > 1e-9:
        out.warnings.append(f"{m.id}: poses rounded to {10.0 ** -options.decimals:g} mm "
                            f"(largest change {err * 1e3:.3f} um); plan round targets or "
                            "give the laser software the rounded targets")
    body = _motion(m, pos, travel, options, out)
    # the first move becomes the separate start positioning; the operator stop follows it
    first = next((i for i, st in enumerate(body) if st.kind == "move"), None)
    if first is None:
        raise VolcalInputError("the measurement has no pose to visit", m.file)
    out.steps.append(Step("start", body[first].position, options.feed,
                          text="safe positioning to the start pose"))
    out.steps += body[:first]
    out.steps.append(Step("stop", text=OPERATOR_STOP_TEXT))
    out.steps += body[first + 1:]
    return out



def _motion(m: Measurement, pos: NDArray[np.float64], travel: NDArray[np.float64],
            options: ProgramOptions, out: StepList) -> list[Step]:
    """Moves and dwells of the readings; a move to where the machine stands is left out."""
    steps: list[Step] = []

    def move(p: NDArray[np.float64], role: str) -> None:
        if current is not None and np.allclose(p, current, rtol=0.0, atol=_TOL_MM):
            return
        steps.append(Step("move", tuple(p.tolist()), options.feed, text=role))

    from volcal.session.kinds import kind_of

    # ISO 230-2 approach and overrun: a kind approached from both sides, and any measurement
    # along one axis whose rows say their approach direction (the direct optics' runs: without
    # the overrun the two readings at a reversal were one stand of the machine, neither
    # approached from its side, and a capture could not tell them apart)
    bidirectional = kind_of(m.kind).bidirectional or (m.direction is not None
                                                      and m.axis is not None)
    linear = bidirectional and options.overrun_mm > 0
    k = m.axis if bidirectional else None
    dirs = _directions(m, k) if linear and k is not None else None
    current: NDArray[np.float64] | None = None
    run = m.run
    no_approach: list[int] = []
    short: list[int] = []
    for i in range(m.n):
        target = pos[i]
        if run is not None and (i == 0 or run[i] != run[i - 1]):
            steps.append(Step("comment", text=f"run {int(run[i])}"))
        if dirs is not None and k is not None:
            s = 1.0 if dirs[i] == "+" else -1.0
            from_side = (current is not None
                         and np.allclose(np.delete(current, k), np.delete(target, k), atol=1e-9)
                         and s * (target[k] - current[k]) > _TOL_MM)
            if not from_side:
                want = target[k] - s * options.overrun_mm
                got = float(np.clip(want, travel[k, 0], travel[k, 1]))
                if abs(got - target[k]) <= _TOL_MM:
                    no_approach.append(i + 2)
                else:
                    if abs(got - want) > _TOL_MM:
                        short.append(i + 2)
                    p = target.copy()
                    p[k] = got
                    role = "approach" if current is None or dirs[i - 1] == dirs[i] else "overrun"
                    move(p, role)
                    current = p
        move(target, "reading")
        steps.append(Step("dwell", seconds=options.dwell_s, text=f"reading {i + 1}",
                          reading=i))
        current = target
    if no_approach:
        out.warnings.append(
            f"{m.id}: {len(no_approach)} reversal(s) at a target on the travel limit (rows "
            f"{_rows(no_approach)}) have no overrun; ISO 230-2 wants the targets inside the "
            "travel by the overrun")
    if short:
        out.warnings.append(f"{m.id}: overrun shortened by the travel limit at rows "
                            f"{_rows(short)}")
    return steps


def _rows(rows: list[int]) -> str:
    return ", ".join(map(str, rows[:6])) + (", ..." if len(rows) > 6 else "")
