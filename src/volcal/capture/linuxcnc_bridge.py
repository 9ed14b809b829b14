#!/usr/bin/python3
"""LinuxCNC status bridge: poll ``linuxcnc.stat()`` and write one JSON line per poll.

Run by Debian's system Python (``/usr/bin/python3``), the only interpreter LinuxCNC's
``linuxcnc`` module is built for; volcal's own interpreter starts it as a subprocess and
reads its standard output (:mod:`volcal.capture.linuxcnc`). It only reads the status
channel: it never sends a command to the machine. Standard library and ``linuxcnc`` only
(volcal is not importable here).

Usage: ``/usr/bin/python3 linuxcnc_bridge.py [--period S] [--nml FILE] [--ini FILE]
[--wait S] [--lost S]``. With ``--ini``, only a LinuxCNC started with that INI file is
read (``stat.ini_filename``): another machine configuration on the same PC is waited out.

Each line is a JSON object:

* ``{"t": s, "pos": {"X": mm, ...}, "machine": {...}, "joints": [...], "interp": n,
  "paused": bool, "inpos": bool, "vel": mm/s, "line": n, "mode": n, "state": n,
  "moving": bool, "running": bool}``: ``t`` the bridge's monotonic clock [s]; ``pos``
  the actual position in the program's coordinates (``actual_position`` minus the
  active G5x and G92 offsets and the tool offset), ``machine`` in machine coordinates,
  ``joints`` ``joint_actual_position``; ``moving`` is ``current_vel > 0`` or not
  ``inpos``; ``running`` is a program executing in auto mode and not paused (an
  ``M0`` stop or a feed hold reads false);
* ``{"waiting": text}``: LinuxCNC is not running yet (up to ``--wait`` seconds at the
  start), or its status channel failed and the bridge connects again (up to ``--lost``
  seconds);
* ``{"error": text}``: LinuxCNC did not come (back) in time; the bridge exits with
  status 1.
"""

import argparse
import json
import os
import sys
import time

# this script's folder is volcal's package folder: never take one of its modules for
# LinuxCNC's own (the first entry of the path is the script's folder)
sys.path[:] = [p for p in sys.path
               if os.path.abspath(p or ".") != os.path.dirname(os.path.abspath(__file__))]


def main():
    """Poll the status channel and write JSON lines until killed."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--period", type=float, default=0.02)
    ap.add_argument("--nml", default=None)
    ap.add_argument("--wait", type=float, default=600.0)
    ap.add_argument("--lost", type=float, default=30.0)
    ap.add_argument("--ini", default=None)
    a = ap.parse_args()
    out = sys.stdout

    def emit(obj):
        out.write(json.dumps(obj, separators=(",", ":")) + "\n")
        out.flush()

    try:
        import linuxcnc  # type: ignore[import-not-found]  # Debian's, system Python only
    except ImportError as e:
        emit({"error": f"the linuxcnc module does not import: {e}"})
        return 1
    if a.nml:
        linuxcnc.nmlfile = a.nml
    def ours(st):
        """The LinuxCNC running is the one of ``--ini`` (when given)."""
        return a.ini is None or os.path.realpath(st.ini_filename) == os.path.realpath(a.ini)

    def connect(wait_s):
        """A polled status object; None (after an error line) when none came in time."""
        deadline = time.monotonic() + wait_s
        while True:
            try:
                st = linuxcnc.stat()
                st.poll()
                if ours(st):
                    return st
                why = f"the LinuxCNC running is another one's ({st.ini_filename})"
            except (linuxcnc.error, SystemError) as e:
                # SystemError: poll() of a status channel LinuxCNC is still setting up (or
                # tearing down) "returned NULL without setting an exception"
                why = str(e) or type(e).__name__
            if time.monotonic() > deadline:
                emit({"error": f"LinuxCNC is not running: {why}"})
                return None
            emit({"waiting": why})
            time.sleep(0.2)

    s = connect(a.wait)
    if s is None:
        return 1
    letters = "XYZABCUVW"
    auto, running_states = linuxcnc.MODE_AUTO, (linuxcnc.INTERP_READING,
                                                 linuxcnc.INTERP_WAITING)
    while True:
        try:
            s.poll()
            lost = not ours(s)
        except (linuxcnc.error, SystemError):  # SystemError: see connect
            lost = True
        if lost:  # LinuxCNC starting, restarting or replaced: connect again
            s = connect(a.lost)
            if s is None:
                return 1
            continue
        mask = s.axis_mask
        act, g5x, g92, tool = s.actual_position, s.g5x_offset, s.g92_offset, s.tool_offset
        pos, machine = {}, {}
        for k, name in enumerate(letters):
            if mask & (1 << k):
                machine[name] = act[k]
                pos[name] = act[k] - g5x[k] - g92[k] - tool[k]
        if not pos:  # LinuxCNC up, its status not filled yet
            emit({"waiting": "no axis in the status yet"})
            time.sleep(max(a.period, 0.2))
            continue
        paused = bool(s.task_paused) or s.interp_state == linuxcnc.INTERP_PAUSED
        emit({"t": time.monotonic(), "pos": pos, "machine": machine,
              "joints": list(s.joint_actual_position[:s.joints]),
              "interp": s.interp_state, "paused": paused, "inpos": bool(s.inpos),
              "vel": s.current_vel, "line": s.motion_line, "mode": s.task_mode,
              "state": s.task_state,
              "moving": bool(s.current_vel > 1e-9 or not s.inpos),
              "running": bool(s.task_mode == auto and s.interp_state in running_states
                              and not paused)})
        time.sleep(a.period)


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (BrokenPipeError, KeyboardInterrupt):
        sys.exit(0)
