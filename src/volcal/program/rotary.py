"""Part programs of a rotary test (ISO 230-2 for rotary axes), for every dialect.

The program turns the rotary axis through the planned targets in the session's order, with
a dwell at every reading, and approaches each target from its planned direction: before
each change of direction (the start of each run, the end of each pass) it turns past the
target by the overrun and comes back (ISO 230-2:2014, 5.3, the standard test cycle).

**Modulo and shortest path.** Controls treat an absolute angle on a full-circle axis
differently: LinuxCNC with ``[AXIS_C] WRAPPED_ROTARY = 1`` turns in the direction of the
sign of the programmed value (the INI documentation: "positive numbers will move the axis
in a positive direction and negative numbers ... in the negative direction"; without it
the axis is a "wrapped linear axis" counting without limit, G-code documentation,
"Rotational Axes"); Fanuc with the roll-over function (parameter 1008 bit 0 ROA) turns the
shorter way unless bit 1 RAB says otherwise (FANUC operator's manual B-63534EN, 20.2.1
"Rotary axis roll-over": "for an incremental command, the tool moves the angle specified
in the command"); SINUMERIK modulo axes (MD30310 ROT_IS_MODULO) position with ``AC`` (by
the sign of the difference), ``DC`` (shortest path), ``ACP`` / ``ACN`` (positive /
negative), and G90 follows MD30455 bit 2 (SINUMERIK 840D sl Function Manual Axes and
spindles, R2 "Rotary axes", 7.2 "Modulo 360 degrees"); HEIDENHAIN turns the shorter way
with ``M126`` (shortest-path traverse of rotary axes) and by the programmed value
without it. Therefore **every measuring move is incremental** (``G91`` / ``IC``): an
incremental angle is turned as written, in its direction, on every control and in every
modulo setting, so the approach direction of each reading is the planned one. Only the
start is absolute: the turn to the first target.

**Safe start.** Z goes up first, in machine coordinates (``G53`` / ``SUPA`` / ``M91``),
then the rotary axis turns to the first target at the measuring feed and on past it by the
overrun (incrementally, against the first reading's direction), so that the first reading
is approached from its side like every other; the linear axes do not move otherwise. The
operator stop comes there (check the calibrator, start the capture): at the first
reading's approach point, never at a reading's target, so that a capture reading a
control that reports positions only takes no reading at the stop (``volcal capture``);
the header says how far the axis turns, so that nothing attached to the table is wound up.
The feed of a rotary-only move is in deg/min on all four controls.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from volcal.program.dialects import COORDINATES_TEXT, _ascii, _paren_comment
from volcal.program.steps import OPERATOR_STOP_TEXT, ProgramOptions

__all__ = ["MODULO_NOTES", "RotaryMoves", "rotary_moves", "rotary_program"]

MODULO_NOTES: dict[str, str] = {
    "linuxcnc": ("LinuxCNC: WRAPPED_ROTARY = 1 turns an absolute angle by the sign of the "
                 "value, without it the axis counts without limit; the moves here are "
                 "incremental (G91), so either setting turns them as planned"),
    "fanuc": ("Fanuc: with roll-over (parameter 1008#0 ROA) an absolute angle turns the "
              "shorter way unless 1008#1 RAB = 1; the moves here are incremental (G91), "
              "which roll-over turns as written"),
    "siemens": ("SINUMERIK: a modulo axis (MD30310) positions absolute angles by AC, DC "
                "(shortest path), ACP or ACN, G90 as MD30455 bit 2 says; the moves here are "
                "incremental (G91), turned as written"),
    "heidenhain": ("HEIDENHAIN: M126 turns absolute angles the shorter way, without it by the "
                   "programmed value; the moves here are incremental (IC), turned as "
                   "written"),
}
"""What each control does with an absolute angle on a full-circle axis, and why the
program moves incrementally (sources in the module docstring)."""


def _n(v: float, decimals: int, signed: bool = False) -> str:
    s = f"{v:.{decimals}f}"
    if s.startswith("-") and float(s) == 0.0:
        s = s[1:]
    if signed and not s.startswith("-"):
        s = "+" + s
    return s


@dataclass(frozen=True)
class RotaryMoves:
    """The moves and dwells of a rotary test's program, dialect-free.

    Attributes
    ----------
    start_deg : float
        The absolute turn of the safe start: the first target [deg].
    items : list of tuple
        After the start, in order: ``('turn', delta_deg, None)`` (an incremental turn
        [deg]), ``('dwell', seconds, row)`` (a reading's dwell; ``row`` the 0-based data
        row), ``('run', run, None)`` (a comment). The turns before the operator stop (the
        overrun before the first target) come first; ``stop`` says where the stop goes.
    stop : int
        Index in ``items`` where the operator stop is written: after the start's overrun
        turn, so that the program stops at the first reading's approach point (a stop
        there is no reading), never at a reading's target.
    warnings : list of str
        Overruns shortened by a limited range.
    """

    start_deg: float
    items: list[tuple[str, float, int | None]]
    stop: int
    warnings: list[str]


def rotary_moves(m: Any, options: ProgramOptions) -> RotaryMoves:
    """Incremental turns and dwells of a rotary test (the program's and the capture's).

    Each target is reached turning in its planned direction: before a reading approached
    from the other side than the previous turn (the first reading, each reversal) the axis
    turns past the target by ``options.overrun_deg`` and comes back (ISO 230-2:2014, 5.3).

    Parameters
    ----------
    m : Measurement
        A planned ``rotary`` measurement (``target_deg``, ``run``, ``direction``).
    options : ProgramOptions
        Dwell [s], ``overrun_deg`` [deg], decimals [deg].

    Returns
    -------
    RotaryMoves
    """
    t = np.round(np.asarray(m.columns["target_deg"], dtype=float), options.decimals)
    d = m.columns.get("direction")
    d = np.where(np.diff(t, prepend=t[0]) < 0, "-", "+") if d is None else np.asarray(d)
    run = m.columns.get("run")
    lo, hi = (float(v) for v in m.meta.get("range_deg", (0.0, 360.0)))
    modulo = bool(m.meta.get("modulo", True))
    ov = float(options.overrun_deg)
    out: list[tuple[str, float, int | None]] = []
    warn: list[str] = []
    cur = float(t[0])
    stop = 0
    for i in range(t.size):
        if run is not None and i > 0 and run[i] != run[i - 1]:
            out.append(("run", float(run[i]), None))
        s = 1.0 if d[i] == "+" else -1.0
        from_side = i > 0 and s * (t[i] - cur) > 1e-9
        if not from_side and ov > 0:
            want = t[i] - s * ov
            got = want if modulo else float(np.clip(want, lo, hi))
            if abs(got - want) > 1e-9:
                warn.append(f"{m.id}: overrun shortened by the range of axis "
                            f"{m.meta['axis'].upper()} at row {i + 2}")
            if abs(got - cur) > 1e-9:
                out.append(("turn", got - cur, None))
                cur = got
        if i == 0:
            stop = len(out)  # the operator stop: at the first reading's approach point
            if run is not None:
                out.append(("run", float(run[0]), None))
        if abs(t[i] - cur) > 1e-9:
            out.append(("turn", float(t[i] - cur), None))
            cur = float(t[i])
        out.append(("dwell", options.dwell_s, i))
    return RotaryMoves(float(t[0]), out, stop, warn)


def _header(m: Any, dialect: str, options: ProgramOptions) -> list[str]:
    axis = m.meta["axis"].upper()
    t = np.asarray(m.columns["target_deg"], dtype=float)
    lo, hi = (float(v) for v in m.meta.get("range_deg", (0.0, 360.0)))
    full = "full circle (modulo 360)" if m.meta.get("modulo", True) else "limited"
    from volcal.session.kinds import kind_of

    return [f"volcal measurement {m.id}: rotary test of axis {axis}, {m.n} readings",
            *(kind_of(m.kind).program_setup_lines(m) or []),
            f"axis {axis}: range {lo:g}..{hi:g} deg, {full}; targets {t.min():g}..{t.max():g} "
            f"deg; overrun {options.overrun_deg:g} deg before each reversal",
            f"the axis turns through {np.ptp(t) + 2 * options.overrun_deg:g} deg per pass: "
            "nothing attached to the table may be wound up",
            f"feed of the rotary moves: {options.feed:g} deg/min; dwell {options.dwell_s:g} s "
            "per reading",
            "sign: deviation = actual - commanded angle, positive counter-clockwise looking "
            f"from the positive end of the {'XYZ'['ABC'.index(axis)]} axis towards the "
            "origin (ISO 841)",
            MODULO_NOTES[dialect]]


def rotary_program(m: Any, dialect: str, name: str, number: int,
                   options: ProgramOptions) -> tuple[str, list[str]]:
    """Program text of a rotary test in a dialect, and its warnings.

    Parameters
    ----------
    m : Measurement
        A planned ``rotary`` measurement (``target_deg``, ``run``, ``direction``).
    dialect : str
        ``'fanuc'``, ``'linuxcnc'``, ``'siemens'`` or ``'heidenhain'``.
    name : str
        Program name.
    number : int
        Fanuc program number (``O`` word).
    options : ProgramOptions
        Dwell [s], feed (of the rotary moves) [deg/min], ``overrun_deg`` [deg],
        decimals [deg], ``safe_z_mm`` (the retract, machine coordinates) [mm].

    Returns
    -------
    text : str
    warnings : list of str
    """
    options.check()
    mv = rotary_moves(m, options)
    writer = {"fanuc": _iso, "linuxcnc": _iso, "siemens": _siemens,
              "heidenhain": _heidenhain}[dialect]
    return writer(m, dialect, name, number, options, mv), mv.warnings


def _body(mv: RotaryMoves, stop: list[str], comment: Any, turn: Any, dwell: Any
          ) -> list[str]:
    """The lines after the start, each written by the dialect's functions.

    Turns, the operator stop after the first overrun, run comments and dwells.
    """
    out: list[str] = []
    for k, (kind, v, _row) in enumerate(mv.items):
        if k == mv.stop:
            out += stop
        if kind == "run":
            out.append(comment(f"run {int(v)}"))
        elif kind == "turn":
            out.append(turn(v))
        else:
            out += dwell(v)
    return out


_START_TEXT = ("safe start: Z up in machine coordinates, then the rotary axis to the first "
               "target and past it by the overrun (the operator stop stands there)")


def _iso(m: Any, dialect: str, name: str, number: int, options: ProgramOptions,
         mv: RotaryMoves) -> str:
    """Fanuc and LinuxCNC (G-code): ``G91`` turns, ``G4`` dwells."""
    lx = dialect == "linuxcnc"
    axis, dec, f = m.meta["axis"].upper(), options.decimals, f"{options.feed:g}"
    out = ([_paren_comment("volcal " + name)] if lx
           else ["%", f"O{number:04d} {_paren_comment('volcal ' + name)}"])
    out += ["G21", "G90 G17 G40 G49 G80 G94 G54", _paren_comment(COORDINATES_TEXT)]
    out += [_paren_comment(h) for h in _header(m, dialect, options)]
    out += [_paren_comment(_START_TEXT), f"G53 G00 Z{_n(options.safe_z_mm, 3)}",
            f"G90 G01 {axis}{_n(mv.start_deg, dec)} F{f}", "G91"]
    stop = [("(MSG," + _paren_comment(OPERATOR_STOP_TEXT)[1:]) if lx
            else _paren_comment(OPERATOR_STOP_TEXT), "M0" if lx else "M00"]
    out += _body(mv, stop, _paren_comment, lambda v: f"G01 {axis}{_n(v, dec)} F{f}",
                 lambda v: [f"G4 P{v:g}" if lx else f"G04 P{round(v * 1000):d}"])
    out += ["G90", "M2"] if lx else ["G90", "M30", "%"]
    return "\n".join(out) + "\n"


def _siemens(m: Any, dialect: str, name: str, number: int, options: ProgramOptions,
             mv: RotaryMoves) -> str:
    """SINUMERIK: ``G91`` turns, ``G4 F`` dwells, the start ``DC`` on a modulo axis."""
    axis, dec, f = m.meta["axis"].upper(), options.decimals, f"{options.feed:g}"
    out = [f"; volcal program {name}", "G71 G90 G94 G17 G40 G54 D0",
           "; " + COORDINATES_TEXT.replace("G54", "G54 (settable frame)")]
    out += ["; " + _ascii(h) for h in _header(m, dialect, options)]
    t0 = _n(mv.start_deg, dec)
    start = f"{axis}=DC({t0})" if bool(m.meta.get("modulo", True)) else f"{axis}={t0}"
    out += ["; " + _START_TEXT, f"G0 SUPA Z{_n(options.safe_z_mm, 3)}",
            f"G90 G1 {start} F{f}", "G91"]
    stop = ['MSG("' + _ascii(OPERATOR_STOP_TEXT).replace('"', "'") + '")', "M0", "MSG()"]
    out += _body(mv, stop, lambda c: "; " + c, lambda v: f"G1 {axis}{_n(v, dec)} F{f}",
                 lambda v: [f"G4 F{v:g}"])
    out += ["G90", "M30"]
    return "\n".join(out) + "\n"


def _heidenhain(m: Any, dialect: str, name: str, number: int, options: ProgramOptions,
                mv: RotaryMoves) -> str:
    """HEIDENHAIN Klartext: ``L IC`` turns, cycle 9 dwells, numbered blocks."""
    axis, dec, f = m.meta["axis"].upper(), options.decimals, f"{options.feed:g}"
    body = [f"BEGIN PGM {name} MM", "TOOL CALL 0 Z"]
    body += ["; " + _ascii(h) for h in _header(m, dialect, options)]
    body += ["; " + _START_TEXT, f"L Z{_n(options.safe_z_mm, 3, True)} R0 FMAX M91",
             f"L {axis}{_n(mv.start_deg, dec, True)} R0 F{f}"]
    body += _body(mv, ["; " + _ascii(OPERATOR_STOP_TEXT), "STOP"], lambda c: "; " + c,
                  lambda v: f"L I{axis}{_n(v, dec, True)} R0 F{f}",
                  lambda v: ["CYCL DEF 9.0 DWELL TIME", f"CYCL DEF 9.1 DWELL {v:g}"])
    body.append(f"END PGM {name} MM")
    return "\n".join(f"{i} {line}" for i, line in enumerate(body)) + "\n"
