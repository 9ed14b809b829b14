#!/usr/bin/python3
"""LinuxCNC status bridge: poll ``linuxcnc.stat()`` and write one JSON line per poll.

Run by Debian's system Python (``/usr/bin/python3``), the only interpreter LinuxCNC's
``linuxcnc`` module is built for; volcal's own interpreter starts it as a subprocess and
reads its standard output (:mod:`volcal.capture.linuxcnc`). It only reads the status
channel: it never sends a command to the machine. Standard library and ``linuxcnc`` only
(volcal is not importable here).

Usage: ``/usr/bin/python3 linuxcnc_bridge.py [--period S] [--nml FILE] [--wait S]``

Each line is a JSON object:

* ``{"t": s, "pos": {"X": mm, ...}, "machine": {...}, "joints": [...], "interp": n,
  "paused": bool, "inpos": bool, "vel": mm/s, "line": n, "mode": n, "state": n,
  "moving": bool, "running": bool}``: ``t`` the bridge's monotonic clock [s]; ``pos``
  the actual position in the program's coordinates (``actual_position`` minus the
  active G5x and G92 offsets and the tool offset), ``machine`` in machine coordinates,
  ``joints`` ``joint_actual_position``; ``moving`` is ``current_vel > 0`` or not
  ``inpos``; ``running`` is a program executing in auto mode and not paused (an
  ``M0`` stop or a feed hold reads false);
* ``{"waiting": text}``: LinuxCNC is not running yet (once a second, up to ``--wait``);
* ``{"error": text}``: the status channel failed; the bridge exits with status 1.
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
    deadline = time.monotonic() + a.wait
    s = None
    while s is None:
        try:
            s = linuxcnc.stat()
            s.poll()
        except linuxcnc.error as e:
            s = None
            if time.monotonic() > deadline:
                emit({"error": f"LinuxCNC is not running: {e}"})
                return 1
            emit({"waiting": str(e)})
            time.sleep(1.0)
    letters = "XYZABCUVW"
    auto, running_states = linuxcnc.MODE_AUTO, (linuxcnc.INTERP_READING,
                                                 linuxcnc.INTERP_WAITING)
    while True:
        try:
            s.poll()
        except linuxcnc.error as e:
            emit({"error": f"status poll failed: {e}"})
            return 1
        mask = s.axis_mask
        act, g5x, g92, tool = s.actual_position, s.g5x_offset, s.g92_offset, s.tool_offset
        pos, machine = {}, {}
        for k, name in enumerate(letters):
            if mask & (1 << k):
                machine[name] = act[k]
                pos[name] = act[k] - g5x[k] - g92[k] - tool[k]
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
