"""Render program steps as Fanuc/ISO, LinuxCNC, Siemens 840D or Heidenhain code.

Every program has the same shape, written in the dialect's own words:

1. a header that states the coordinate system (metric, absolute, XY plane, no cutter
   radius or tool length compensation, no canned cycle, feed per minute, work offset
   G54 or the active preset);
2. a separate, safe positioning to the start pose: Z up in **machine** coordinates first
   (``G53`` / ``SUPA`` / ``M91``), then X and Y, then Z down; the retract is a rapid
   move straight up (away from the set-up), the X-Y and Z-down moves run at the
   measuring feed so that the operator keeps the feed override while the tool
   approaches the optics;
3. an operator stop (``M00`` / ``M0`` / ``STOP``) with a message: check the optics,
   start the laser capture, cycle start;
4. the measuring moves, a dwell at every reading, each block written once (a move to
   where the machine already stands, e.g. the reversal at the end of travel, is left
   out);
5. the program end (``M30`` / ``M2`` / ``M30`` / ``END PGM``).

Dialects:

* ``fanuc``: ISO 6983 G-code as read by Fanuc controls: ``%``, ``O`` number, ``G21`` in a
  block of its own (the manual asks for it before anything else), ``G90 G17 G40 G49 G80
  G94 G54``, ``G53 G00 Z..`` (machine coordinates, one-shot, moves at rapid),
  ``G01 X.. Y.. Z.. F..`` moves, ``G04 P..`` dwell (P in ms, no decimal point),
  ``M00`` program stop, comments in parentheses, ``M30``.
* ``linuxcnc``: the LinuxCNC dialect of RS274/NGC: same words, but ``G4 P`` is in
  **seconds**, ``G53 G0 Z..`` in machine coordinates, ``(MSG,...)`` shows the operator
  message, ``M0`` pauses, ``M2`` ends the program; no ``O`` number (O words are
  subroutine labels in LinuxCNC).
* ``siemens``: SINUMERIK 840D: ``G71 G90 G94 G17 G40 G54 D0`` (``D0`` cancels the tool
  offset), ``G0 SUPA Z..`` (SUPA suppresses every frame: machine coordinates, non-modal),
  ``G1 X.. Y.. Z.. F..``, dwell ``G4 F..`` (F in s, in a block of its own),
  ``MSG("...")`` and ``M0``, comments after ``;``, ``M30``.
* ``heidenhain``: Klartext (conversational): numbered blocks, ``BEGIN PGM .. MM``,
  ``BLK FORM 0.1 Z`` / ``0.2`` (the travel box, for the graphics), ``TOOL CALL 0 Z``
  (tool 0 is the zero tool, L = R = 0; tool axis Z), ``L Z.. R0 FMAX M91`` (M91: the
  coordinate refers to the machine datum), ``L X+.. Y+.. Z+.. R0 F..``, dwell cycle
  ``CYCL DEF 9.0 DWELL TIME`` / ``CYCL DEF 9.1 DWELL ..`` (s), ``STOP``, comments after
  ``;``, ``END PGM .. MM``.

References
----------
ISO 6983-1:2009, Numerical control of machines - Program format and definitions of
address words. FANUC Series 0i-MF Plus operator's manual B-64694EN (G04 dwell, P in ms;
G20/G21 in an independent block at the start of the program; G53 machine coordinate
system selection, moves at rapid; M00 program stop). LinuxCNC G-code reference
(linuxcnc.org/docs/html/gcode/g-code.html: G4 "P seconds", G53, G17, G21, G40, G49, G54,
G80, G90, G94; M-codes: M0, M2; comments: MSG). SINUMERIK 840D sl Programming Manual
Fundamentals (G4 dwell time in its own block, G53/SUPA, G71, D0, MSG, M0, M30).
HEIDENHAIN TNC 640 Klartext User's Manual (BLK FORM, TOOL CALL, tool 0, M91, cycle 9
DWELL TIME, STOP, END PGM).
"""

from __future__ import annotations

import re
from collections.abc import Callable

from volcal.program.steps import Step

