"""The LinuxCNC bridge rides out a status channel that fails while LinuxCNC starts.

LinuxCNC's ``linuxcnc.stat().poll()`` raised ``SystemError`` ("returned NULL without
setting an exception") in the first tenth of a second of a capture on a loaded box, and
the bridge died with it: the capture ended "disconnected" before its first reading
(``tests/capture/test_linuxcnc_capture.py`` on a fresh machine, session 16). The bridge
now treats it as LinuxCNC not being up yet, waits and connects again. Here a stand-in
``linuxcnc`` module (its status fails twice with ``SystemError``, then with
``linuxcnc.error`` and ``SystemError`` in the loop) is put before the real one on the bridge's path.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from volcal.capture.linuxcnc_source import BRIDGE

FAKE = '''
import os
error = type("error", (Exception,), {})
MODE_AUTO, INTERP_READING, INTERP_WAITING, INTERP_PAUSED = 2, 2, 3, 4
_count = [0]
FAIL = {1: SystemError, 2: SystemError, 5: error, 6: SystemError}


class stat:
    axis_mask = 7
    actual_position = (1.0, 2.0, 3.0, 0, 0, 0, 0, 0, 0)
    g5x_offset = g92_offset = tool_offset = (0.0,) * 9
    joint_actual_position = (1.0, 2.0, 3.0)
    joints = 3
    task_paused = 0
    interp_state = 1
    inpos = True
    current_vel = 0.0
    motion_line = 0
    task_mode = 1
    task_state = 4
    ini_filename = os.environ["FAKE_INI"]

    def poll(self):
        _count[0] += 1
        e = FAIL.get(_count[0])
        if e is not None:
            raise e() if e is error else e("<method 'poll' of 'linuxcnc.stat' objects> "
                                           "returned NULL without setting an exception")
'''


def test_a_status_channel_failing_at_the_start_is_waited_out(tmp_path: Path) -> None:
    (tmp_path / "linuxcnc.py").write_text(FAKE)
    ini = tmp_path / "sim.ini"
    ini.write_text("")
    env = dict(os.environ, PYTHONPATH=str(tmp_path), FAKE_INI=str(ini))
    p = subprocess.Popen([sys.executable, str(BRIDGE), "--period", "0.01", "--ini", str(ini),
                          "--wait", "5", "--lost", "5"], stdout=subprocess.PIPE, text=True,
                         env=env)
    lines = []
    try:
        assert p.stdout is not None
        for line in p.stdout:
            lines.append(json.loads(line))
            if sum("pos" in x for x in lines) >= 3:
                break
    finally:
        p.kill()
        p.wait()
    kinds = ["pos" if "pos" in x else next(iter(x)) for x in lines]
    assert "error" not in kinds, lines
    # polls 1-2 (connecting) fail: two waits; 3 connects, 4 reads; 5 (reading) and 6
    # (connecting again) fail: a wait; 7 connects, 8 and on read
    assert kinds[:2] == ["waiting", "waiting"], lines
    assert "SystemError" in lines[0]["waiting"] or "NULL" in lines[0]["waiting"]
    assert kinds[2] == "pos" and lines[2]["pos"] == {"X": 1.0, "Y": 2.0, "Z": 3.0}
    assert kinds[3] == "waiting" and kinds[4:] == ["pos", "pos"], lines
