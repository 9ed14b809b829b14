"""Independent replay of generated programs: dwell positions in order.

* Fanuc/ISO is parsed with pygcode (PyPI, an ISO 6983 parser and machine-state
  interpreter) and, with LinuxCNC, by LinuxCNC's own standalone interpreter ``rs274``
  (Debian package ``linuxcnc-uspace``): :func:`run_rs274` returns its canonical commands.
* Siemens and Heidenhain are replayed by the small parsers below, written from the
  controller manuals (SINUMERIK 840D sl Programming Manual Fundamentals; HEIDENHAIN TNC
  640 Klartext User's Manual), not from volcal's renderer. They check the block syntax
  the manuals give: G4 in a block of its own, SUPA/M91 only on a retract, MSG("..."),
  numbered Klartext blocks, BLK FORM 0.1 then 0.2 with MIN < MAX, TOOL CALL before the
  first move, END PGM last.

Every replay returns ``(dwells (n, 3), seconds (n,), moves (m, 3))`` where ``moves`` is the
position after every motion block in work coordinates (NaN where a move in machine
coordinates left an axis unknown), and records the order of the program's events in
``EVENTS`` (``'retract'``, ``'move'``, ``'stop'``, ``'dwell'``, ``'end'``).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from pygcode import (
    GCodeDwell,
    GCodeLinearMove,
    GCodeMoveInMachineCoords,
    GCodePauseProgram,
    GCodeRapidMove,
    Line,
    Machine,
)

from timing import scaled_timeout

EVENTS: list[str] = []

RS274 = shutil.which("rs274")
"""Path of LinuxCNC's standalone interpreter, None when linuxcnc-uspace is missing."""

WORK_OFFSET_INCH = (4.0, 2.0, -16.0)
"""G54 offset given to rs274 in its var file; the standalone interpreter stores
parameters in inches (its internal unit): 101.6, 50.8, -406.4 mm."""


def replay_fanuc(text: str):
    """Replay with pygcode; Fanuc's P dwell is in ms without a decimal point."""
    EVENTS.clear()
    machine = Machine()
    dwells, secs, moves = [], [], []
    lines = [raw.strip() for raw in text.splitlines()]
    assert lines[0] == "%" and lines[-1] == "%" and lines[-2] == "M30"
    assert re.fullmatch(r"O\d{4} \(.*\)", lines[1])
    assert lines[2] == "G21", "G21 in a block of its own, before anything else"
    for raw in lines[2:-1]:
        line = Line(raw)
        machine.process_block(line.block)
        kinds = [type(g) for g in line.block.gcodes]
        for g in line.block.gcodes:
            if isinstance(g, GCodeDwell):
                p = g.params["P"].value
                assert float(p) == int(p), "Fanuc P dwell is in ms without decimals"
                secs.append(int(p) / 1000.0)
                dwells.append(machine.pos.values.copy())
                EVENTS.append("dwell")
            elif isinstance(g, GCodeLinearMove):
                moves.append(machine.pos.values.copy())
                EVENTS.append("move")
            elif isinstance(g, GCodeRapidMove):
                assert GCodeMoveInMachineCoords in kinds, "the only rapid is the G53 retract"
                moves.append({"X": np.nan, "Y": np.nan, "Z": np.nan})
                EVENTS.append("retract")
            elif isinstance(g, GCodePauseProgram):
                EVENTS.append("stop")
    EVENTS.append("end")
    to = lambda d: [d["X"], d["Y"], d["Z"]]  # noqa: E731
    out = [np.array([to(d) for d in dwells]), np.array(secs), np.array([to(d) for d in moves])]
    # pygcode keeps the position through G53; the work position is unknown until X Y Z
    out[2][EVENTS.index("retract")] = np.nan
    return tuple(out)


CANON = re.compile(r"^\s*\d+\s+N\.+\s+([A-Z_]+)\((.*)\)\s*$")
"""One canonical command of ``rs274 -g``: its name and its arguments."""