DIALECTS: tuple[str, ...] = ("fanuc", "linuxcnc", "siemens", "heidenhain")
EXTENSIONS: dict[str, str] = {"fanuc": ".nc", "linuxcnc": ".ngc", "siemens": ".MPF",
                              "heidenhain": ".H"}

COORDINATES_TEXT = ("coordinates: work offset G54 = origin of the plan (zero offset to "
                    "measure in machine coordinates), no tool length or radius offset")
"""Comment stating the coordinate system (G-code dialects)."""


def program_name(mid: str, dialect: str) -> str:
    """Program (and file) name of a measurement in a dialect.

    Parameters
    ----------
    mid : str
        Measurement id.
    dialect : str
        One of :data:`DIALECTS`.

    Returns
    -------
    str
        Letters, digits and ``_`` only; upper case for Siemens and Heidenhain.
    """
    name = re.sub(r"[^A-Za-z0-9_]", "_", mid).strip("_") or "TEST"
    if not name[0].isalpha():
        name = "T" + name
    return name if dialect in ("fanuc", "linuxcnc") else name.upper()[:24]


def _num(v: float, decimals: int, signed: bool = False) -> str:
    s = f"{v:.{decimals}f}"
    if s.startswith("-") and float(s) == 0.0:
        s = s[1:]
    if decimals == 0:
        s += "."
    if signed and not s.startswith("-"):
        s = "+" + s
    return s


def _ascii(text: str) -> str:
    return text.encode("ascii", "replace").decode("ascii").replace("\n", " ")


def _paren_comment(text: str) -> str:
    return "(" + _ascii(text).upper().replace("(", "[").replace(")", "]") + ")"


def _iso(steps: list[Step], name: str, number: int, decimals: int, safe_z: float,
         linuxcnc: bool) -> str:
    """Fanuc and LinuxCNC: the same ISO words, different dwell unit, stop and end."""
    out = [] if linuxcnc else ["%", f"O{number:04d} {_paren_comment('volcal ' + name)}"]
    if linuxcnc:
        out.append(_paren_comment("volcal " + name))
    out += ["G21", "G90 G17 G40 G49 G80 G94 G54", _paren_comment(COORDINATES_TEXT)]
    for s in steps:
        if s.kind == "comment":
            out.append(_paren_comment(s.text))
        elif s.kind == "start":
            assert s.position is not None and s.feed is not None
            x, y, z = (_num(v, decimals) for v in s.position)
            out += [_paren_comment("safe start: Z up in machine coordinates, then X Y, then "
                                   "Z down"),
                    f"G53 G00 Z{_num(safe_z, decimals)}",
                    f"G01 X{x} Y{y} F{_num(s.feed, 0)}", f"G01 Z{z}"]
        elif s.kind == "stop":
            out += [("(MSG," + _paren_comment(s.text)[1:]) if linuxcnc
                    else _paren_comment(s.text), "M0" if linuxcnc else "M00"]
        elif s.kind == "move":
            assert s.position is not None and s.feed is not None
            x, y, z = (_num(v, decimals) for v in s.position)
            out.append(f"G01 X{x} Y{y} Z{z} F{_num(s.feed, 0)}")
        elif s.kind == "dwell":
            assert s.seconds is not None
            out.append(f"G4 P{s.seconds:g}" if linuxcnc
                       else f"G04 P{round(s.seconds * 1000):d}")
    out += ["M2"] if linuxcnc else ["M30", "%"]
    return "\n".join(out) + "\n"


def _fanuc(steps: list[Step], name: str, number: int, decimals: int, safe_z: float) -> str:
    return _iso(steps, name, number, decimals, safe_z, linuxcnc=False)


def _linuxcnc(steps: list[Step], name: str, number: int, decimals: int, safe_z: float) -> str:
    return _iso(steps, name, number, decimals, safe_z, linuxcnc=True)


