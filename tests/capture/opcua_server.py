"""The independent OPC UA server of the capture tests: node-opcua with the OPC 40502 nodeset.

``tests/opcua/cnc_server.mjs`` (run by Node.js) loads the official CNC nodeset
(``Opc.Ua.CNC.NodeSet.xml`` from npm ``node-opcua-nodesets``), instantiates three
``CncAxisType`` axes X, Y, Z and writes their ``PosDirect/ActPos`` when told on its standard
input. ``make opcua-deps`` installs the npm packages into ``tests/opcua/node_modules``; the
tests skip, with the reason, where Node.js or the packages are missing.
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

    def __init__(self, port: int | None = None, pki: Path | None = None) -> None:
        """``pki``: serve signed and encrypted channels only, certificates in that folder."""
        self.port = free_port() if port is None else port
        self.url = f"opc.tcp://127.0.0.1:{self.port}/"
        secure = [] if pki is None else ["secure", str(pki)]
        self.proc = subprocess.Popen(
            ["node", str(SCRIPT), str(self.port), *secure], cwd=HERE, stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, bufsize=1)
        self.lines: list[str] = []
        self._cond = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()
        self._wait(lambda: any(x.startswith("READY") for x in self.lines), 60.0, "start")
        self.served = 0

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
        """Write ``ActPos`` of the named axes [mm]; returns once the server applied it."""
        assert self.proc.stdin is not None
        self.served += 1
        n = self.served
        self.proc.stdin.write(json.dumps({"set": axes}) + "\n")
        self.proc.stdin.flush()
        self._wait(lambda: f"OK {n}" in self.lines, 10.0, "apply a position")

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
