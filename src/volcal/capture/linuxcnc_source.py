"""The LinuxCNC control source: ``--control linuxcnc[:INI][;period=S]``.

LinuxCNC's Python interface (the ``linuxcnc`` module: ``linuxcnc.stat()``, the status
channel) is built by Debian for the system Python (``/usr/bin/python3``, 3.11.2 on
Debian 12) and imports in no other interpreter, volcal's virtual environment included.
volcal therefore reaches it through a bridge: this source starts
``/usr/bin/python3 volcal/capture/linuxcnc_bridge.py`` (a standalone script of the
package, standard library only), which polls ``linuxcnc.stat()`` every ``period``
seconds and writes one JSON line per poll (the actual position, ``joint_actual_position``,
``interp_state``, ``task_paused``, ``inpos``, ``current_vel``, ``motion_line``); a reader
thread turns each line into a :class:`~volcal.capture.samples.ControlSample`. The bridge
only reads the status: volcal never commands the machine.

* ``linuxcnc`` reads the LinuxCNC running (its default NML file);
  ``linuxcnc:/path/machine.ini`` reads only a LinuxCNC started with that INI file
  (``stat.ini_filename``; another configuration running is waited out) and uses the
  ``[EMC] NML_FILE`` the INI file names, if any.
* The interpreter is ``/usr/bin/python3``, or the environment variable
  ``VOLCAL_LINUXCNC_PYTHON``.
* The positions are those of the program (actual position minus the G5x, G92 and tool
  offsets), as volcal's programs command them; ``in_motion`` is LinuxCNC's ``current_vel
  > 0`` or not ``inpos``; ``program_running`` is a program executing in auto mode and not
  paused (``M0``, feed hold).
* Started before LinuxCNC, the bridge waits for it (up to 10 minutes).
"""

from __future__ import annotations

import configparser
import contextlib
import json
import os
import queue
import subprocess
import threading
from collections import deque
from pathlib import Path

from volcal.capture.samples import ControlSample
from volcal.capture.sources import (
    SourceContext,
    SourceError,
    SourceSpec,
    options,
    register_control,
)
from volcal.errors import VolcalInputError

__all__ = ["BRIDGE", "LinuxCNCControl", "system_python"]

BRIDGE = Path(__file__).with_name("linuxcnc_bridge.py")
"""The bridge script, run by the system Python."""


def system_python() -> str:
    """The interpreter of LinuxCNC's Python modules.

    Returns
    -------
    str
        ``VOLCAL_LINUXCNC_PYTHON``, else ``/usr/bin/python3``.
    """
    return os.environ.get("VOLCAL_LINUXCNC_PYTHON", "/usr/bin/python3")


def _nml_of(ini: Path, where: str) -> str | None:
    cp = configparser.ConfigParser(strict=False, interpolation=None, inline_comment_prefixes=("#",))
    try:
        cp.read_string(ini.read_text(encoding="utf-8", errors="replace"))
    except (OSError, configparser.Error) as e:
        raise VolcalInputError(f"source {where!r}: cannot read the INI file ({e})", ini) \
            from None
    nml = cp.get("EMC", "NML_FILE", fallback=None)
    if nml is None:
        return None
    p = Path(nml.strip())
    return str(p if p.is_absolute() else ini.parent / p)


class LinuxCNCControl:
    """The ``linuxcnc`` control source (see the module's docstring)."""

    def __init__(self, spec: SourceSpec, ctx: SourceContext) -> None:
        ini, _, rest = spec.argument.partition(";")
        opts = options(rest, spec.text, ("period",))
        try:
            self.period = float(opts.get("period", "0.02"))
        except ValueError:
            self.period = 0.0
        if not 0.001 <= self.period <= 1.0:
            raise VolcalInputError(f"source {spec.text!r}: period={opts.get('period')!r}: "
                                   "expected 0.001 to 1 s")
        self.ini = str(Path(ini.strip()).resolve()) if ini.strip() else None
        self.nml = _nml_of(Path(ini), spec.text) if ini.strip() else None
        self.where, self.ctx = spec.text, ctx
        self._q: queue.Queue[ControlSample] = queue.Queue()
        self._proc: subprocess.Popen[bytes] | None = None
        self._thread: threading.Thread | None = None
        self._error: str | None = None
        self._stderr: deque[str] = deque(maxlen=20)
        self.waiting: str | None = None

    def open(self) -> None:
        """Start the bridge."""
        py = system_python()
        if not Path(py).exists():
            raise SourceError(f"control {self.where!r}: {py} (the system Python LinuxCNC's "
                              "module is built for) is missing; set VOLCAL_LINUXCNC_PYTHON")
        cmd = [py, str(BRIDGE), "--period", repr(self.period)]
        if self.nml:
            cmd += ["--nml", self.nml]
        if self.ini:
            cmd += ["--ini", self.ini]
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
        self._proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      stdin=subprocess.DEVNULL, env=env)
        self._thread = threading.Thread(target=self._read, daemon=True,
                                        name="volcal-linuxcnc-bridge")
        self._thread.start()
        threading.Thread(target=self._read_stderr, daemon=True).start()

    def _read_stderr(self) -> None:
        assert self._proc is not None and self._proc.stderr is not None
        for raw in self._proc.stderr:
            self._stderr.append(raw.decode("utf-8", "replace").rstrip())

    def _read(self) -> None:
        assert self._proc is not None and self._proc.stdout is not None
        for raw in self._proc.stdout:
            try:
                obj = json.loads(raw)
            except json.JSONDecodeError:
                continue
            if "error" in obj:
                self._error = str(obj["error"])
                continue
            if "waiting" in obj:
                self.waiting = str(obj["waiting"])
                continue
            self.waiting = None
            self._q.put(ControlSample(
                self.ctx.clock.now(), {k: float(v) for k, v in obj["pos"].items()},
                in_motion=bool(obj["moving"]), program_running=bool(obj["running"]),
                line=int(obj.get("line", 0)), device_time_s=float(obj["t"])))
        if self._error is None:
            self._error = "the bridge stopped" + (
                f": {self._stderr[-1]}" if self._stderr else "")

    def poll(self) -> ControlSample | None:
        """The next status received, or None."""
        try:
            return self._q.get_nowait()
        except queue.Empty:
            pass
        if self._thread is not None and not self._thread.is_alive() and self._error:
            raise SourceError(f"control {self.where!r}: {self._error}")
        return None

    def close(self) -> None:
        """Stop the bridge."""
        p, self._proc = self._proc, None
        if p is not None and p.poll() is None:
            p.terminate()
            with contextlib.suppress(subprocess.TimeoutExpired):
                p.wait(5)
            if p.poll() is None:
                p.kill()
                p.wait()


register_control("linuxcnc", LinuxCNCControl,
                 "LinuxCNC's status channel, through a bridge run by the system Python")