def _siemens(steps: list[Step], name: str, number: int, decimals: int, safe_z: float) -> str:
    out = [f"; volcal program {name}", "G71 G90 G94 G17 G40 G54 D0",
           "; " + COORDINATES_TEXT.replace("G54", "G54 (settable frame)")]
    for s in steps:
        if s.kind == "comment":
            out.append("; " + _ascii(s.text))
        elif s.kind == "start":
            assert s.position is not None and s.feed is not None
            x, y, z = (_num(v, decimals) for v in s.position)
            out += ["; safe start: Z up in machine coordinates (SUPA), then X Y, then Z down",
                    f"G0 SUPA Z{_num(safe_z, decimals)}", f"G1 X{x} Y{y} F{s.feed:g}",
                    f"G1 Z{z}"]
        elif s.kind == "stop":
            out += ['MSG("' + _ascii(s.text).replace('"', "'") + '")', "M0", "MSG()"]
        elif s.kind == "move":
            assert s.position is not None and s.feed is not None
            x, y, z = (_num(v, decimals) for v in s.position)
            out.append(f"G1 X{x} Y{y} Z{z} F{s.feed:g}")
        elif s.kind == "dwell":
            assert s.seconds is not None
            out.append(f"G4 F{s.seconds:g}")
    out.append("M30")
    return "\n".join(out) + "\n"


def _heidenhain_blank(steps: list[Step], decimals: int) -> list[str]:
    """BLK FORM of the box spanned by every position of the program [mm]."""
    pts = [s.position for s in steps if s.position is not None]
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(max(p[k] for p in pts), lo[k] + 1.0) for k in range(3)]
    f = [[_num(v, decimals, signed=True) for v in c] for c in (lo, hi)]
    return [f"BLK FORM 0.1 Z X{f[0][0]} Y{f[0][1]} Z{f[0][2]}",
            f"BLK FORM 0.2 X{f[1][0]} Y{f[1][1]} Z{f[1][2]}"]


def _heidenhain(steps: list[Step], name: str, number: int, decimals: int,
                safe_z: float) -> str:
    body = [f"BEGIN PGM {name} MM", *_heidenhain_blank(steps, decimals),
            "; coordinates: the active preset = origin of the plan, tool 0 (L = R = 0)",
            "TOOL CALL 0 Z"]
    for s in steps:
        if s.kind == "comment":
            body.append("; " + _ascii(s.text))
        elif s.kind == "start":
            assert s.position is not None and s.feed is not None
            x, y, z = (_num(v, decimals, signed=True) for v in s.position)
            body += ["; safe start: Z up in machine coordinates (M91), then X Y, then Z down",
                     f"L Z{_num(safe_z, decimals, signed=True)} R0 FMAX M91",
                     f"L X{x} Y{y} R0 F{s.feed:g}", f"L Z{z} R0 F{s.feed:g}"]
        elif s.kind == "stop":
            body += ["; " + _ascii(s.text), "STOP"]
        elif s.kind == "move":
            assert s.position is not None and s.feed is not None
            x, y, z = (_num(v, decimals, signed=True) for v in s.position)
            body.append(f"L X{x} Y{y} Z{z} R0 F{s.feed:g}")
        elif s.kind == "dwell":
            assert s.seconds is not None
            body.append("CYCL DEF 9.0 DWELL TIME")
            body.append(f"CYCL DEF 9.1 DWELL {s.seconds:g}")
    body.append(f"END PGM {name} MM")
    return "\n".join(f"{i} {line}" for i, line in enumerate(body)) + "\n"


_RENDERERS: dict[str, Callable[[list[Step], str, int, int, float], str]] = {
    "fanuc": _fanuc, "linuxcnc": _linuxcnc, "siemens": _siemens, "heidenhain": _heidenhain}


def render(steps: list[Step], dialect: str, name: str, number: int = 1000,
           decimals: int = 3, safe_z_mm: float = 0.0) -> str:
    """Program text of a step list.

    Parameters
    ----------
    steps : list of Step
        From :func:`volcal.program.steps.build_steps`.
    dialect : str
        ``'fanuc'``, ``'linuxcnc'``, ``'siemens'`` or ``'heidenhain'``.
    name : str
        Program name (see :func:`program_name`).
    number : int
        Fanuc program number (``O`` word, 1..9999).
    decimals : int
        Decimals of the coordinates [mm].
    safe_z_mm : float
        Z of the first retract, in machine coordinates [mm] (0 = the reference position,
        at the top of the Z travel on most machining centres).

    Returns
    -------
    str
    """
    return _RENDERERS[dialect](steps, name, number, decimals, safe_z_mm)
