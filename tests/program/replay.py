"""Independent replay of generated programs: dwell positions in order.

Fanuc/ISO is parsed with pygcode (PyPI, an ISO 6983 parser and machine-state
interpreter); Siemens and Heidenhain with the small regex parsers below, written
from the controller manuals, not from volcal's renderer.
"""

from __future__ import annotations

import re

import numpy as np
from pygcode import GCodeDwell, GCodeLinearMove, Line, Machine


def replay_fanuc(text: str):
    """Return (dwell positions (n,3), dwell seconds (n,), all move targets (m,3))."""
    machine = Machine()
    dwells, secs, moves = [], [], []
    for raw in text.splitlines():
        raw = raw.strip()
        if not raw or raw == "%":
            continue
        line = Line(raw)
        machine.process_block(line.block)
        for g in line.block.gcodes:
            if isinstance(g, GCodeDwell):
                p = g.params["P"].value
                assert float(p) == int(p), "Fanuc P dwell is in ms without decimals"
                secs.append(int(p) / 1000.0)
                dwells.append(machine.pos.values.copy())
            elif isinstance(g, GCodeLinearMove):
                moves.append(machine.pos.values.copy())
    to = lambda d: [d["X"], d["Y"], d["Z"]]  # noqa: E731
    return (np.array([to(d) for d in dwells]), np.array(secs),
            np.array([to(d) for d in moves]))


_SIE_MOVE = re.compile(r"^G0?1((?:\s+[XYZ]-?\d+(?:\.\d*)?)+)\s+F(\d+(?:\.\d*)?)$")
_SIE_DWELL = re.compile(r"^G4\s+F(\d+(?:\.\d*)?)$")


def replay_siemens(text: str):
    """Replay a SINUMERIK program: G1 moves with X/Y/Z words, G4 F dwells [s]."""
    pos = {"X": np.nan, "Y": np.nan, "Z": np.nan}
    dwells, secs, moves = [], [], []
    absolute = False
    for raw in text.splitlines():
        line = raw.split(";", 1)[0].strip()
        if not line:
            continue
        if "G90" in line.split():
            absolute = True
            continue
        if m := _SIE_MOVE.match(line):
            assert absolute
            for w in m.group(1).split():
                pos[w[0]] = float(w[1:])
            moves.append([pos["X"], pos["Y"], pos["Z"]])
        elif m := _SIE_DWELL.match(line):
            dwells.append([pos["X"], pos["Y"], pos["Z"]])
            secs.append(float(m.group(1)))
        elif line != "M30":
            raise AssertionError(f"unexpected Siemens block {line!r}")
    return np.array(dwells), np.array(secs), np.array(moves)


_HH_MOVE = re.compile(r"^L((?:\s+[XYZ][+-]\d+(?:\.\d*)?)+)\s+R0\s+F(\d+(?:\.\d*)?|MAX)$")


def replay_heidenhain(text: str):
    """Replay a Klartext program: numbered blocks, L moves, cycle 9 dwell [s]."""
    pos = {"X": np.nan, "Y": np.nan, "Z": np.nan}
    dwells, secs, moves = [], [], []
    pending = False
    lines = text.splitlines()
    for n, raw in enumerate(lines):
        num, _, line = raw.partition(" ")
        assert int(num) == n, "blocks are numbered 0, 1, 2..."
        line = line.strip()
        if line.startswith(";") or line.startswith("BEGIN PGM") or line.startswith("END PGM"):
            continue
        if m := _HH_MOVE.match(line):
            for w in m.group(1).split():
                pos[w[0]] = float(w[1:])
            moves.append([pos["X"], pos["Y"], pos["Z"]])
        elif line == "CYCL DEF 9.0 DWELL TIME":
            pending = True
        elif line.startswith("CYCL DEF 9.1 DWELL "):
            assert pending
            pending = False
            dwells.append([pos["X"], pos["Y"], pos["Z"]])
            secs.append(float(line.rsplit(" ", 1)[1]))
        else:
            raise AssertionError(f"unexpected Heidenhain block {line!r}")
    assert lines[0].endswith(" MM") and lines[-1].startswith(f"{len(lines) - 1} END PGM")
    return np.array(dwells), np.array(secs), np.array(moves)


REPLAY = {"fanuc": replay_fanuc, "siemens": replay_siemens, "heidenhain": replay_heidenhain}
