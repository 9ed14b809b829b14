"""The independent OPC UA server of the capture tests: node-opcua with the OPC 40502 nodeset.

``tests/opcua/cnc_server.mjs`` (run by Node.js) loads the official CNC nodeset
(``Opc.Ua.CNC.NodeSet.xml`` from npm ``node-opcua-nodesets``), instantiates three
``CncAxisType`` axes X, Y, Z (or those asked: a rotary axis ``C:deg`` too, ``IsRotational``
true and its positions' ``EngineeringUnits`` degree) and writes their ``PosDirect/ActPos``
when told on its standard input. ``make opcua-deps`` installs the npm packages into
``tests/opcua/node_modules``; the tests skip, with the reason, where Node.js or the
packages are missing.
"""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest

from timing import scaled_timeout

HERE = Path(__file__).resolve().parent.parent / "opcua"
SCRIPT = HERE / "cnc_server.mjs"
NODESET = HERE / "node_modules" / "node-opcua-nodesets" / "nodesets" / "Opc.Ua.CNC.NodeSet.xml"


def skip_reason() -> str | None:
    """Why the server cannot run here (None: it can)."""
    if shutil.which("node") is None:
        return "node (Node.js) is not installed: make opcua-deps installs it"
    if not (HERE / "node_modules" / "node-opcua").is_dir():
        return "npm node-opcua is not installed in tests/opcua: run make opcua-deps"
    if not NODESET.is_file():
        return f"the OPC 40502 nodeset is missing ({NODESET}): run make opcua-deps"
    return None


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class CncServer:
    """A running ``cnc_server.mjs``: ``set(X=..., ...)`` writes positions, ``stop()`` ends it."""

    def __init__(self, port: int | None = None, pki: Path | None = None,
                 axes: tuple[str, ...] | None = None, channel: bool = False,
                 channels: tuple[str, ...] = (), unreadable: bool = False) -> None:
        """``pki``: serve signed and encrypted channels only, certificates in that folder.
        ``axes``: the axes, ``NAME`` or ``NAME:UNIT`` (``mm``, ``deg``, ``rad``, ``rot``:
        cnc_server.mjs); default X, Y, Z. ``channel``: a CncChannelType object whose
        ``ActProgramStatus`` :meth:`program` writes (Stopped at the start); ``channels``:
        several, by name; ``unreadable``: their status without read access."""
        self.port = free_port() if port is None else port
        self.url = f"opc.tcp://127.0.0.1:{self.port}/"
        args = [] if pki is None else ["secure", str(pki)]
        if axes is not None:
            args.append("axes=" + ",".join(axes))
        if channel:
            args.append("channel")
        if channels:
            args.append("channels=" + ",".join(channels))
        if unreadable:
            args.append("unreadable")
        self.proc = subprocess.Popen(
            ["node", str(SCRIPT), str(self.port), *args], cwd=HERE, stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, bufsize=1)
        self.lines: list[str] = []
        self._cond = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()
        self._wait(lambda: any(x.startswith("READY") for x in self.lines), 60.0, "start")

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            with self._cond:
                self.lines.append(line.strip())
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def _wait(self, pred, nominal_s: float, what: str) -> None:
        deadline = time.monotonic() + scaled_timeout(nominal_s)
        with self._cond:
            while not pred():
                if self.proc.poll() is not None:
                    err = self.proc.stderr.read() if self.proc.stderr else ""
                    raise RuntimeError(f"the OPC UA test server died ({what}): {err[-2000:]}")
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"the OPC UA test server did not {what}: {self.lines}")
                self._cond.wait(min(left, 0.5))

    def set(self, **axes: float) -> None:
        """Write ``ActPos`` of the named axes [mm, deg]; returns once the server applied it."""
        self._command({"set": axes}, "apply a position")

    def program(self, status: int, channel: str | None = None) -> None:
        """Write a channel's ``ActProgramStatus`` (0 Stopped, 1 Running, 3 Interrupted);
        default the first channel."""
        cmd: dict = {"program": int(status)}
        if channel is not None:
            cmd["channel"] = channel
        self._command(cmd, "apply a program status")

    def add(self, *axes: str) -> None:
        """Instantiate axes, ``NAME`` or ``NAME:UNIT`` (as ``axes`` of the constructor)."""
        self._command({"add": list(axes)}, "add axes")

    def remove(self, *names: str) -> None:
        """Delete the named axes from the address space."""
        self._command({"remove": list(names)}, "remove axes")

    def _command(self, cmd: dict, what: str) -> None:
        """Send one command; wait for its ``OK n`` (an ``ERROR`` answer raises)."""
        assert self.proc.stdin is not None
        with self._cond:
            start = len(self.lines)
        self.proc.stdin.write(json.dumps(cmd) + "\n")
        self.proc.stdin.flush()
        self._wait(lambda: any(x.startswith(("OK ", "ERROR")) for x in self.lines[start:]),
                   10.0, what)
        answer = next(x for x in self.lines[start:] if x.startswith(("OK ", "ERROR")))
        if not answer.startswith("OK "):
            raise RuntimeError(f"the OPC UA test server refused {cmd}: {answer}")

    def stop(self) -> None:
        """Shut the server down (the client sees the connection drop)."""
        if self.proc.poll() is None:
            try:
                assert self.proc.stdin is not None
                self.proc.stdin.write('{"quit": true}\n')
                self.proc.stdin.flush()
                self.proc.wait(timeout=scaled_timeout(10.0))
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()


@pytest.fixture(scope="module")
def cnc_server():
    """One server for the module's tests (it takes a few seconds to load the nodesets)."""
    why = skip_reason()
    if why:
        pytest.skip(why)
    server = CncServer()
    try:
        yield server
    finally:
        server.stop()
