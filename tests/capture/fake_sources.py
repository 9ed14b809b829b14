"""What the capture tests share: sources that play a control or a laser lacking something,
the readings a journal holds as accepted, and a capture process killed midway."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any


class Wrapped:
    """A simulated source (``wraps``: ``'control'`` or ``'laser'``) whose samples
    :meth:`alter` may change or withhold; opened and closed as the simulated one."""

    wraps = "laser"

    def __init__(self, spec, ctx):
        from volcal.capture.simulated import SimulatedControl, SimulatedLaser

        self.inner = (SimulatedControl if self.wraps == "control" else SimulatedLaser)(spec, ctx)
        self.ctx = ctx

    def open(self):
        self.inner.open()

    def close(self):
        self.inner.close()

    def poll(self):
        s = self.inner.poll()
        return None if s is None else self.alter(s)

    def alter(self, s: Any) -> Any:
        """The sample as this source gives it (None: withheld)."""
        return s


class NoRotary(Wrapped):
    """The simulated control reporting the linear axes only (as an OPC UA server might)."""

    wraps = "control"

    def alter(self, s):
        return replace(s, positions={a: v for a, v in s.positions.items() if a in "XYZ"})


def accepted(journal: Path) -> list[int]:
    """The readings a capture journal records as accepted, in its order (a line being
    written is skipped)."""
    if not journal.is_file():
        return []
    out = []
    for line in journal.read_bytes().splitlines():
        try:
            x = json.loads(line)
        except json.JSONDecodeError:
            continue  # the line being written
        if x.get("type") == "accepted":
            out.append(x["reading"])
    return out


def kill_capture_after(args: list[str], journal: Path, n: int) -> list[int]:
    """Run ``volcal capture ARGS`` as a process of its own and SIGKILL it (no handler
    runs) once ``journal`` holds ``n`` accepted readings; the accepted readings then."""
    import os
    import signal
    import subprocess
    import sys
    import time

    from timing import scaled_timeout

    cmd = [sys.executable, "-c", "from volcal.cli import main; main()", "capture", *args]
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + scaled_timeout(120)
    try:
        while len(accepted(journal)) < n:
            assert p.poll() is None, p.stderr.read().decode() if p.stderr else ""
            assert time.monotonic() < deadline, "the capture did not accept readings"
            time.sleep(0.01)
        os.kill(p.pid, signal.SIGKILL)
    finally:
        p.wait(timeout=scaled_timeout(30))
    assert p.returncode == -signal.SIGKILL
    return accepted(journal)
