"""The planned dwells of a measurement, from the step list its part program was written from.

The capture does not parse the part program: it rebuilds the program's steps with
:func:`volcal.program.steps.build_steps` from the session and the program options (read
from the program folder's index ``volcal-programs.toml`` when given), so the targets, the
approach moves and the dwell time are exactly those of the program on the control.

A rotary test's program turns one rotary axis (:func:`volcal.program.rotary.rotary_moves`:
incremental turns, the overrun before each reversal, a dwell per reading); its dwells are
planned in that axis' frame (:func:`volcal.capture.frame.rotary_frame`): the commanded
angle [deg] and the sign of the turn that reaches it. The linear axes stand where the
program's safe start left them (Z up in machine coordinates, X and Y not moved): their pose
is carried (``pose_mm``, the plan's fixed pose) but not compared.

An R-test's program (:func:`volcal.program.r_test.rtest_program_path`: the blocks
:func:`volcal.program.r_test.rtest_program` writes) turns the rotary axes with the linear
axes following and dwells at each pose: its dwells are planned in a mixed frame
(:func:`volcal.capture.frame.mixed_frame`): X, Y, Z [mm] and the rotary axes [deg] as
the program commands them (the control's angles), without an approach direction (the
nest reads the sphere from wherever the path comes). Its start pose is the first pose,
where the program's ``M0`` zeroes the sensors.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.capture.frame import LINEAR, Frame, mixed_frame, rotary_frame
from volcal.errors import VolcalInputError
from volcal.program.rotary import RotaryMoves, rotary_moves
from volcal.program.steps import ProgramOptions, Step, build_steps

__all__ = ["PlannedDwell", "PlannedMeasurement", "dwell_lines", "plan_measurement",
           "program_options"]

_DWELL = re.compile(r"^\s*(?:N\d+\s+)?G0?4(?![0-9.])", re.IGNORECASE)
_MOVE = re.compile(r"^\s*(?:N\d+\s+)?(?:G0?[01](?![0-9.])|[XYZABC][-+0-9.])", re.IGNORECASE)


@dataclass(frozen=True)
class PlannedDwell:
    """One programmed dwell: where a reading is taken.

    Attributes
    ----------
    reading : int
        Data row of the measurement's CSV (0-based; the CSV row is ``reading + 2``).
    target : ndarray, shape (3,) or (1,)
        Commanded position in the measurement's frame (:class:`PlannedMeasurement`
        ``frame``): X, Y, Z [mm]; a rotary test's commanded angle [deg].
    approach : ndarray, shape (3,) or (1,), or None
        Unit vector of the move that reaches the target (the ISO 230-2 approach
        direction; a rotary test's ``[+1]`` or ``[-1]``, the sign of the turn); None for
        a dwell reached by the start positioning only.
    seconds : float
        Programmed dwell [s].
    run : int or None
        Run number (linear tests).
    direction : str or None
        ``'+'`` or ``'-'`` (linear tests).
    lines : tuple of int
        Lines of the part program (1-based) a control reports while the machine dwells
        here: the dwell block and the move before it (LinuxCNC's ``motion_line`` names the
        move); empty when the program file is not known.
    pose_mm : ndarray, shape (3,), or None
        A rotary test's pose of the linear axes X, Y, Z [mm] (the plan's fixed pose:
        zeros, not recorded; not compared); None for a dwell of the linear axes, whose
        ``target`` is its pose.
    after_stop : bool
        The program stops (``M0``) at this dwell's target just before it: an R-test's
        first pose, where the sensors are zeroed. A control that reports no program
        status cannot show the cycle start, so the reading is the last stable window
        before the machine leaves (:class:`volcal.capture.trigger.TriggerRule`).
    """

    reading: int
    target: NDArray[np.float64]
    approach: NDArray[np.float64] | None
    seconds: float
    run: int | None = None
    direction: str | None = None
    lines: tuple[int, ...] = ()
    pose_mm: NDArray[np.float64] | None = None
    after_stop: bool = False


@dataclass(frozen=True)
class PlannedMeasurement:
    """A measurement with its programmed steps and dwells.

    Attributes
    ----------
    measurement : Measurement
        The planned measurement (:class:`volcal.session.format.Measurement`).
    steps : tuple of Step
        The program's steps (start positioning, operator stop, moves, dwells).
    dwells : tuple of PlannedDwell
        One per reading, in the program's order.
    waypoints : ndarray, shape (k, 3) or (k, 1)
        End points of the moves that are not readings (start pose, approach and overrun
        points) [mm], in the frame (a rotary test's angles [deg]): a stop there is no
        reading.
    options : ProgramOptions
        The program's options.
    frame : Frame
        The coordinates of the targets (:data:`volcal.capture.frame.LINEAR`, or a rotary
        axis' angle).
    rotary : RotaryMoves or None
        A rotary test's turns and dwells (its program's); ``steps`` is then empty.
    path : tuple or None
        An R-test's program blocks (:func:`volcal.program.r_test.rtest_program_path`);
        ``steps`` is then empty.
    """

    measurement: Any
    steps: tuple[Step, ...]
    dwells: tuple[PlannedDwell, ...]
    waypoints: NDArray[np.float64]
    options: ProgramOptions
    frame: Frame = LINEAR
    rotary: RotaryMoves | None = None
    path: tuple[tuple[str, NDArray[np.float64], int | None], ...] | None = None

    @property
    def start(self) -> NDArray[np.float64] | None:
        """The start pose: where the program stands at its operator stop [mm or deg]."""
        if self.path is not None:
            return next((p.copy() for k, p, _ in self.path if k == "stop"), None)
        if self.rotary is not None:
            turns = sum(v for k, v, _ in self.rotary.items[:self.rotary.stop] if k == "turn")
            return np.array([self.rotary.start_deg + turns])
        st = next((s for s in self.steps if s.kind == "start"), None)
        return None if st is None or st.position is None else np.asarray(st.position, float)

    @property
    def id(self) -> str:
        """The measurement's id."""
        return str(self.measurement.id)


def program_options(programs: str | Path | None = None, **overrides: Any) -> ProgramOptions:
    """The options the part programs were written with.

    Parameters
    ----------
    programs : str or Path, optional
        The program folder (``volcal program -o``) or its ``volcal-programs.toml``: its
        dwell, feed, overrun and safe Z are used.
    **overrides
        ``dwell_s``, ``feed``, ``overrun_mm``, ``decimals``, ``safe_z_mm`` given
        explicitly (None: from the index, else volcal's defaults).

    Returns
    -------
    ProgramOptions
    """
    base: dict[str, Any] = {}
    if programs is not None:
        p = Path(programs)
        index = p / "volcal-programs.toml" if p.is_dir() else p
        try:
            doc = tomllib.loads(index.read_text(encoding="utf-8"))
        except (OSError, tomllib.TOMLDecodeError) as e:
            raise VolcalInputError(f"cannot read the program index: {e}", index) from None
        for key, name in (("dwell_s", "dwell_s"), ("feed_mm_min", "feed"),
                          ("overrun_mm", "overrun_mm"), ("safe_z_machine_mm", "safe_z_mm"),
                          ("overrun_deg", "overrun_deg")):
            if key in doc:
                base[name] = float(doc[key])
    base.update({k: v for k, v in overrides.items() if v is not None})
    opts = ProgramOptions(**base)
    opts.check()
    return opts


def dwell_lines(programs: str | Path | None, measurement_id: str) -> list[tuple[int, int]]:
    """Program lines of each dwell of a measurement's part program, in order.

    Parameters
    ----------
    programs : str or Path or None
        The program folder (``volcal program -o``) or its index.
    measurement_id : str
        The measurement.

    Returns
    -------
    list of (int, int)
        (line of the move before the dwell, line of the dwell block), 1-based; empty when
        the folder, its index or the program is missing, or the program has no ISO dwell
        blocks (``G4``/``G04``: Fanuc, LinuxCNC, Siemens).
    """
    if programs is None:
        return []
    p = Path(programs)
    folder = p if p.is_dir() else p.parent
    try:
        doc = tomllib.loads((folder / "volcal-programs.toml").read_text(encoding="utf-8"))
        entry = next(e for e in doc.get("programs", [])
                     if isinstance(e, dict) and e.get("measurement") == measurement_id)
        text = (folder / str(entry["file"])).read_text(encoding="utf-8", errors="replace")
    except (OSError, tomllib.TOMLDecodeError, StopIteration, KeyError):
        return []
    out: list[tuple[int, int]] = []
    move = 0
    for no, line in enumerate(text.splitlines(), start=1):
        if _DWELL.match(line):
            out.append((move, no))
        elif _MOVE.match(line):
            move = no
    return out


def plan_measurement(m: Any, travel: NDArray[np.float64], options: ProgramOptions,
                     programs: str | Path | None = None) -> PlannedMeasurement:
    """The programmed dwells of measurement ``m``.

    Parameters
    ----------
    m : Measurement
        A planned (or measured) measurement.
    travel : ndarray, shape (3, 2)
        The machine's travel [mm].
    options : ProgramOptions
        The program's options (:func:`program_options`).
    programs : str or Path, optional
        The program folder: the program lines of each dwell (:func:`dwell_lines`), by
        which a control that reports its line (LinuxCNC) names the dwell it stands in.

    Returns
    -------
    PlannedMeasurement
    """
    if "target_deg" in m.columns and m.meta.get("axis") in ("a", "b", "c"):
        return _plan_rotary(m, options, programs)
    if m.kind == "r_test":
        return _plan_rtest(m, options, programs)
    sl = build_steps(m, travel, options)
    dwells: list[PlannedDwell] = []
    waypoints: list[tuple[float, float, float]] = []
    here: NDArray[np.float64] | None = None
    approach: NDArray[np.float64] | None = None
    run = m.run
    direction = m.direction
    for st in sl.steps:
        if st.kind == "start" and st.position is not None:
            here, approach = np.asarray(st.position, float), None
        elif st.kind == "move" and st.position is not None:
            p = np.asarray(st.position, float)
            if here is not None:
                d = p - here
                n = float(np.linalg.norm(d))
                approach = d / n if n > 0 else approach
            here = p
            if st.text != "reading":
                waypoints.append(st.position)
        elif st.kind == "dwell" and st.reading is not None:
            i = int(st.reading)
            dwells.append(PlannedDwell(
                i, np.asarray(m.positions[i], float),
                None if approach is None else approach.copy(), float(st.seconds or 0.0),
                None if run is None else int(run[i]),
                None if direction is None else str(direction[i])))
    lines = dwell_lines(programs, m.id)
    if len(lines) == len(dwells):
        dwells = [replace(d, lines=lines[k]) for k, d in enumerate(dwells)]
    start = next(st.position for st in sl.steps if st.kind == "start")
    if start is not None:
        waypoints.insert(0, start)
    return PlannedMeasurement(m, tuple(sl.steps), tuple(dwells),
                              np.asarray(waypoints, float).reshape(-1, 3), options)


def _plan_rotary(m: Any, options: ProgramOptions, programs: str | Path | None
                 ) -> PlannedMeasurement:
    """The dwells of a rotary test: the angles its program turns to, and from which side."""
    mv = rotary_moves(m, options)
    frame = rotary_frame(str(m.meta["axis"]), bool(m.meta.get("modulo", True)))
    here = mv.start_deg
    last = 0.0
    dwells: list[PlannedDwell] = []
    waypoints: list[float] = []
    run, direction = m.columns.get("run"), m.columns.get("direction")
    pose = np.asarray(m.positions, float)
    for k, (kind, v, row) in enumerate(mv.items):
        if kind == "turn":
            here, last = here + v, float(np.sign(v))
            nxt = next((it for it in mv.items[k + 1:] if it[0] != "run"), None)
            if nxt is None or nxt[0] != "dwell":
                waypoints.append(here)  # an overrun or approach point: no reading
        elif kind == "dwell" and row is not None:
            i = int(row)
            dwells.append(PlannedDwell(
                i, np.array([here]), np.array([last]) if last else None, float(v),
                None if run is None else int(run[i]),
                None if direction is None else str(direction[i]), pose_mm=pose[i].copy()))
    lines = dwell_lines(programs, m.id)
    if len(lines) == len(dwells):
        dwells = [replace(d, lines=lines[k]) for k, d in enumerate(dwells)]
    pm = PlannedMeasurement(m, (), tuple(dwells), np.zeros((0, 1)), options, frame, mv)
    start = pm.start
    points = ([] if start is None else [float(start[0])]) + waypoints
    return replace(pm, waypoints=np.asarray(points, float).reshape(-1, 1))


def _plan_rtest(m: Any, options: ProgramOptions, programs: str | Path | None
                ) -> PlannedMeasurement:
    """The dwells of an R-test: the poses of every axis its program commands."""
    from volcal.program.r_test import rtest_program_path
    from volcal.session.r_test import rtest_keys

    k = rtest_keys(m)
    letters = tuple(k["chain"].rotary)
    frame = mixed_frame(letters, tuple(a.upper() == "C" for a in letters))
    path = tuple(rtest_program_path(m, options))
    pose = np.asarray(m.positions, float)
    kinds = [kind for kind, _, _ in path]
    dwells = [PlannedDwell(int(i), p.copy(), None, float(options.dwell_s),
                           pose_mm=pose[int(i)].copy(),
                           after_stop=j > 0 and kinds[j - 1] == "stop")
              for j, (kind, p, i) in enumerate(path) if kind == "dwell" and i is not None]
    lines = dwell_lines(programs, m.id)
    if len(lines) == len(dwells):
        dwells = [replace(d, lines=lines[j]) for j, d in enumerate(dwells)]
    # the approach point above the sphere, the points between poses, the retract: no
    # reading there (an axis a block does not command stands where the block before left it)
    stops: list[NDArray[np.float64]] = []
    here = np.full(len(frame.axes), np.nan)
    for kind, p, _ in path:
        here = np.where(np.isnan(p), here, p)
        if kind == "move" and not np.isnan(here).any():
            stops.append(here.copy())
    below = {tuple(d.target) for d in dwells}
    waypoints = [p for p in stops if tuple(p) not in below]
    return PlannedMeasurement(m, (), tuple(dwells),
                              np.asarray(waypoints, float).reshape(-1, len(frame.axes)),
                              options, frame, None, path)