def rs274_output(folder: Path, text: str, variables: str = "5220\t1.000000\n") -> str:
    """LinuxCNC's interpreter run on a program in ``folder``: its canonical commands' text.

    Writes ``tool.tbl``, ``rs274ngc.var`` (``variables``) and ``p.ngc`` there and runs
    ``rs274 -g``; up to twice more after a failure, a second apart: the program is
    deterministic, so a refusal repeats, while a one-off does not (rs274 exited with no
    output, or by SIGBUS, beside the LinuxCNC sims of a full make test).

    Parameters
    ----------
    folder : Path
        Working folder.
    text : str
        Program text.
    variables : str
        The parameter file's lines (``5220`` the coordinate system; ``5221..`` G54's
        offsets [inch]).

    Returns
    -------
    str
        ``out.txt``, one canonical command per line.
    """
    assert RS274 is not None
    (folder / "tool.tbl").write_text("T1 P1 Z0 D0 ;unused\n")
    (folder / "rs274ngc.var").write_text(variables)
    (folder / "p.ngc").write_text(text)
    tries: list[str] = []
    for attempt in range(3):
        if attempt:
            time.sleep(1.0)
        r = subprocess.run([RS274, "-g", "-t", str(folder / "tool.tbl"), "-v",
                            str(folder / "rs274ngc.var"), str(folder / "p.ngc"),
                            str(folder / "out.txt")],
                           stdin=subprocess.DEVNULL, capture_output=True, text=True,
                           timeout=scaled_timeout(120))
        out = (folder / "out.txt").read_text() if (folder / "out.txt").is_file() else ""
        if r.returncode == 0:
            return out
        tries.append(f"exit {r.returncode}: {r.stdout[-500:]}{r.stderr}{out[-500:]}")
    raise AssertionError("rs274 refused the program: " + " | ".join(tries))


def run_rs274(text: str, strip_fanuc: bool = False, axes: int = 3
              ) -> list[tuple[str, list[float]]]:
    """Run LinuxCNC's interpreter on a program; return its canonical commands.

    Parameters
    ----------
    text : str
        Program text.
    strip_fanuc : bool
        Remove the ``%`` lines and the ``O`` number line of a Fanuc program (an O word is a
        subroutine label in LinuxCNC); every other block is given as written.
    axes : int
        Coordinates kept of each move: 3 (x, y, z) or 6 (with a, b, c [deg]).

    Returns
    -------
    list of (name, numbers)
        ``STRAIGHT_TRAVERSE``, ``STRAIGHT_FEED`` (x, y, z [mm] in work coordinates),
        ``DWELL`` (seconds), ``PROGRAM_STOP``, ``MESSAGE``, ``PROGRAM_END``, in order.
    """
    assert RS274 is not None
    if strip_fanuc:
        text = "\n".join(ln for ln in text.splitlines()
                         if ln.strip() != "%" and not re.match(r"O\d+", ln)) + "\n"
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        out = rs274_output(d, text, "5220\t1.000000\n" + "".join(
            f"{5221 + k}\t{v:.6f}\n" for k, v in enumerate(WORK_OFFSET_INCH)))
    cmds = []
    for line in out.splitlines():
        m = CANON.match(line)
        if not m or m.group(1) not in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "DWELL",
                                       "PROGRAM_STOP", "MESSAGE", "PROGRAM_END"):
            continue
        nums = ([] if m.group(1) == "MESSAGE"
                else [float(x) for x in m.group(2).split(",") if x.strip()])
        cmds.append((m.group(1), nums[:axes] if "STRAIGHT" in m.group(1) else nums))
    return cmds


def replay_rs274(text: str, strip_fanuc: bool = False):
    """Dwell poses, dwell seconds and move targets as rs274 executes the program."""
    dwells, secs, moves = [], [], []
    pos = [np.nan] * 3
    for name, v in run_rs274(text, strip_fanuc):
        if name.startswith("STRAIGHT"):
            pos = v
            moves.append(v)
        elif name == "DWELL":
            dwells.append(pos)
            secs.append(v[0])
    return np.array(dwells), np.array(secs), np.array(moves)


_SIE_MOVE = re.compile(r"^G0?1((?:\s+[XYZ]-?\d+(?:\.\d*)?)+)(?:\s+F(\d+(?:\.\d*)?))?$")
_SIE_RETRACT = re.compile(r"^G0\s+SUPA\s+Z-?\d+(?:\.\d*)?$")
_SIE_DWELL = re.compile(r"^G4\s+F(\d+(?:\.\d*)?)$")
_SIE_MSG = re.compile(r'^MSG\("[^"]*"\)$|^MSG\(\)$')


