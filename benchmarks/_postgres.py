"""A throw-away PostgreSQL server for the history benchmarks (as tests/conftest.py's).

Debian's ``initdb`` and ``pg_ctl`` (``make postgres-deps``), run as the unprivileged
``postgres`` user when the benchmark runs as root, on a free port of 127.0.0.1 with
``fsync=off``; stopped and removed on exit. ``None`` where PostgreSQL is not installed.
"""

from __future__ import annotations

import contextlib
import glob
import os
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path


def _as_postgres(cmd: list[str]) -> list[str]:
    return cmd if os.geteuid() != 0 else ["runuser", "-u", "postgres", "--", *cmd]


@contextlib.contextmanager
def server() -> Iterator[str | None]:
    """URL prefix ``postgresql://postgres@127.0.0.1:PORT`` of a running server, or None."""
    bins = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
    if not bins:
        yield None
        return
    bindir = Path(bins[-1]).parent
    tmp = Path(tempfile.mkdtemp(prefix="volcal-bench-pg-"))
    data, sock = tmp / "data", tmp / "sock"
    sock.mkdir()
    if os.geteuid() == 0:
        import pwd

        pw = pwd.getpwnam("postgres")
        os.chown(tmp, pw.pw_uid, pw.pw_gid)
        os.chown(sock, pw.pw_uid, pw.pw_gid)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "LC_ALL": "C.UTF-8"}
    subprocess.run(_as_postgres([str(bindir / "initdb"), "-D", str(data), "-A", "trust",
                                 "-U", "postgres", "-E", "UTF8"]), check=True, env=env,
                   capture_output=True)
    subprocess.run(_as_postgres([str(bindir / "pg_ctl"), "-D", str(data), "-l",
                                 str(tmp / "server.log"), "-w", "-o",
                                 f"-p {port} -k {sock} -c listen_addresses=127.0.0.1 "
                                 "-c fsync=off", "start"]),
                   check=True, env=env, capture_output=True)
    try:
        yield f"postgresql://postgres@127.0.0.1:{port}"
    finally:
        subprocess.run(_as_postgres([str(bindir / "pg_ctl"), "-D", str(data), "-m",
                                     "immediate", "stop"]), env=env, capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)


def new_database(prefix: str, name: str) -> str:
    """A new, empty database ``name`` on the server; its URL."""
    import psycopg

    with psycopg.connect(f"{prefix}/postgres", autocommit=True) as conn:
        conn.execute(f"CREATE DATABASE {name}")
    return f"{prefix}/{name}"
