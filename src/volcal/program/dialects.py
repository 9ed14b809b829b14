"""Render program steps as Fanuc/ISO, Siemens 840D or Heidenhain conversational code.

* ``fanuc``: ISO 6983 G-code as read by Fanuc controls: ``%``, ``O`` number,
  ``G21 G90 G94`` (metric, absolute, feed per minute), ``G01 X.. Y.. Z.. F..`` moves,
  ``G04 P..`` dwell (P in ms, no decimal point), comments in parentheses, ``M30``.
* ``siemens``: SINUMERIK 840D: ``G71 G90 G94``, ``G1 X.. Y.. Z.. F..``, dwell ``G4 F..``
  (F in s, in a block of its own), comments after ``;``, ``M30``.
* ``heidenhain``: Klartext (conversational): numbered blocks, ``BEGIN PGM .. MM``,
  ``L X+.. Y+.. Z+.. R0 F..``, dwell cycle ``CYCL DEF 9.0 DWELL TIME`` /
  ``CYCL DEF 9.1 DWELL ..`` (s), comments after ``;``, ``END PGM .. MM``.

References
----------
ISO 6983-1:2009, Numerical control of machines - Program format and definitions of
address words. FANUC Series 0i-MF operator's manual (G04 dwell, P in ms). SINUMERIK
840D sl Programming Manual Fundamentals (G4 dwell time). HEIDENHAIN TNC 640 Klartext
User's Manual (cycle 9 DWELL TIME).
"""

from __future__ import annotations

import re
from collections.abc import Callable

from volcal.program.steps import Step

DIALECTS: tuple[str, ...] = ("fanuc", "siemens", "heidenhain")
EXTENSIONS: dict[str, str] = {"fanuc": ".nc", "siemens": ".MPF", "heidenhain": ".H"}


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
    return name if dialect == "fanuc" else name.upper()[:24]


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


def _fanuc_comment(text: str) -> str:
    return "(" + _ascii(text).upper().replace("(", "[").replace(")", "]") + ")"


def _fanuc(steps: list[Step], name: str, number: int, decimals: int) -> str:
    out = ["%", f"O{number:04d} {_fanuc_comment('volcal ' + name)}"]
    out.append("G21 G90 G17 G40 G49 G80 G94")
    for s in steps:
        if s.kind == "comment":
            out.append(_fanuc_comment(s.text))
        elif s.kind == "move":
            assert s.position is not None and s.feed is not None
            x, y, z = (_num(v, decimals) for v in s.position)
            out.append(f"G01 X{x} Y{y} Z{z} F{_num(s.feed, 0)}")
        elif s.kind == "dwell":
            assert s.seconds is not None
            out.append(f"G04 P{round(s.seconds * 1000):d}")
    out += ["M30", "%"]
    return "\n".join(out) + "\n"


def _siemens(steps: list[Step], name: str, number: int, decimals: int) -> str:
    out = [f"; volcal program {name}", "G71 G90 G94 G17 G40"]
    for s in steps:
        if s.kind == "comment":
            out.append("; " + _ascii(s.text))
        elif s.kind == "move":
            assert s.position is not None and s.feed is not None
            x, y, z = (_num(v, decimals) for v in s.position)
            out.append(f"G1 X{x} Y{y} Z{z} F{s.feed:g}")
        elif s.kind == "dwell":
            assert s.seconds is not None
            out.append(f"G4 F{s.seconds:g}")
    out.append("M30")
    return "\n".join(out) + "\n"


def _heidenhain(steps: list[Step], name: str, number: int, decimals: int) -> str:
    body = [f"BEGIN PGM {name} MM"]
    for s in steps:
        if s.kind == "comment":
            body.append("; " + _ascii(s.text))
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


_RENDERERS: dict[str, Callable[[list[Step], str, int, int], str]] = {
    "fanuc": _fanuc, "siemens": _siemens, "heidenhain": _heidenhain}


def render(steps: list[Step], dialect: str, name: str, number: int = 1000,
           decimals: int = 3) -> str:
    """Program text of a step list.

    Parameters
    ----------
    steps : list of Step
        From :func:`volcal.program.steps.build_steps`.
    dialect : str
        ``'fanuc'``, ``'siemens'`` or ``'heidenhain'``.
    name : str
        Program name (see :func:`program_name`).
    number : int
        Fanuc program number (``O`` word, 1..9999).
    decimals : int
        Decimals of the coordinates [mm].

    Returns
    -------
    str
    """
    return _RENDERERS[dialect](steps, name, number, decimals)