def replay_siemens(text: str):
    """Replay a SINUMERIK program: G1 moves with X/Y/Z words, G4 F dwells [s]."""
    EVENTS.clear()
    pos = {"X": np.nan, "Y": np.nan, "Z": np.nan}
    dwells, secs, moves = [], [], []
    header = False
    for raw in text.splitlines():
        line = raw.split(";", 1)[0].strip()
        if not line:
            continue
        if line == "G71 G90 G94 G17 G40 G54 D0":
            header = True
            continue
        assert header, "metric, absolute, G54, no tool offset before any motion"
        if m := _SIE_MOVE.match(line):
            for w in m.group(1).split():
                pos[w[0]] = float(w[1:])
            moves.append([pos["X"], pos["Y"], pos["Z"]])
            EVENTS.append("move")
        elif _SIE_RETRACT.match(line):
            pos = {"X": np.nan, "Y": np.nan, "Z": np.nan}  # machine coordinates
            moves.append([np.nan] * 3)
            EVENTS.append("retract")
        elif m := _SIE_DWELL.match(line):
            dwells.append([pos["X"], pos["Y"], pos["Z"]])
            secs.append(float(m.group(1)))
            EVENTS.append("dwell")
        elif line == "M0":
            EVENTS.append("stop")
        elif _SIE_MSG.match(line):
            continue
        elif line == "M30":
            EVENTS.append("end")
        else:
            raise AssertionError(f"unexpected Siemens block {line!r}")
    assert EVENTS[-1] == "end"
    return np.array(dwells), np.array(secs), np.array(moves)


_HH_NUM = r"[+-]\d+(?:\.\d*)?"
_HH_MOVE = re.compile(rf"^L((?:\s+[XYZ]{_HH_NUM})+)\s+R0\s+F(\d+(?:\.\d*)?)$")
_HH_RETRACT = re.compile(rf"^L\s+Z{_HH_NUM}\s+R0\s+FMAX\s+M91$")
_HH_BLK1 = re.compile(rf"^BLK FORM 0\.1 Z X({_HH_NUM}) Y({_HH_NUM}) Z({_HH_NUM})$")
_HH_BLK2 = re.compile(rf"^BLK FORM 0\.2 X({_HH_NUM}) Y({_HH_NUM}) Z({_HH_NUM})$")


def replay_heidenhain(text: str):
    """Replay a Klartext program: numbered blocks, L moves, cycle 9 dwell [s]."""
    EVENTS.clear()
    pos = {"X": np.nan, "Y": np.nan, "Z": np.nan}
    dwells, secs, moves = [], [], []
    pending = False
    tool = False
    lines = text.splitlines()
    assert re.fullmatch(r"0 BEGIN PGM \w+ MM", lines[0])
    b1, b2 = _HH_BLK1.match(lines[1].split(" ", 1)[1]), _HH_BLK2.match(lines[2].split(" ", 1)[1])
    assert b1 and b2, "BLK FORM 0.1 and 0.2 follow BEGIN PGM"
    assert all(float(lo) < float(hi) for lo, hi in zip(b1.groups(), b2.groups(), strict=True))
    for n, raw in enumerate(lines):
        num, _, line = raw.partition(" ")
        assert int(num) == n, "blocks are numbered 0, 1, 2..."
        line = line.strip()
        if line.startswith(";") or n in (0, 1, 2):
            continue
        if line.startswith("END PGM"):
            assert n == len(lines) - 1 and line == lines[0].split(" ", 1)[1].replace("BEGIN",
                                                                                      "END")
            EVENTS.append("end")
            continue
        if line == "TOOL CALL 0 Z":
            tool = True
            continue
        assert tool, "TOOL CALL before any motion"
        if m := _HH_MOVE.match(line):
            for w in m.group(1).split():
                pos[w[0]] = float(w[1:])
            moves.append([pos["X"], pos["Y"], pos["Z"]])
            EVENTS.append("move")
        elif _HH_RETRACT.match(line):
            pos = {"X": np.nan, "Y": np.nan, "Z": np.nan}  # M91: machine datum
            moves.append([np.nan] * 3)
            EVENTS.append("retract")
        elif line == "CYCL DEF 9.0 DWELL TIME":
            pending = True
        elif line.startswith("CYCL DEF 9.1 DWELL "):
            assert pending
            pending = False
            dwells.append([pos["X"], pos["Y"], pos["Z"]])
            secs.append(float(line.rsplit(" ", 1)[1]))
            EVENTS.append("dwell")
        elif line == "STOP":
            EVENTS.append("stop")
        else:
            raise AssertionError(f"unexpected Heidenhain block {line!r}")
    assert EVENTS[-1] == "end"
    return np.array(dwells), np.array(secs), np.array(moves)


def replay_linuxcnc(text: str):
    """LinuxCNC programs are replayed by LinuxCNC's interpreter (work coordinates)."""
    return replay_rs274(text)


REPLAY = {"fanuc": replay_fanuc, "linuxcnc": replay_linuxcnc, "siemens": replay_siemens,
          "heidenhain": replay_heidenhain}
